#include "solvers/registry.h"

#include "core/error.h"
#include "core/text.h"
#include "solvers/gathering.h"
#include "solvers/solver_factories.h"

namespace radlab {

const std::vector<SolverInfo>& solver_registry() {
  static const std::vector<SolverInfo> table = {
      jacobi_solver_info(),
      gauss_seidel_solver_info(),
      shooting_solver_info(),
      sorted_shooting_solver_info(),
      overshooting_solver_info(),
      interleaved_solver_info(),
      conjugate_gradient_solver_info(),
      hierarchical_solver_info(),
  };
  return table;
}

const SolverInfo& solver_info(const std::string& name) {
  for (const SolverInfo& info : solver_registry())
    if (info.name == name) return info;
  std::vector<std::string> names;
  for (const SolverInfo& info : solver_registry()) names.push_back(info.name);
  throw UsageError("unknown solver '" + name + "'; solvers: " + text::join(names, ", "));
}

std::unique_ptr<Solver> make_solver(const std::string& name, ParamBag& parameters) {
  const SolverInfo& info = solver_info(name);
  std::unique_ptr<Solver> solver = info.make(parameters);
  parameters.finish();
  return solver;
}

}  // namespace radlab
