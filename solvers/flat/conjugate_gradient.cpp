// conjugate-gradient — preconditioned conjugate gradients on the symmetric form of the system.
//
// Method: multiplying row i of (I - diag(rho) F) B = E by A_i / rho_i gives, per channel,
//   M B = b,  M_ij = (A_i / rho_i) delta_ij - A_i F_ij,  b_i = A_i E_i / rho_i,
//   which is symmetric when the form factors are reciprocal (A_i F_ij = A_j F_ji) and positive
//   definite when the spectral radius of diag(rho) F is below 1. Elements with rho_i = 0 in a
//   channel are eliminated there (B_i = E_i is known; their coupling moves into b). CG starts
//   from B = E and minimises the M-norm of the error over growing Krylov spaces, so that norm
//   never increases; solution() is the current iterate. Preconditioner: Jacobi (diag M) or none.
//   Stop: a channel is converged when its recursive residual is at the rounding level of
//   evaluating M B in double, |r_i| <= 4u (|b_i| + sum_j |M_ij| ||B||_inf) for every element
//   (componentwise, so a tiny element's row counts), and the solver reports finished when all
//   are. A breakdown (p^T M p <= 0) with the residual within 1e3 of that level is rounding noise
//   after convergence and counts as converged; anywhere else it is a NumericalError.
//   Reciprocity: by default init() checks it on the dense matrix and refuses (UsageError) a
//   matrix whose relative defect |A_i F_ij - A_j F_ji| / max(A_i F_ij, A_j F_ji) exceeds
//   reciprocity_tolerance: on a non-symmetric M, CG has no convergence guarantee. With
//   symmetrise=true it instead solves the symmetrised system, M_ij = (A_i/rho_i) delta_ij -
//   (A_i F_ij + A_j F_ji) / 2, without copying the matrix: one pass over the rows gives both
//   A F p and (A F)^T p. That is the plain average, not the inverse-variance weights of
//   formfactor/matrix/matrix.h's symmetrise() (which the cached matrix gets by default, and
//   which is the better choice): pair weights would need a second pass. Either way the solution
//   differs from the unsymmetrised System's (and its reference's) by the reciprocity defect.
// Paper: none of the three; Hestenes & Stiefel 1952, on the symmetric formulation that
//   reciprocity allows (e.g. Cohen & Wallace 1993 ch. 5 discuss it for radiosity).
// Parameters: preconditioner (jacobi | none), symmetrise (bool), reciprocity_tolerance (float
//   storage alone leaves a relative defect of up to ~1.2e-7 in a symmetrised matrix, so the
//   default must lie above that); defaults: `radlab solvers` (ConjugateGradientOptions).
// Cost per step: one matrix-vector product = one form-factor row per element that reflects in
//   some channel (black elements are eliminated), plus O(n) vector work. init() costs the same
//   rows once more (the initial residual), and with the check an O(n^2) pass over the matrix.
// Left out: restarts and residual replacement (the recursive residual is used throughout).
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "core/error.h"
#include "core/text.h"
#include "solvers/kernels/kernels.h"
#include "solvers/solver_factories.h"

namespace radlab {
namespace {

struct ConjugateGradientOptions {
  std::string preconditioner = "jacobi";  // "jacobi" scales by diag(M): cheap, evens out
                                          // elements of very different area / reflectance
  bool symmetrise = false;  // solve the symmetrised system instead of refusing a non-reciprocal
                            // matrix: works on the fly too, but converges to a (slightly)
                            // different solution
  double reciprocity_tolerance = 1e-6;  // largest relative defect accepted as symmetric

  static ConjugateGradientOptions from(ParamBag& bag) {
    ConjugateGradientOptions o;
    o.preconditioner = bag.get_choice("preconditioner", o.preconditioner, {"jacobi", "none"});
    o.symmetrise = bag.get_bool("symmetrise", o.symmetrise);
    o.reciprocity_tolerance = bag.get_double("reciprocity_tolerance", o.reciprocity_tolerance);
    o.validate();
    return o;
  }
  void validate() const {
    if (!(reciprocity_tolerance >= 0.0 && reciprocity_tolerance < 1.0))
      throw UsageError("conjugate-gradient: reciprocity_tolerance must lie in [0,1), got " +
                       text::format_double(reciprocity_tolerance));
  }
};

class ConjugateGradientSolver final : public Solver {
 public:
  explicit ConjugateGradientSolver(ConjugateGradientOptions options)
      : options_(std::move(options)) {}

