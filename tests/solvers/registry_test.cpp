// Each fact about a solver in one place (issue 15): the parameter defaults `radlab solvers`
// prints are the ones the options structs use, every key an options struct reads is listed (and
// nothing else), the kind in SolverInfo is true of the solver, and docs/solvers.md's table names
// every solver with every parameter.
#include "solvers/registry.h"

#include <gtest/gtest.h>

#include <fstream>
#include <set>
#include <sstream>

#include "core/text.h"
#include "formfactor/methods/raycast.h"
#include "scene/builtin/builtin_scenes.h"
#include "scene/validate.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

// `radlab solvers`'s parameter lines: solver -> parameter -> default.
std::map<std::string, std::map<std::string, std::string>> printed_defaults() {
  const auto result = radlab::testing::run_command(std::string(RADLAB_BINARY) + " solvers");
  EXPECT_EQ(result.code, 0) << result.output;
  std::map<std::string, std::map<std::string, std::string>> out;
  std::string solver;
  std::istringstream lines(result.output);
  std::string line;
  while (std::getline(lines, line)) {
    if (text::starts_with(line, "Form-factor methods")) break;
    const auto words = text::split_whitespace(line);
    if (line.rfind("  ", 0) == 0 && line.size() > 2 && line[2] != ' ' && !words.empty())
      solver = std::string(words[0]);  // "  name   summary"
    else if (words.size() >= 3 && words[1] == "default")
      out[solver][std::string(words[0])] = std::string(words[2]);
  }
  return out;
}

TEST(Registry, PrintedDefaultsAreTheOptionsStructs) {
  const auto printed = printed_defaults();
  for (const SolverInfo& info : solver_registry()) {
    // What the code uses: the fallbacks make() passes when no key is given.
    const std::map<std::string, std::string> used = read_parameter_defaults(info);
    std::map<std::string, std::string> shown;
    if (auto it = printed.find(info.name); it != printed.end()) shown = it->second;
    EXPECT_EQ(shown, used) << info.name;
    // Every listed parameter is read, and nothing else is.
    std::set<std::string> listed;
    for (const ParameterInfo& p : info.parameters) listed.insert(p.name);
    std::set<std::string> read;
    for (const auto& [key, value] : used) read.insert(key);
    EXPECT_EQ(listed, read) << info.name;
  }
}

TEST(Registry, GivingThePrintedDefaultChangesNothing) {
  // A default printed with too few digits would be a different value.
  for (const SolverInfo& info : solver_registry())
    for (const ParameterInfo& p : info.parameters) {
      ParamBag bag("solver '" + info.name + "'");
      bag.set(p.name, p.default_value);
      EXPECT_NO_THROW(make_solver(info.name, bag)) << info.name << " " << p.name;
      ParamBag twice("solver '" + info.name + "'");
      twice.set(p.name, p.default_value);
      info.make(twice);
      EXPECT_EQ(twice.defaults().at(p.name), p.default_value);
    }
}

TEST(Registry, KindIsTrueOfTheSolver) {
  Scene scene = make_builtin_scene("cube:rho=0.5");
  validate_scene(scene);
  const Mesh mesh = build_mesh(scene, {2, 0.0});
  RaycastOptions options;
  options.rays = 4;
  RaycastFormFactors ff(scene, mesh, options);
  BuildReport report;
  FormFactorMatrix matrix = build_matrix(ff, mesh.size(), Precision::kFloat, report);
  // Reciprocal to rounding, as every cached run has it: conjugate gradients refuses a matrix
  // whose reciprocity defect exceeds 1e-6, and this test is about kinds, not reciprocity.
  symmetrise(matrix, mesh.area);
  const System system(scene, mesh, matrix);
  int gathering = 0;
  for (const SolverInfo& info : solver_registry()) {
    if (info.name == "adaptive-shooting") continue;  // needs a two-level System
    ParamBag none("test");
    auto solver = make_solver(info.name, none);
    solver->init(system);
    switch (info.kind) {
      case SolverKind::kShooting:
        EXPECT_NE(solver->unshot(), nullptr) << info.name;
        break;
      case SolverKind::kGathering: {
        // One step gathers at one element: one row, and only that element changes.
        ++gathering;
        EXPECT_EQ(solver->unshot(), nullptr) << info.name;
        system.reset_counters();
        const Radiosity before = solver->solution();
        solver->step();
        EXPECT_EQ(system.rows_used(), 1u) << info.name;
        int changed = 0;
        for (size_t i = 0; i < mesh.size(); ++i)
          changed += before.mean(i) != solver->solution().mean(i);
        EXPECT_LE(changed, 1) << info.name;
        break;
      }
      case SolverKind::kOther:
        break;
    }
  }
  EXPECT_EQ(solver_info("jacobi").kind, SolverKind::kGathering);
  EXPECT_EQ(solver_info("gauss-seidel").kind, SolverKind::kGathering);
  EXPECT_EQ(gathering, 2);
}

TEST(Registry, DocsSolverTableNamesEverySolverAndParameter) {
  std::ifstream file(std::string(RADLAB_SOURCE_DIR) + "/docs/solvers.md");
  ASSERT_TRUE(file) << "docs/solvers.md";
  std::map<std::string, std::string> rows;  // solver -> its table row
  // The solver table is the page's first table: its rows start "| `name`"; it ends at the
  // first line that is not a table row (later tables, e.g. hierarchical's measurements, also
  // start with a backquoted cell and are not solver rows).
  std::string line;
  bool in_table = false;
  while (std::getline(file, line)) {
    const bool table_line = text::starts_with(line, "|");
    if (in_table && !table_line) break;
    in_table = in_table || table_line;
    if (text::starts_with(line, "| `")) {
      const size_t end = line.find('`', 3);
      rows[line.substr(3, end - 3)] = line;
    }
  }
  std::set<std::string> registered;
  for (const SolverInfo& info : solver_registry()) {
    registered.insert(info.name);
    auto it = rows.find(info.name);
    ASSERT_NE(it, rows.end()) << "docs/solvers.md has no row for " << info.name;
    for (const ParameterInfo& p : info.parameters)
      EXPECT_NE(it->second.find("`" + p.name + "`"), std::string::npos)
          << "docs/solvers.md's row for " << info.name << " lacks parameter " << p.name;
  }
  for (const auto& [name, row] : rows)
    EXPECT_TRUE(registered.count(name)) << "docs/solvers.md lists unknown solver " << name;
}

}  // namespace
}  // namespace radlab
