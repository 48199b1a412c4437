// Factories of the gathering solvers (jacobi.cpp, gauss_seidel.cpp).
#pragma once

#include "solvers/registry.h"

namespace radlab {

SolverInfo jacobi_solver_info();
SolverInfo gauss_seidel_solver_info();

}  // namespace radlab
