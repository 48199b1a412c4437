// A form-factor matrix with one integration per unordered pair (issue 13 target 2).
//
// For a method whose pair integral is an estimate of the exact F_ij to a relative tolerance
// (FormFactorMethod::integrates_pairs_once(): `exact`, in every visibility mode — the unoccluded
// integral, the clipped visible part and the shaft decisions are all properties of the pair),
// reciprocity A_i F_ij = A_j F_ji gives the
// other entry for free: F_ji = F_ij A_i / A_j, each within the same relative tolerance of its
// exact value, and the matrix is reciprocal to rounding. View3D does the same (it stores A_i F_ij
// once per pair). Which side is integrated: the smaller element (its row is the one whose
// entries the larger element's quadrature resolves worst), the lower index on a tie — the
// orientation the method's own rows use (FormFactorMethod::upper_row gives the integrated side's
// values, orient_row turns them into a row), so the result equals build_matrix() (and every row
// computed on the fly) bit for bit, at half the pair integrals.
//
// Two passes. First the pairs (i, j > i), rows in parallel (TBB), each F_ab of the integrated
// side kept in a sparse upper triangle (culled and hidden pairs cost nothing; at most 4 n^2
// bytes); then every row of the result is assembled from it, rows in parallel, each task
// writing only its own row (so the sparse layout is built without repacking shared rows). Same
// bits for any thread count: every value is computed by the same code from the same inputs.
// Cost counters: kernel evaluations (and rays) as spent; the pair classes (culled, unoccluded,
// traced) counted for both entries of a pair, as build_matrix counts them.
// Left out: methods whose row is not a sum of pair integrals (hemicube), and raycast (its
// visibility estimate is per ordered pair).
#pragma once

#include <functional>

#include "formfactor/form_factor_method.h"
#include "formfactor/matrix/matrix.h"

namespace radlab {

// `method` must integrate pairs once (integrates_pairs_once()). `progress`, if given, is called
// now and then with the unordered pairs done and their total n (n - 1) / 2.
FormFactorMatrix build_matrix_symmetric(
    const FormFactorMethod& method, const Mesh& mesh, Precision precision, Layout layout,
    BuildReport& report, const std::function<void(size_t done, size_t total)>& progress = {});

}  // namespace radlab
