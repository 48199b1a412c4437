// Factories of the shooting solvers and conjugate gradients, one per .cpp file (the gathering
// ones are in gathering.h). registry.cpp lists them.
#pragma once

#include "solvers/registry.h"

namespace radlab {

SolverInfo shooting_solver_info();            // shooting.cpp
SolverInfo sorted_shooting_solver_info();     // sorted_shooting.cpp
SolverInfo overshooting_solver_info();        // overshooting.cpp
SolverInfo interleaved_solver_info();         // interleaved.cpp
SolverInfo conjugate_gradient_solver_info();  // conjugate_gradient.cpp
SolverInfo hierarchical_solver_info();        // hierarchical.cpp
SolverInfo adaptive_shooting_solver_info();   // two_level_adaptive.cpp
SolverInfo stochastic_jacobi_solver_info();   // monte_carlo/stochastic_jacobi.cpp
SolverInfo random_walk_solver_info();         // monte_carlo/random_walk.cpp

}  // namespace radlab