  void init(const System& system) override {
    system_ = &system;
    const size_t n = system.size();
    const int channels = system.channels();
    const Radiosity& rho = system.reflectance();
    active_.clear();
    for (size_t i = 0; i < n; ++i) {
      bool reflects = false;
      for (int c = 0; c < channels; ++c) reflects |= rho.at(c, i) > 0.0;
      if (reflects) active_.push_back(i);
    }
    // The two-level system is not reciprocal (A_e K_ej != A_j K_je), and symmetrising it would
    // solve another system than the one its reference certifies.
    if (system_->two_level())
      throw UsageError(
          "conjugate-gradient needs a reciprocal system (A_i F_ij = A_j F_ji); the two-level "
          "system is not (A_e K_ej != A_j K_je) and symmetrise=true would solve another one; use "
          "gathering or shooting");
    if (!options_.symmetrise) check_reciprocity();

    B_ = system.emission();
    r_ = Radiosity(channels, n);
    z_ = Radiosity(channels, n);
    p_ = Radiosity(channels, n);
    q_ = Radiosity(channels, n);
    diagonal_ = Radiosity(channels, n, 1.0);
    scatter_ = Radiosity(channels, n);

    // Initial residual b - M E = (A F E)_i (or (S E)_i symmetrised) on the free entries: the
    // coupling to eliminated elements and M's diagonal cancel against b. One pass over the rows
    // (symmetrised: all rows, since eliminated elements couple through the transpose too).
    std::vector<double> self(n, 0.0), row_sum(n, 0.0);
    auto rows = [&](size_t i, const auto* F) {
      self[i] = double(F[i]);
      double sum = 0.0;
      for (size_t j = 0; j < n; ++j) sum += double(F[j]);
      row_sum[i] = sum;
    };
    multiply(B_, r_, options_.symmetrise, /*all_rows=*/options_.symmetrise, rows);
    for (int c = 0; c < channels; ++c)
      for (size_t i = 0; i < n; ++i) {
        const double rc = rho.at(c, i);
        if (rc > 0.0) {
          if (options_.preconditioner == "jacobi")
            diagonal_.at(c, i) = system.area()[i] * (1.0 / rc - self[i]);
        } else {
          r_.at(c, i) = 0.0;
        }
      }
    // The rounding level of the residual, per element and channel: row i of M has absolute sum
    // A_i (1/rho_i + sum_j F_ij) and b_i = A_i E_i / rho_i. A residual with
    // |r_i| <= 4u (|b_i| + row_i ||B||_inf) everywhere is as small as evaluating M B in double
    // can tell apart from zero; iterating further only follows rounding noise (and, left
    // running, drifts or breaks down with p^T M p = 0). Per element, not in norm: a 1e-6 m^2
    // element's row is 1e6 times smaller than its neighbours'.
    row_scale_ = Radiosity(channels, n);
    for (int c = 0; c < channels; ++c)
      for (size_t i = 0; i < n; ++i) {
        const double rc = rho.at(c, i);
        if (rc > 0.0) row_scale_.at(c, i) = system.area()[i] * (1.0 / rc + row_sum[i]);
      }
    converged_.assign(size_t(channels), false);
    rz_.assign(size_t(channels), 0.0);
    for (int c = 0; c < channels; ++c) {
      double rz = 0.0;
      for (size_t i = 0; i < n; ++i) {
        z_.at(c, i) = r_.at(c, i) / diagonal_.at(c, i);
        p_.at(c, i) = z_.at(c, i);
        rz += r_.at(c, i) * z_.at(c, i);
      }
      rz_[size_t(c)] = rz;
      converged_[size_t(c)] = rz == 0.0;
    }
  }

