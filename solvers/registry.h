// The explicit table of solvers (DESIGN §4, §8: no self-registration inside a static library,
// which the linker would drop). `radlab solvers` and the README's solver table come from here; a
// test counts the entries.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/param_bag.h"
#include "solvers/solver.h"

namespace radlab {

struct ParameterInfo {
  std::string name;
  std::string default_value;
  std::string help;
};

struct SolverInfo {
  std::string name;
  std::string summary;    // one line
  std::string reference;  // the paper or book it follows
  std::string cost;       // cost of one step
  std::vector<ParameterInfo> parameters;
  // Reads the solver's options from the bag (validating them) and creates it.
  std::function<std::unique_ptr<Solver>(ParamBag&)> make;
};

const std::vector<SolverInfo>& solver_registry();

// Creates a solver by name. Unknown names, unknown keys and invalid values are UsageErrors that
// list what is valid.
std::unique_ptr<Solver> make_solver(const std::string& name, ParamBag& parameters);

const SolverInfo& solver_info(const std::string& name);

}  // namespace radlab
