// gauss-seidel — gathering by Gauss–Seidel (successive over-relaxation with omega != 1).
//
// Method: visit elements in index order; each step gathers at one element i from the newest
//   estimates:  B_i <- (1-omega) B_i + omega (E_i + rho_i sum_{j != i} F_ij B_j) / (1 - rho_i
//   F_ii). Starting from B = E (below the solution) with omega <= 1 the iterates rise monotonically
//   to the solution (all terms are non-negative).
// Paper: the "traditional" radiosity solution of Cohen & Greenberg 1985, the "Gathering Only"
//   curve of Cohen et al. 1988 (Fig. 7); Gortler, Cohen & Slusallek 1994 for SOR.
// Parameters: omega (relaxation factor in (0,2); 1 is plain Gauss–Seidel); defaults:
//   `radlab solvers` (GaussSeidelOptions).
// Cost per step: one form-factor row (n multiply-adds per channel).
// Left out: per-element adaptive ordering (that is Southwell, i.e. sorted shooting's cousin).
#include <algorithm>
#include <cstdio>

#include "core/error.h"
#include "core/text.h"
#include "solvers/flat/gathering.h"
#include "solvers/kernels/kernels.h"

namespace radlab {
namespace {

struct GaussSeidelOptions {
  double omega = 1.0;  // > 1 over-relaxes: faster on stiff scenes, but loses monotonicity

  static GaussSeidelOptions from(ParamBag& bag) {
    GaussSeidelOptions o;
    o.omega = bag.get_double("omega", o.omega);
    o.validate();
    return o;
  }
  void validate() const {
    if (!(omega > 0.0 && omega < 2.0))
      throw UsageError("gauss-seidel: omega must lie in (0,2) for convergence, got " +
                       text::format_double(omega));
  }
};

class GaussSeidelSolver final : public Solver {
 public:
  explicit GaussSeidelSolver(GaussSeidelOptions options) : options_(options) {}

  void init(const System& system) override {
    system_ = &system;
    B_ = system.emission();
    next_ = 0;
    lowest_ = 0.0;
  }

  StepInfo step() override {
    const size_t i = next_;
    const int channels = B_.channels();
    double gathered[3] = {0.0, 0.0, 0.0};
    double self = 0.0;
    system_->with_compact_row(i, [&](const auto& F) {
      kernels::gather(F, B_, gathered);
      self = double(F[i]);
    });
    for (int c = 0; c < channels; ++c) {
      const double rho = system_->reflectance().at(c, i);
      const double E = system_->emission().at(c, i);
      // Remove the diagonal term from the sum and solve for B_i exactly (F_ii = 0 for planar
      // elements, but a method may report a non-zero self term).
      const double others = gathered[c] - self * B_.at(c, i);
      const double target = (E + rho * others) / (1.0 - rho * self);
      B_.at(c, i) = (1.0 - options_.omega) * B_.at(c, i) + options_.omega * target;
      lowest_ = std::min(lowest_, B_.at(c, i));
    }
    next_ = (next_ + 1) % B_.size();
    return {};
  }

  const Radiosity& solution() const override { return B_; }

  // Over-relaxation (omega > 1) can push radiosities below 0 (the Cornell box at omega 1.9:
  // -0.15 after 3,000 rows), which no physical solution has: counted, so run.json and `radlab
  // solve` say it.
  std::vector<std::pair<std::string, double>> statistics() const override {
    double negative = 0.0, now = 0.0;
    for (double b : B_.raw()) {
      negative += b < 0.0 ? 1.0 : 0.0;
      now = std::min(now, b);
    }
    return {{"negative_radiosities", negative},
            {"min_radiosity", now},
            {"min_radiosity_seen", lowest_}};
  }

 private:
  GaussSeidelOptions options_;
  const System* system_ = nullptr;
  Radiosity B_;
  size_t next_ = 0;
  double lowest_ = 0.0;  // the lowest value any element took (0 if none went below)
};

}  // namespace

SolverInfo gauss_seidel_solver_info() {
  return {"gauss-seidel",
          "gathering, one element per step, newest values (SOR with omega)",
          "Cohen & Greenberg 1985; Cohen et al. 1988 'Gathering Only'",
          "one form-factor row",
          {{"omega", "", "relaxation factor in (0,2); 1 is Gauss-Seidel"}},
          [](ParamBag& bag) -> std::unique_ptr<Solver> {
            return std::make_unique<GaussSeidelSolver>(GaussSeidelOptions::from(bag));
          },
          SolverKind::kGathering};
}

}  // namespace radlab
