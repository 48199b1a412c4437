// southwell — Southwell relaxation as progressive shooting, written as an out-of-tree plugin.
//
// Method: every step shoots from the element with the largest unshot power residual,
//   A_i * sum_c |dB_c,i| (Southwell 1946; Gortler et al. 1993 identify progressive radiosity
//   with it). The shot of s_c = omega * dB_c,i adds rho_c,j F_ij (A_i / A_j) s_c to B_c,j and
//   dB_c,j for every j (j = i included, for a form-factor method with a self term F_ii), then
//   takes s_c off dB_c,i. Whatever is shot, x = B - dB then has the residual dB exactly (radlab's
//   docs/solvers.md, "Bookkeeping shared by the shooting family"), so the solution converges to
//   the system's fixed point as the unshot power goes to zero.
// Paper: R. V. Southwell, "Relaxation Methods in Theoretical Physics", 1946; S. J. Gortler,
//   M. F. Cohen, P. Slusallek, "Radiosity and Relaxation Methods", IEEE CG&A 14(6), 1994.
// Parameters: omega (relaxation factor in (0,2): 1 shoots all unshot radiosity, > 1 overshoots).
// Cost per step: a scan of the n unshot values (to select) plus one form-factor row.
// Left out: radlab's built-in sorted-shooting fuses the selection into the previous shot and has
//   AVX2 kernels; this plugin keeps the plain loops, as an example of the plugin interface.
//   One-level systems only (the elements shoot; --patches is refused).
#include <cmath>
#include <memory>

#include "core/error.h"
#include "core/text.h"
#include "solvers/plugin.h"

namespace {

using radlab::ParamBag;
using radlab::Radiosity;
using radlab::StepInfo;
using radlab::System;

struct SouthwellOptions {
  double omega = 1.0;

  // The registry reads the defaults from here (an empty bag): they are not typed anywhere else.
  static SouthwellOptions from(ParamBag& bag) {
    SouthwellOptions o;
    o.omega = bag.get_double("omega", o.omega);
    if (!(o.omega > 0.0 && o.omega < 2.0))
      throw radlab::UsageError("southwell: omega must lie in (0,2), got " +
                               radlab::text::format_double(o.omega));
    return o;
  }
};

class SouthwellSolver final : public radlab::Solver {
 public:
  explicit SouthwellSolver(SouthwellOptions options) : options_(options) {}

  void init(const System& system) override {
    if (system.two_level())
      throw radlab::UsageError("southwell: shoots elements; use a one-level system (no --patches)");
    system_ = &system;
    B_ = system.emission();
    dB_ = system.emission();
  }

  StepInfo step() override {
    const System& s = *system_;
    // Selection: the largest unshot power (ties: the lowest index, for determinism).
    size_t best = 0;
    double best_power = 0.0;
    for (size_t i = 0; i < s.size(); ++i) {
      double unshot = 0.0;
      for (int c = 0; c < dB_.channels(); ++c) unshot += std::abs(dB_.at(c, i));
      const double power = s.area()[i] * unshot;
      if (power > best_power) {
        best_power = power;
        best = i;
      }
    }
    if (best_power == 0.0) return {.finished = true};  // nothing left: B is the fixed point

    double shot[3] = {0.0, 0.0, 0.0};
    for (int c = 0; c < dB_.channels(); ++c) shot[c] = options_.omega * dB_.at(c, best);
    const double area_i = s.area()[best];
    s.with_row(best, [&](const auto* F) {
      for (size_t j = 0; j < s.size(); ++j) {
        if (F[j] == 0) continue;
        const double transfer = double(F[j]) * area_i * s.inverse_area()[j];
        for (int c = 0; c < dB_.channels(); ++c) {
          const double delta = s.reflectance().at(c, j) * transfer * shot[c];
          B_.at(c, j) += delta;
          dB_.at(c, j) += delta;
        }
      }
    });
    for (int c = 0; c < dB_.channels(); ++c) dB_.at(c, best) -= shot[c];
    return {};
  }

  const Radiosity& solution() const override { return B_; }
  const Radiosity* unshot() const override { return &dB_; }

 private:
  SouthwellOptions options_;
  const System* system_ = nullptr;
  Radiosity B_, dB_;
};

radlab::SolverInfo southwell_info() {
  radlab::SolverInfo info;
  info.name = "southwell";
  info.summary = "plugin example: shoot the largest unshot power residual (plain loops)";
  info.reference = "Southwell 1946; Gortler, Cohen & Slusallek 1994";
  info.cost = "a scan of n unshot values + one form-factor row";
  info.parameters = {{"omega", "", "relaxation factor in (0,2); 1 shoots all unshot radiosity"}};
  info.make = [](ParamBag& bag) -> std::unique_ptr<radlab::Solver> {
    return std::make_unique<SouthwellSolver>(SouthwellOptions::from(bag));
  };
  info.kind = radlab::SolverKind::kShooting;
  return info;
}

void register_southwell() {
  radlab::register_solver(southwell_info());
}

}  // namespace

RADLAB_PLUGIN(register_southwell)
