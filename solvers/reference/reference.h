// The certified reference solution of the same discretised system (DESIGN §5).
//
// Solve (I - J) B = E, J = diag(rho) F, per channel: a double-precision solve (dense LU up to
// `dense_limit` elements, restarted GMRES above), then iterative refinement with residuals
// accumulated in long double (64-bit mantissa). The result is certified:
//
//   ||B - B*||_inf <= ||r||_inf * ||(I - J)^-1||_inf
//
// with two independent upper bounds on the inverse's norm, the tighter one used:
//   (a) 1 / (1 - q), q = max_i rho_i sum_j F_ij, when q < 1 (DESIGN §5);
//   (b) ||w||_inf / (1 - ||s||_inf), where w solves (I - J) w = 1 approximately and
//       s = 1 - (I - J) w. If w > 0 and ||s||_inf < 1, then J w < w, so rho(J) < 1, (I-J)^-1 >= 0
//       and (I-J)^-1 1 <= w / (1 - ||s||). This also certifies scenes with q >= 1 (some element
//       with rho = 1 in a closed scene) as long as the spectral radius is below 1.
// Residuals include a bound on their own rounding error (blocked summation), so the certificate
// is rigorous for the F given, rho and E. prepare_problem() gives it the method's F in double
// whatever the solvers' storage (docs/reference.md), and names that system in `system`.
// Above dense_limit, GMRES solves each correction only to gmres_tolerance: refinement with
// long-double residuals supplies the accuracy (a tighter inner tolerance stalls on rounding).
//
// A system with no finite solution (spectral radius of J >= 1, e.g. a closed scene with rho = 1
// everywhere) is detected by Collatz–Wielandt bounds before any solve and reported as a
// NumericalError (exit 4); so is any solve that cannot be certified.
#pragma once

#include <limits>
#include <string>
#include <vector>

#include "core/radiosity.h"
#include "formfactor/form_factor_method.h"
#include "formfactor/matrix/matrix.h"
#include "solvers/system.h"

namespace radlab {

struct ReferenceOptions {
  double target = 1e-12;           // stop refining once the bound is below target * max B
  double acceptable = 1e-8;        // a bound above acceptable * max B is a failure
  int max_refinements = 10;        // refinement steps per channel
  size_t dense_limit = 9000;       // largest n for dense LU (n^2 doubles of memory, n^3/3 flops)
  double gmres_tolerance = 1e-10;  // relative residual of each inner GMRES solve above
                                   // dense_limit; refinement (long double) supplies the rest
};

struct Reference {
  Radiosity B;
  double bound_inf = 0.0;           // certified max over channels of ||B - B*||_inf
  double bound_relative = 0.0;      // bound_inf / max B
  double residual_inf = 0.0;        // max over channels of ||E - (I-J)B||_inf (with rounding bound)
  double inverse_norm_bound = 0.0;  // certified upper bound on ||(I-J)^-1||_inf (worst channel)
  std::vector<double> channel_inverse_norm;  // the same bound per channel
  double q = 0.0;                            // max_i rho_i sum_j F_ij (worst channel)
  double spectral_radius_upper = 0.0;  // Collatz–Wielandt upper bound on rho(J) (worst channel)
  std::string method;                  // "dense LU" or "GMRES(30)"
  // What the errors are measured against, written in trace.csv and run.json: "certified" (this
  // file's certificate holds), or the name of an uncertified stand-in for scenes too large for
  // the certified solve (never presented as certified).
  std::string kind = "certified";
  // Which system the certificate is of, in words (printed with it; set by prepare_problem):
  // e.g. the method's F in double precision, symmetrised or not. Empty: the matrix given.
  std::string system;
  // With float storage (issue 35.6): a certified bound on ||B_f - B*||_inf, B_f the solution of
  // the system the solvers read (F rounded to float), absolute and relative to max B; NaN when
  // the solvers read the certified matrix itself. No solver reading float rows can be certified
  // closer to B* than about this: their floor, printed before they hit it.
  double float_storage_bound = std::numeric_limits<double>::quiet_NaN();
  double float_storage_bound_relative = std::numeric_limits<double>::quiet_NaN();
  int refinements = 0;
  long long gmres_iterations = 0;  // matrix-vector products of all GMRES solves (0 with LU)
  double seconds = 0.0;

