// jacobi — gathering by (damped) Jacobi iteration.
//
// Method: sweeps over the elements in index order; every gather in a sweep reads the previous
//   sweep's estimate:  B_i^{k+1} = (1-omega) B_i^k + omega (E_i + rho_i sum_j F_ij B_j^k).
//   solution() shows the newest value of each element (new for those gathered in the current
//   sweep, old for the rest). From B = E with omega <= 1 the iterates rise monotonically, and
//   after each sweep lie below Gauss–Seidel's (Stein–Rosenberg for non-negative matrices).
// Paper: the textbook baseline (Cohen & Wallace 1993, ch. 5).
// Parameters: omega (damping in (0,1]); defaults: `radlab solvers` (JacobiOptions).
// Cost per step: one form-factor row. On a dense matrix rows i and i+1 are gathered in one pass
//   at step i (paired_gather.h: the previous sweep's B is read once for both), step i+1 is
//   charged its row: one row a step, every step's solution the same bits as one row a pass; only
//   the second row's time falls in step i.
// Left out: nothing; it is the slowest gathering method by design, kept as the baseline.
#include <optional>

#include "core/error.h"
#include "core/text.h"
#include "solvers/flat/gathering.h"
#include "solvers/flat/paired_gather.h"
#include "solvers/kernels/kernels.h"

namespace radlab {
namespace {

struct JacobiOptions {
  double omega = 1.0;  // < 1 damps the update; > 1 is not convergent in general for Jacobi

  static JacobiOptions from(ParamBag& bag) {
    JacobiOptions o;
    o.omega = bag.get_double("omega", o.omega);
    o.validate();
    return o;
  }
  void validate() const {
    if (!(omega > 0.0 && omega <= 1.0))
      throw UsageError("jacobi: omega must lie in (0,1], got " + text::format_double(omega));
  }
};

class JacobiSolver final : public Solver {
 public:
  explicit JacobiSolver(JacobiOptions options) : options_(options) {}

  void init(const System& system) override {
    system_ = &system;
    previous_ = system.emission();
    current_ = previous_;
    next_ = 0;
    pairs_.reset();
  }

  StepInfo step() override {
    const size_t i = next_;
    double gathered[3] = {0.0, 0.0, 0.0};
    const bool more = i + 1 < current_.size();  // a pair never crosses the sweep's end
    pairs_.gather(*system_, i, more ? std::optional<size_t>(i + 1) : std::nullopt, previous_,
                  gathered);
    for (int c = 0; c < current_.channels(); ++c) {
      const double target =
          system_->emission().at(c, i) + system_->reflectance().at(c, i) * gathered[c];
      current_.at(c, i) = (1.0 - options_.omega) * previous_.at(c, i) + options_.omega * target;
    }
    if (++next_ == current_.size()) {
      next_ = 0;
      previous_ = current_;  // end of sweep
    }
    return {};
  }

  const Radiosity& solution() const override { return current_; }

 private:
  JacobiOptions options_;
  const System* system_ = nullptr;
  Radiosity previous_, current_;
  size_t next_ = 0;
  PairedGather pairs_;  // rows i and i+1 in one pass on a dense matrix
};

}  // namespace

SolverInfo jacobi_solver_info() {
  return {"jacobi",
          "gathering, one element per step, previous sweep's values",
          "textbook baseline (Cohen & Wallace 1993, ch. 5)",
          "one form-factor row",
          {{"omega", "", "damping in (0,1]"}},
          [](ParamBag& bag) -> std::unique_ptr<Solver> {
            return std::make_unique<JacobiSolver>(JacobiOptions::from(bag));
          },
          SolverKind::kGathering};
}

}  // namespace radlab
