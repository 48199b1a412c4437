#include "solvers/registry.h"

#include <stdexcept>

#include "core/error.h"
#include "core/text.h"
#include "solvers/flat/gathering.h"
#include "solvers/plugin_loader.h"
#include "solvers/solver_factories.h"

namespace radlab {

const char* to_string(SolverKind kind) {
  switch (kind) {
    case SolverKind::kGathering:
      return "gathering";
    case SolverKind::kShooting:
      return "shooting";
    case SolverKind::kOther:
      break;
  }
  return "other";
}

std::map<std::string, std::string> read_parameter_defaults(const SolverInfo& info) {
  ParamBag bag("solver '" + info.name + "'");
  info.make(bag);  // reads every key with its fallback; creating a solver does no work yet
  return bag.defaults();
}

namespace {

// Fills in the defaults; returns what is wrong ("" when nothing is).
std::string complete_parameters(SolverInfo& info) {
  return fill_parameter_defaults(info.parameters, read_parameter_defaults(info));
}

std::vector<SolverInfo> builtin_solvers() {
  std::vector<SolverInfo> table = {
      jacobi_solver_info(),
      gauss_seidel_solver_info(),
      shooting_solver_info(),
      sorted_shooting_solver_info(),
      overshooting_solver_info(),
      interleaved_solver_info(),
      conjugate_gradient_solver_info(),
      hierarchical_solver_info(),
      adaptive_shooting_solver_info(),
      stochastic_jacobi_solver_info(),
      random_walk_solver_info(),
  };
  for (SolverInfo& info : table) {
    const std::string problems = complete_parameters(info);
    // A programming error in radlab itself; tests/solvers/registry_test.cpp would fail first.
    if (!problems.empty()) throw std::logic_error("solver '" + info.name + "': " + problems);
  }
  return table;
}

std::vector<SolverInfo>& table() {
  static std::vector<SolverInfo> solvers = builtin_solvers();
  return solvers;
}

}  // namespace

const std::vector<SolverInfo>& solver_registry() {
  load_requested_plugins();  // plugins load where solvers are used (solvers/plugin_loader.h)
  return table();
}

void register_solver(SolverInfo info) {
  if (info.name.empty()) throw InputError("a solver to register has no name");
  for (const SolverInfo& existing : table())
    if (existing.name == info.name)
      throw InputError("a solver named '" + info.name + "' is registered already");
  if (!info.make) throw InputError("solver '" + info.name + "' has no make function");
  std::string problems;
  try {
    problems = complete_parameters(info);
  } catch (const Error& e) {
    throw InputError("solver '" + info.name + "' cannot be made with its defaults: " + e.what());
  }
  if (!problems.empty()) throw InputError("solver '" + info.name + "': " + problems);
  table().push_back(std::move(info));
}

const SolverInfo& solver_info(const std::string& name) {
  for (const SolverInfo& info : solver_registry())
    if (info.name == name) return info;
  std::vector<std::string> names;
  for (const SolverInfo& info : solver_registry()) names.push_back(info.name);
  throw UsageError("unknown solver '" + name + "'; solvers: " + text::join(names, ", "));
}

bool is_matrix_free(const std::string& name) {
  for (const SolverInfo& info : solver_registry())
    if (info.name == name) return info.matrix_free;
  return false;
}

bool needs_step_or_time_budget(const std::string& name) {
  // The same solvers today: reading no rows is why a budget in rows cannot end them.
  return is_matrix_free(name);
}

std::unique_ptr<Solver> make_solver(const std::string& name, ParamBag& parameters) {
  const SolverInfo& info = solver_info(name);
  std::unique_ptr<Solver> solver = info.make(parameters);
  parameters.finish();
  return solver;
}

}  // namespace radlab