  std::string summary() const;
};

Reference compute_reference(const System& system, const FormFactorMatrix& matrix,
                            const ReferenceOptions& options = {});

// Sets ref.float_storage_bound(_relative): ||B_f - B*||_inf for B_f solving the system with
// `stored` (the certified matrix `certified` rounded to another precision) in place of F. With
// J = diag(rho) F and dJ = diag(rho)(stored - certified): B_f - B* = (I - J - dJ)^-1 dJ B*, and
// by the Banach lemma ||(I - J - dJ)^-1|| <= N / (1 - N ||dJ||), N = ref.inverse_norm_bound, so
//   ||B_f - B*|| <= N (||dJ B_ref|| + ||dJ|| bound_inf) / (1 - N ||dJ||)
// (B_ref within bound_inf of B*), every norm taken over channels and summed in long double from
// the two matrices' actual entries. Infinite when N ||dJ|| >= 1 (the rounding may then move the
// spectral radius to 1).
void bound_storage_rounding(const System& system, const FormFactorMatrix& certified,
                            const FormFactorMatrix& stored, Reference& ref);

// Certifies a stored reference anew against `matrix` (the reference cache): recomputes every
// channel's residual in long double and the bound residual * channel_inverse_norm (a property of
// J alone, stored with B under a key naming the matrix, rho and E). Fills residual_inf, bound_inf
// and bound_relative; throws NumericalError when the bound exceeds options.acceptable of max B,
// so a stale or damaged B is never used.
void recertify_reference(const System& system, const FormFactorMatrix& matrix, Reference& ref,
                         const ReferenceOptions& options = {});

// One pass over F's rows computed by `method` (O(n) memory: for rows on the fly, when the dense
// matrix is not held): every channel's ||E - (I - J) B||_inf with the same long-double blocked
// sums and rounding bound as residual_inf, each row's sum, and each row's emission-weighted sum
// sum_j E_j F_ij (E summed over channels), for the checks a dense build runs.
struct StreamedCheck {
  std::vector<double> residual;     // per channel
  std::vector<double> row_sum;      // per row
  std::vector<double> emitter_sum;  // per row
};
StreamedCheck streamed_check(const System& system, const FormFactorMethod& method,
                             const Radiosity& B);
// The same pass over a matrix in memory, term for term (the same rows give the same numbers): what
// the reference cache stores beside a reference, so that a later run with rows on the fly need
// not compute every row again to certify it (experiments/problem/reference_cache.h).
StreamedCheck matrix_check(const System& system, const FormFactorMatrix& matrix,
                           const Radiosity& B);

// recertify_reference with the residuals of a streamed_check (rows from the method).
void recertify_reference(const System& system, const std::vector<double>& residuals, Reference& ref,
                         const ReferenceOptions& options = {});

// Collatz–Wielandt bounds on the spectral radius of J = diag(rho) F for one channel after
// `iterations` steps of power iteration (J is non-negative): lower <= rho(J) <= upper.
struct SpectralRadiusBounds {
  double lower = 0.0;
  double upper = 0.0;
};
SpectralRadiusBounds spectral_radius_bounds(const FormFactorMatrix& matrix,
                                            std::span<const double> rho, int iterations);

// ||E - (I - J) B||_inf per channel, accumulated in long double, plus a bound on the rounding of
// that computation. Used by the reference and by the metrics.
std::vector<double> residual_inf(const System& system, const FormFactorMatrix& matrix,
                                 const Radiosity& B);

}  // namespace radlab
