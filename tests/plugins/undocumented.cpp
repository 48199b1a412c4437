// A plugin whose solver reads an option it does not list among its parameters: radlab must
// refuse it (the registry reads parameters from the options struct;
// tests/solvers/plugin_loader_test.cpp).
#include <memory>

#include "solvers/plugin.h"

namespace {

void register_undocumented() {
  radlab::SolverInfo info = radlab::solver_info("jacobi");
  info.name = "undocumented";
  info.parameters.clear();  // jacobi's make() reads omega
  radlab::register_solver(info);
}

}  // namespace

RADLAB_PLUGIN(register_undocumented)
