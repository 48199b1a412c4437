// sorted-shooting — progressive refinement, shooting the largest unshot power first (Southwell).
//
// Method: each step shoots from the shooter (element, or patch on a two-level System) with the
//   largest unshot power A_i sum_c |dB_ci|
//   (ties to the lowest index), delivering rho_j F_ij (A_i/A_j) s to every j with s = omega dB_i
//   (solvers/flat/shooting_core.h has the bookkeeping). With omega <= 1 and E >= 0 every dB
//   stays
//   >= 0 and B rises monotonically to the solution of the shooting system.
//   Selection: a shot changes the priority of every receiver, so an indexed heap would pay
//   O(n log n) per shot and a tournament tree O(n) to learn the new maximum. Instead the maximum
//   is found inside the shot's own pass over the receivers (a running maximum per block of 64
//   elements, then a search inside the best block): no second pass over memory, no extra storage.
//   bench/bench_solvers.cpp measures a shot with and without the selection.
// Ambient (Cohen et al. 1988 §3.3, eqs 9-13), display only: per channel c,
//   rho_avg,c = sum_j A_j rho_cj / sum_j A_j, R_c = 1 / (1 - rho_avg,c),
//   Ambient_c = R_c sum_j dB_cj A_j / sum_j A_j, display B_ci + rho_ci Ambient_c.
//   The ambient never enters dB or the solution: solution() is the same with or without it.
// Paper: Cohen et al. 1988 "Shooting and Sorting" and "... and Ambient" (Figs. 4, 5, 7);
//   Gortler, Cohen & Slusallek 1994 for the Southwell reading and over-relaxation.
// Parameters: ambient (bool), omega (in (0,2)), storage (double | float: float rounds x and dB
//   to float after every shot, to reproduce the accumulation of a float implementation;
//   ShootingCore::set_float_storage); defaults: `radlab solvers` (SortedShootingOptions).
// Cost per step: one form-factor row; the selection is fused into the row's pass. display()
//   with ambient costs O(n) per call (the runner calls it at checkpoints only).
// Left out: Cohen's incremental Delta-Ambient update of the displayed elements (display() forms
//   the same values directly).
#include <cmath>

#include "core/error.h"
#include "core/text.h"
#include "solvers/flat/shooting_core.h"
#include "solvers/solver_factories.h"

namespace radlab {
namespace {

struct SortedShootingOptions {
  bool ambient = false;  // adds Cohen's ambient term to display(): useful images from the first
                         // shots, at the price of over-lit shadows early on; no effect on solution
  double omega = 1.0;    // shoots omega dB_i: > 1 over-relaxes (can be faster, dB may go negative,
                         // the approach from below is lost), < 1 under-relaxes
  bool float_storage = false;  // storage=float: x and dB kept in float (Wu & Wang's baseline)

  static SortedShootingOptions from(ParamBag& bag) {
    SortedShootingOptions o;
    o.ambient = bag.get_bool("ambient", o.ambient);
    o.omega = bag.get_double("omega", o.omega);
    o.float_storage = bag.get_choice("storage", "double", {"double", "float"}) == "float";
    o.validate();
    return o;
  }
  void validate() const {
    if (!(omega > 0.0 && omega < 2.0))
      throw UsageError("sorted-shooting: omega must lie in (0,2) for convergence, got " +
                       text::format_double(omega));
  }
};

class SortedShootingSolver final : public Solver {
 public:
  explicit SortedShootingSolver(SortedShootingOptions options) : options_(options) {}

  void init(const System& system) override {
    core_.init(system);
    core_.set_float_storage(options_.float_storage);
    best_ = core_.max_priority();
    interreflection_.clear();
    if (options_.ambient) {
      for (double rho : average_reflectance(system)) {
        if (!(rho < 1.0))
          throw NumericalError(
              "sorted-shooting: ambient=true needs an average reflectance below 1 (R = "
              "1/(1-rho_avg)), got rho_avg = " +
              std::to_string(rho));
        interreflection_.push_back(1.0 / (1.0 - rho));
      }
    }
  }

  StepInfo step() override {
    if (!(best_.value > 0.0)) {
      // Priorities can underflow to zero; finish only when every dB is exactly zero.
      if (core_.all_shot()) return {.finished = true};
      best_ = core_.first_unshot();
    }
    const size_t i = best_.index;
    double s[3] = {0.0, 0.0, 0.0};
    for (int c = 0; c < core_.channels(); ++c) s[c] = options_.omega * core_.shooter_unshot(c, i);
    core_.system().with_compact_shooter_row(
        i, [&](const auto& F) { best_ = core_.shoot(F, i, s, true); });
    return {};
  }

  const Radiosity& solution() const override { return core_.solution(); }
  const Radiosity* unshot() const override { return &core_.unshot(); }

  Radiosity display() const override {
    Radiosity shown = core_.solution();
    if (!options_.ambient) return shown;
    double power[3] = {0.0, 0.0, 0.0};
    core_.unshot_power(false, power);
    const std::vector<double> ambient =
        ambient_radiosity(interreflection_, power, core_.system().total_area());
    const Radiosity& rho = core_.system().reflectance();
    for (int c = 0; c < shown.channels(); ++c)
      for (size_t j = 0; j < shown.size(); ++j) shown.at(c, j) += rho.at(c, j) * ambient[size_t(c)];
    return shown;
  }

 private:
  SortedShootingOptions options_;
  ShootingCore core_;
  kernels::Argmax best_;
  std::vector<double> interreflection_;  // R_c
};

}  // namespace

SolverInfo sorted_shooting_solver_info() {
  return {"sorted-shooting",
          "progressive shooting of the largest unshot power (Southwell); optional display ambient",
          "Cohen et al. 1988 'Shooting and Sorting' (+ 'Ambient', eqs 9-13)",
          "one form-factor row (selection fused into the shot)",
          {{"ambient", "", "add Cohen's display-only ambient term to display()"},
           {"omega", "", "shoot omega*dB_i; in (0,2), > 1 over-relaxes"},
           {"storage", "", "double or float: keep x and dB in float (Wu & Wang's baseline)"}},
          [](ParamBag& bag) -> std::unique_ptr<Solver> {
            return std::make_unique<SortedShootingSolver>(SortedShootingOptions::from(bag));
          },
          SolverKind::kShooting};
}

}  // namespace radlab
