// What the adaptive-shooting solver (two_level_adaptive.cpp) exposes beyond Solver: its blocks.
#pragma once

#include <cstdint>
#include <vector>

#include "solvers/solver.h"

namespace radlab {

// Per element of the evaluation mesh, the index of the adaptive block holding it; empty when
// `solver` is not adaptive-shooting or has not been initialised.
std::vector<uint32_t> adaptive_blocks(const Solver& solver);

}  // namespace radlab
