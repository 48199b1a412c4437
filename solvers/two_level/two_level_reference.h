// The certified reference of the two-level system (solvers/two_level/patch_rows.h) from its P x n
// patch rows alone: no n x n matrix, O(P n) memory and time per product, O(P^3) for the solve.
//
// K = D_A^-1 P^T S D_A has rank <= P (S_pj = 1 when element j lies in patch p), so with
// y_p = sum_{j in p} A_j B_j (A_p times the patch's radiosity) the n-unknown system
// (I - diag(rho) K) B = E reduces to the P-unknown one
//
//   (I - M) y = S D_A E,   M_qp = sum_{j in q} rho_j P_pj,   then B_e = E_e + rho_e/A_e sum_p P_pe
//   y_p,
//
// solved by dense LU (Eigen). The certificate is the one of solvers/reference/reference.h, on the
// n-unknown system, with everything recomputed here in long double:
//   ||B - B*||_inf <= ||r||_inf ||(I - J)^-1||_inf,  r = E - (I - J) B with a rounding bound
//   gamma_{largest patch + P + 6} sum |terms| (the nested sum over j in p, then over p);
//   ||(I - J)^-1||_inf <= 1/(1 - q) when q = max_e rho_e sum_j K_ej < 1, and
//   <= ||w||_inf / (1 - ||s||_inf) when w solves (I - J) w = 1 approximately, w > 0, and the
//   residual s has ||s|| < 1 (then rho(J) < 1 and (I - J)^-1 >= 0).
// q often exceeds 1 here: reciprocity F_{e,p} = P_pe A_p / A_e multiplies a patch hemicube's
// aliasing on a small element by A_p / A_e (docs/solvers.md); the second bound still certifies,
// because shooting conserves power (sum_e A_e K_ej = A_j sum_e P_pe <= A_j), so rho(J) < 1.
// The spectral-radius bound it reports is q, or max_e (J w)_e / w_e (Collatz–Wielandt at w > 0).
// Iterative refinement as solvers/reference/reference.cpp: residuals in long double, corrections
// through the same reduction, until the bound is below options.target of max B. Left out: caching
// (the solve takes milliseconds at P = 438, n = 7,008).
#pragma once

#include <vector>

#include "solvers/reference/reference.h"
#include "solvers/system.h"
#include "solvers/two_level/patches.h"

namespace radlab {

// `rows` in double: the certified system is K of exactly these numbers (and the mesh's areas).
Reference compute_two_level_reference(const System& system, const Patches& patches,
                                      const RowMatrix& rows, const ReferenceOptions& options = {});

// ||E - (I - J) B||_inf per channel with its rounding bound, J = diag(rho) K (as residual_inf).
std::vector<double> two_level_residual_inf(const System& system, const Patches& patches,
                                           const RowMatrix& rows, const Radiosity& B);

}  // namespace radlab
