// A dense form-factor matrix with one integration per unordered pair (issue 13 target 2).
//
// For a method whose pair integral is an estimate of the exact F_ij to a relative tolerance
// (`exact`, in every visibility mode: the unoccluded integral, the clipped visible part and the
// shaft decisions are all properties of the pair), reciprocity A_i F_ij = A_j F_ji gives the
// other entry for free: F_ji = F_ij A_i / A_j, each within the same relative tolerance of its
// exact value, and the matrix is reciprocal to rounding. View3D does the same (it stores A_i F_ij
// once per pair). Which side is integrated: the smaller element (its row is the one whose
// entries the larger element's quadrature resolves worst), the lower index on a tie.
//
// Cost: half the pair integrals of build_matrix; rows run in parallel (TBB), each task writing
// both entries of the pairs (i, j > i) it owns, so no two tasks write one entry. The result
// differs from build_matrix by at most the method's tolerance per entry, not bit for bit.
// Left out: methods whose row is not a sum of pair integrals (hemicube), and raycast (owned
// elsewhere; its pair API is private).
#pragma once

#include "radlab/formfactor/exact.h"
#include "radlab/formfactor/matrix.h"

namespace radlab {

FormFactorMatrix build_matrix_symmetric(const ExactFormFactors& method, const Mesh& mesh,
                                        Precision precision, BuildReport& report);

}  // namespace radlab
