// A plugin that registers a solver under a built-in's name: radlab must refuse it
// (tests/solvers/plugin_loader_test.cpp).
#include <memory>

#include "solvers/plugin.h"

namespace {

void register_duplicate() {
  radlab::SolverInfo info = radlab::solver_info("jacobi");  // a copy of the built-in entry
  radlab::register_solver(info);
}

}  // namespace

RADLAB_PLUGIN(register_duplicate)
