// Experiment files shared by the sweep tests (experiments_test, reliability_data_test): one
// definition, so a change of the format changes them together.
#pragma once

namespace radlab::testing {

// Two gauss-seidel runs (omega 1 and 1.3) on a small cube, 200 rows each.
inline constexpr const char* kTwoRuns = R"(name = "tiny"
scenes = ["builtin:cube:rho=0.8"]
subdiv = 2
solvers = ["gauss-seidel"]
[form_factors]
rays = 4
[budget]
rows = 200
[parameters.gauss-seidel]
omega = [1.0, 1.3]
)";

}  // namespace radlab::testing