  StepInfo step() override {
    const size_t n = system_->size();
    const int channels = system_->channels();
    const Radiosity& rho = system_->reflectance();
    const auto area = system_->area();
    // q = M p: the off-diagonal part from one pass over the rows, then the diagonal.
    multiply(p_, q_, options_.symmetrise, /*all_rows=*/false, [](size_t, const auto*) {});
    bool finished = true;
    for (int c = 0; c < channels; ++c) {
      const size_t k = size_t(c);
      if (converged_[k]) continue;
      double pq = 0.0;
      for (size_t i = 0; i < n; ++i) {
        const double rc = rho.at(c, i);
        if (!(rc > 0.0)) {
          q_.at(c, i) = 0.0;
          continue;
        }
        q_.at(c, i) = area[i] / rc * p_.at(c, i) - q_.at(c, i);
        pq += p_.at(c, i) * q_.at(c, i);
      }
      if (!(pq > 0.0) && at_rounding_level(c, 1e3)) {
        // Breakdown after convergence: p is rounding noise, B is already the solution.
        converged_[k] = true;
        continue;
      }
      if (!(pq > 0.0))
        throw NumericalError(
            "conjugate-gradient: p^T M p = " + std::to_string(pq) + " <= 0 in channel " +
            std::to_string(c) +
            ": the system is not positive definite (spectral radius of diag(rho) F >= 1, or "
            "form factors far from reciprocal)");
      const double alpha = rz_[k] / pq;
      double rz = 0.0;
      for (size_t i = 0; i < n; ++i) {
        if (!(rho.at(c, i) > 0.0)) continue;
        B_.at(c, i) += alpha * p_.at(c, i);
        r_.at(c, i) -= alpha * q_.at(c, i);
        z_.at(c, i) = r_.at(c, i) / diagonal_.at(c, i);
        rz += r_.at(c, i) * z_.at(c, i);
      }
      const double beta = rz / rz_[k];
      for (size_t i = 0; i < n; ++i)
        if (rho.at(c, i) > 0.0) p_.at(c, i) = z_.at(c, i) + beta * p_.at(c, i);
      rz_[k] = rz;
      // Converged: the recursive residual vanished, or reached the rounding level.
      converged_[k] = rz == 0.0 || at_rounding_level(c, 1.0);
      finished &= converged_[k];
    }
    for (bool c : converged_) finished &= c;
    return {.finished = finished};
  }

  const Radiosity& solution() const override { return B_; }

 private:
  // out_ci = A_i sum_j F_ij v_cj (or the symmetric part (A_i F_i. v + (F^T A v)_i) / 2) for the
  // active elements, one row each (all_rows: every element's row, which the symmetric part needs
  // when v is non-zero on eliminated elements); visit(i, F) sees every row read.
  template <class Visit>
  void multiply(const Radiosity& v, Radiosity& out, bool symmetric, bool all_rows, Visit&& visit) {
    const int channels = v.channels();
    const auto area = system_->area();
    double sums[3] = {0.0, 0.0, 0.0};
    if (!symmetric) {
      // Two rows a pass where the matrix is dense (kernels::gather_pair reads v once for both;
      // the same bits as one row at a time).
      double next_sums[3] = {0.0, 0.0, 0.0};
      for (size_t a = 0; a < active_.size();) {
        const size_t i = active_[a];
        if (a + 1 < active_.size()) {
          const size_t k = active_[a + 1];
          if (system_->with_dense_rows(i, k, [&](const auto* F, const auto* F_next) {
                visit(i, F);
                visit(k, F_next);
                kernels::gather_pair(F, F_next, v, sums, next_sums);
              })) {
            for (int c = 0; c < channels; ++c) {
              out.at(c, i) = area[i] * sums[c];
              out.at(c, k) = area[k] * next_sums[c];
            }
            a += 2;
            continue;
          }
        }
        system_->with_row(i, [&](const auto* F) {
          visit(i, F);
          kernels::gather(F, v, sums);
          for (int c = 0; c < channels; ++c) out.at(c, i) = area[i] * sums[c];
        });
        ++a;
      }
      return;
    }
    for (double& s : scatter_.raw()) s = 0.0;
    auto visit_row = [&](size_t i) {
      system_->with_row(i, [&](const auto* F) {
        visit(i, F);
        double a[3] = {0.0, 0.0, 0.0};
        for (int c = 0; c < channels; ++c) a[c] = area[i] * v.at(c, i);
        kernels::gather_scatter(F, v, sums, scatter_, a);
        for (int c = 0; c < channels; ++c) out.at(c, i) = area[i] * sums[c];
      });
    };
    if (all_rows) {
      for (size_t i = 0; i < system_->size(); ++i) visit_row(i);
    } else {
      for (size_t i : active_) visit_row(i);
    }
    for (int c = 0; c < channels; ++c)
      for (size_t i = 0; i < v.size(); ++i) out.at(c, i) = 0.5 * (out.at(c, i) + scatter_.at(c, i));
  }

