// Formats a user's tools read back (issue 15): EXR images carry their provenance as header
// attributes, `radlab solve` and `radlab run` spell a run id the same way, and numbers in run
// ids are the shortest text of the value (omega:0.6, not omega:0.59999999999999998).
#include <gtest/gtest.h>

#include <map>
#include <string>

#include "experiments/sweep/experiment_spec.h"
#include "render/exr_io.h"
#include "scene/builtin/builtin_scenes.h"
#include "scene/mesh.h"
#include "scene/scene_loader.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

using radlab::testing::TempDir;

std::map<std::string, std::string> attributes_of(const std::string& path) {
  std::map<std::string, std::string> out;
  for (const auto& [name, value] : read_exr_attributes(path)) out[name] = value;
  return out;
}

TEST(Exr, AttributesRoundTrip) {
  TempDir dir;
  Image image(3, 2);
  write_exr(dir.file("a.exr"), image, {{"radlab.run_id", "x/scene:cube"}, {"radlab.step", "7"}});
  const auto attributes = attributes_of(dir.file("a.exr"));
  EXPECT_EQ(attributes.at("radlab.run_id"), "x/scene:cube");
  EXPECT_EQ(attributes.at("radlab.step"), "7");
}

TEST(RunId, SolveAndRunSpellTheSameRunTheSameWay) {
  TempDir dir;
  // omega 0.6 has no exact double: the id must still read 0.6.
  const ExperimentSpec spec =
      read_experiment(dir.write("e.toml",
                                "name = \"ids\"\nscenes = [\"builtin:cube:rho=0.5\"]\n"
                                "solvers = [\"gauss-seidel\"]\nsubdiv = 2\n[budget]\nrows = 30\n"
                                "[parameters.gauss-seidel]\nomega = [0.6]\n"));
  const SweepPlan plan = plan_sweep(spec);
  ASSERT_EQ(plan.runs.size(), 1u);
  EXPECT_EQ(plan.runs[0].run_id, "gauss-seidel/scene:cube:rho=0.5/omega:0.6");

  const auto solve = radlab::testing::run_command(
      std::string(RADLAB_BINARY) + " -q solve builtin:cube:rho=0.5 --subdiv 2 --ff-set rays=4 " +
      "--solver gauss-seidel --set omega=0.6 --rows 30 --image " + dir.file("s.exr"));
  ASSERT_EQ(solve.code, 0) << solve.output;
  EXPECT_NE(solve.output.find("run          " + plan.runs[0].run_id + "\n"), std::string::npos)
      << solve.output;

  // The image says which run, scene, solver, step and rows made it, and the code's revision.
  const auto attributes = attributes_of(dir.file("s.exr"));
  EXPECT_EQ(attributes.at("radlab.run_id"), plan.runs[0].run_id);
  EXPECT_EQ(attributes.at("radlab.scene"), "builtin:cube:rho=0.5");
  EXPECT_EQ(attributes.at("radlab.solver"), "gauss-seidel");
  EXPECT_EQ(attributes.at("radlab.rows"), "30");
  EXPECT_EQ(attributes.at("radlab.step"), "30");  // one row per gathering step
  EXPECT_FALSE(attributes.at("radlab.git_sha").empty());
}

TEST(Version, PrintsVersionRevisionAndDependencies) {
  const auto r = radlab::testing::run_command(std::string(RADLAB_BINARY) + " --version");
  EXPECT_EQ(r.code, 0) << r.output;
  for (const char* part : {"radlab 0.", "(git ", "Embree: ", "OpenEXR: ", "oneTBB: ", "Ceres: "})
    EXPECT_NE(r.output.find(part), std::string::npos) << part << " in\n" << r.output;
}

// `radlab scenes` gives the element counts the mesher really makes, beside the papers'.
TEST(Scenes, PaperRoomsListTheirRealElementCounts) {
  const std::map<std::string, std::pair<int, std::string>> rooms = {
      {"room", {2, "1,360 elements (the paper's: 1,336)"}},
      {"computer-room", {3, "4,860 elements (the paper's: 4,953)"}}};
  for (const BuiltinScene& scene : builtin_scenes()) {
    auto it = rooms.find(scene.name);
    if (it == rooms.end()) continue;
    EXPECT_NE(scene.summary.find(it->second.second), std::string::npos) << scene.summary;
    const Mesh mesh =
        build_mesh(load_scene("builtin:" + scene.name, false).scene, {it->second.first, 0.0});
    const std::string count = it->second.second.substr(0, it->second.second.find(' '));
    std::string digits;
    for (char c : count)
      if (c != ',') digits += c;
    EXPECT_EQ(mesh.size(), std::stoul(digits)) << scene.name;
  }
}

}  // namespace
}  // namespace radlab
