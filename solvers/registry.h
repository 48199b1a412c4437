// The table of solvers (DESIGN §4, §8): the built-in ones, listed explicitly in registry.cpp (no
// self-registration inside a static library, which the linker would drop), followed by those a
// plugin added with register_solver() (solvers/plugin.h). `radlab solvers`, the README's
// solver table, sweeps and the conformance tests all read this table.
//
// Each fact about a solver is written once, in its SolverInfo: its kind (what the sweep runner
// does for gathering solvers follows from it), its parameters' names and help. Parameter defaults
// are not typed here: the registry reads them from the solver's options struct by calling make()
// on an empty bag (core/param_bag.h records the fallback of every key read), so the
// value `radlab solvers` prints is the one the code uses.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/param_bag.h"
#include "solvers/solver.h"

namespace radlab {

// What the runner may assume about one step.
//   gathering: a step gathers at one element, in sweeps of n steps over the elements; sweeps get
//              a checkpoint at the end of every sweep, the per-sweep rate fit and the
//              spectral-radius column.
//   shooting:  a step shoots unshot energy from one element or patch; unshot() is not null.
//   other:     anything else (conjugate gradients, hierarchical passes).
enum class SolverKind { kGathering, kShooting, kOther };

const char* to_string(SolverKind kind);

struct SolverInfo {
  std::string name;
  std::string summary;    // one line
  std::string reference;  // the paper or book it follows
  std::string cost;       // cost of one step
  std::vector<ParameterInfo> parameters;
  // Reads the solver's options from the bag (validating them) and creates it.
  std::function<std::unique_ptr<Solver>(ParamBag&)> make;
  SolverKind kind = SolverKind::kOther;
  // Reads no form-factor row and never finishes by itself (the Monte Carlo solvers: every step
  // refines an estimate). The runner gives it no matrix of its own (run_request.h) and refuses a
  // budget in rows alone for it (needs_step_or_time_budget).
  bool matrix_free = false;
};

// The built-in solvers, then the registered ones, in registration order. Register before using
// the table: registering may move its entries.
const std::vector<SolverInfo>& solver_registry();

// Adds a solver (a plugin's, solvers/plugin.h). Refused with an InputError (exit 3) when
// the name is empty or taken, make() is missing or fails with no parameters given, or the
// parameters listed differ from the keys its options struct reads.
void register_solver(SolverInfo info);

// Creates a solver by name. Unknown names, unknown keys and invalid values are UsageErrors that
// list what is valid.
std::unique_ptr<Solver> make_solver(const std::string& name, ParamBag& parameters);

const SolverInfo& solver_info(const std::string& name);

// True for the solvers that read no form-factor row and never finish by themselves (the Monte
// Carlo ones, SolverInfo::matrix_free: every step refines an average): a budget in rows alone
// cannot end their runs, so the runner refuses one and an experiment's "all" leaves them out.
// False for names not registered.
bool needs_step_or_time_budget(const std::string& name);

// SolverInfo::matrix_free of a registered solver (false for names not registered): no run of it
// needs a form-factor matrix, so none is built for it when its reference needs none either.
bool is_matrix_free(const std::string& name);

// The keys make() reads from an empty bag, with the defaults of its options struct as text.
std::map<std::string, std::string> read_parameter_defaults(const SolverInfo& info);

}  // namespace radlab