  // |r_i| <= factor * 4u (|b_i| + row_i ||B||_inf) for every free element of channel c.
  bool at_rounding_level(int c, double factor) const {
    const double u = std::numeric_limits<double>::epsilon() / 2;
    const Radiosity& rho = system_->reflectance();
    double B_norm = 0.0;
    for (size_t i : active_)
      if (rho.at(c, i) > 0.0) B_norm = std::max(B_norm, std::abs(B_.at(c, i)));
    for (size_t i : active_) {
      const double rc = rho.at(c, i);
      if (!(rc > 0.0)) continue;
      const double b = system_->area()[i] * std::abs(system_->emission().at(c, i)) / rc;
      if (std::abs(r_.at(c, i)) > factor * 4.0 * u * (b + row_scale_.at(c, i) * B_norm))
        return false;
    }
    return true;
  }

  void check_reciprocity() const {
    const FormFactorMatrix* F = system_->matrix();
    if (!F)
      throw UsageError(
          "conjugate-gradient needs reciprocal form factors and checks them on the cached "
          "matrix; rows are computed on the fly here. Use --ff-mode cached, or set "
          "symmetrise=true to solve the symmetrised system");
    const auto area = system_->area();
    double worst = 0.0;
    size_t wi = 0, wj = 0;
    // Blocks of 64 x 64 keep both F_ij and F_ji in cache.
    constexpr size_t kTile = 64;
    const size_t m = active_.size();
    for (size_t bi = 0; bi < m; bi += kTile)
      for (size_t bj = bi; bj < m; bj += kTile)
        for (size_t a = bi; a < std::min(m, bi + kTile); ++a)
          for (size_t b = std::max(bj, a + 1); b < std::min(m, bj + kTile); ++b) {
            const size_t i = active_[a], j = active_[b];
            const double gij = area[i] * F->at(i, j), gji = area[j] * F->at(j, i);
            const double big = std::max(gij, gji);
            if (big > 0.0) {
              const double defect = std::abs(gij - gji) / big;
              if (defect > worst) {
                worst = defect;
                wi = i;
                wj = j;
              }
            }
          }
    if (worst > options_.reciprocity_tolerance)
      throw UsageError(
          "conjugate-gradient needs reciprocal form factors (A_i F_ij = A_j F_ji): relative "
          "defect " +
          std::to_string(worst) + " at elements " + std::to_string(wi) + ", " + std::to_string(wj) +
          " exceeds reciprocity_tolerance = " +
          text::format_double(options_.reciprocity_tolerance) +
          ". Symmetrise the cached matrix (--ff-set symmetrise=true, the default with "
          "--ff-mode cached), or set the solver's symmetrise=true to solve the symmetrised "
          "system");
  }

  ConjugateGradientOptions options_;
  const System* system_ = nullptr;
  std::vector<size_t> active_;  // elements with rho > 0 in some channel: their rows are read
  Radiosity B_, r_, z_, p_, q_, diagonal_, scatter_;
  Radiosity row_scale_;  // A_i (1/rho_i + sum_j F_ij): row i's absolute sum in M
  std::vector<double> rz_;
  std::vector<bool> converged_;
};

}  // namespace

SolverInfo conjugate_gradient_solver_info() {
  return {"conjugate-gradient",
          "preconditioned conjugate gradients on diag(A/rho)(I - diag(rho) F) B = A E / rho",
          "Hestenes & Stiefel 1952 (beyond the papers); needs reciprocal form factors",
          "one matrix-vector product: a row per reflecting element",
          {{"preconditioner", "", "jacobi (diagonal of M) or none"},
           {"symmetrise", "", "solve the symmetrised system instead of requiring reciprocity"},
           {"reciprocity_tolerance", "", "largest relative reciprocity defect accepted"}},
          [](ParamBag& bag) -> std::unique_ptr<Solver> {
            return std::make_unique<ConjugateGradientSolver>(ConjugateGradientOptions::from(bag));
          }};
}

}  // namespace radlab
