// `radlab solvers`: every registered solver with its parameters, paper and cost per step.
#include <cstdio>

#include "cli/cli_common.h"
#include "formfactor/registry.h"
#include "solvers/registry.h"

namespace radlab::cli {

namespace {

// The README's solver table, from the registry (tests/cli/cli_test.cpp checks the README holds it).
void print_markdown_table() {
  std::printf("| name | method | paper | one step | parameters |\n|---|---|---|---|---|\n");
  for (const SolverInfo& s : solver_registry()) {
    std::string parameters;
    for (const ParameterInfo& p : s.parameters)
      parameters += (parameters.empty() ? "" : ", ") + ("`" + p.name + "`");
    std::printf("| `%s` | %s | %s | %s | %s |\n", s.name.c_str(), s.summary.c_str(),
                s.reference.c_str(), s.cost.c_str(), parameters.empty() ? "—" : parameters.c_str());
  }
}

}  // namespace

void add_solvers_command(CLI::App& app) {
  auto* command = app.add_subcommand("solvers", "list the solvers and form-factor methods");
  auto markdown = std::make_shared<bool>(false);
  command->add_flag("--markdown", *markdown, "print the solver table as Markdown (the README's)");
  command->callback([markdown]() {
    if (*markdown) return print_markdown_table();
    std::printf("Solvers (radlab solve SCENE --solver NAME [--set key=value]...):\n\n");
    for (const SolverInfo& s : solver_registry()) {
      std::printf("  %-20s %s\n", s.name.c_str(), s.summary.c_str());
      std::printf("  %-20s paper: %s; one step: %s\n", "", s.reference.c_str(), s.cost.c_str());
      for (const ParameterInfo& p : s.parameters)
        std::printf("      %-16s default %-8s %s\n", p.name.c_str(), p.default_value.c_str(),
                    p.help.c_str());
    }
    std::printf("\nForm-factor methods (--ff NAME [--ff-set key=value]...):\n\n");
    for (const FormFactorMethodInfo& m : form_factor_methods()) {
      std::printf("  %-20s %s\n", m.name.c_str(), m.summary.c_str());
      for (const ParameterInfo& p : m.parameters)
        std::printf("      %-16s default %-8s %s\n", p.name.c_str(), p.default_value.c_str(),
                    p.help.c_str());
    }
    std::printf("\n  any method, with a dense matrix (--ff-mode cached):\n");
    std::printf("      %-16s %s\n", "symmetrise",
                "true: A_i F_ij and A_j F_ji averaged, so every solver and the reference solve "
                "the same reciprocal system; false keeps the raw matrix");
  });
}

}  // namespace radlab::cli
