// shooting — progressive refinement by shooting, unsorted: a fixed cyclic order.
//
// Method: elements take turns in index order; at its turn an element with unshot radiosity
//   dB_i != 0 shoots all of it (row i of F delivers rho_j F_ij (A_i/A_j) dB_i to every j), and
//   an element with dB_i = 0 (in every channel) is skipped without reading its row. Bookkeeping
//   per DESIGN §2 (solvers/flat/shooting_core.h); solution() is B = x + dB.
//   With reciprocal form factors and F_ii = 0, x = B - dB after each full cycle is exactly the
//   Gauss–Seidel iterate started from x = 0 (not from E): the shot from i sets
//   x_i <- x_i + dB_i = E_i + rho_i sum_j F_ij x_j, which is Gauss–Seidel's update, and a skipped
//   element is one whose Gauss–Seidel update would not change it. B = x + dB = E + J x is one
//   Jacobi step further.
// Paper: Cohen et al. 1988, "Shooting Only" (Fig. 3, the jumps when light sources come round).
// Parameters: none.
// Cost per step: one form-factor row (n multiply-adds per channel); a step that finds the next
//   element with unshot energy scans the skipped elements' dB (no rows).
//   On a two-level System (solvers/two_level/patches.h) the turns go to patches, each shooting one
//   patch row to every element, as Cohen's "Shooting Only" does.
// Left out: nothing of the paper's method.
#include "solvers/flat/shooting_core.h"
#include "solvers/solver_factories.h"

namespace radlab {
namespace {

class ShootingSolver final : public Solver {
 public:
  void init(const System& system) override {
    core_.init(system);
    next_ = 0;
  }

  StepInfo step() override {
    const size_t n = core_.shooters();  // elements, or patches on a two-level System
    for (size_t tried = 0; tried < n; ++tried) {
      const size_t i = (next_ + tried) % n;
      if (!core_.shooter_has_unshot(i)) continue;
      double s[3] = {0.0, 0.0, 0.0};
      for (int c = 0; c < core_.channels(); ++c) s[c] = core_.shooter_unshot(c, i);
      core_.system().with_compact_shooter_row(i,
                                              [&](const auto& F) { core_.shoot(F, i, s, false); });
      next_ = (i + 1) % n;
      return {};
    }
    return {.finished = true};  // every dB is exactly zero
  }

  const Radiosity& solution() const override { return core_.solution(); }
  const Radiosity* unshot() const override { return &core_.unshot(); }

 private:
  ShootingCore core_;
  size_t next_ = 0;
};

}  // namespace

SolverInfo shooting_solver_info() {
  return {"shooting",
          "progressive shooting in fixed cyclic order, skipping elements with no unshot energy",
          "Cohen et al. 1988 'Shooting Only'",
          "one form-factor row",
          {},
          [](ParamBag&) -> std::unique_ptr<Solver> { return std::make_unique<ShootingSolver>(); },
          SolverKind::kShooting};
}

}  // namespace radlab
