// The two-level part of prepare_problem (Cohen et al. 1988 §3.4; solvers/two_level/patches.h):
// patches from the mesh, their P x n rows from the form-factor method
// (solvers/two_level/patch_rows.h: one hemicube at each patch's centre, or the mean of its
// elements' rows), K's rows served from them, and the certified reference of that system by its
// rank-P reduction (solvers/two_level/two_level_reference.h). Nothing of size n x n is built,
// cached or held: memory O(P n), cost P hemicubes (centre). Checks: every patch row sums to at most
// 1 + the method's stated error (light is conserved) unless --ff-set unphysical=accept; the
// element-to-patch sums reciprocity gives may exceed 1 (logged; docs/solvers.md says why).
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "experiments/problem/problem.h"
#include "solvers/solver.h"

namespace radlab {

// The stages of prepare_problem on two levels, in its order (problem.cpp: scene, mesh, method,
// then these in the place of the matrix, checks, reference and system stages of one level).
// `accept_unphysical`: --ff-set unphysical=accept.
//
// Patches and their rows in double (problem.patches, certified_patch_rows, patch_row_report,
// build): the form factors of two levels.
void two_level_patch_rows(Problem& problem);
// Every patch row sums to at most 1 + the method's stated error, unless accepted.
void check_two_level_rows(const Problem& problem, bool accept_unphysical);
// The certified reference of the double rows' system, by its rank-P reduction.
void two_level_reference(Problem& problem, bool accept_unphysical);
// The rows as the solvers read them (float storage rounds them), K's rows served from them, and
// the System (problem.patch_rows, gather_rows, system).
void two_level_system(Problem& problem);

// ||E - (I - J) B||_inf per channel of the two-level system (its certified rows).
std::vector<double> two_level_residual(const Problem& problem, const Radiosity& B);

// adaptive-shooting on two levels: its final blocks' system (block_rows) certified on the
// evaluation mesh, and how far it lies from the fine system (docs/solvers.md, "Adaptive
// subdivision"): final_system_rms_rel_to_fine (the final reference against the fine one),
// rms_rel_to_final_system (the run's last solution against the final reference),
// final_system_bound_relative. Empty for other solvers, one level or without a reference.
std::vector<std::pair<std::string, double>> final_system_statistics(const Problem& problem,
                                                                    const Solver& solver);

}  // namespace radlab
