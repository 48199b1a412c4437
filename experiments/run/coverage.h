// Per-element shot coverage against p-error (Wu & Wang 2002, Figs 2 and 4): for solvers that
// track it (interleaved), one CSV row per element with the summed form factors dff it received
// from this session's shooters, whether it shot, and its p-error per channel.
#pragma once

#include <string>

#include "experiments/problem/problem.h"
#include "solvers/solver.h"

namespace radlab {

// Columns: step,session,element,area,dff,shot,p_mean[,p_r,p_g,p_b]. Does nothing (returns
// false) if the solver does not track coverage or there is no reference.
bool write_coverage_csv(const std::string& path, const Solver& solver, const Problem& problem,
                        long long step);

}  // namespace radlab
