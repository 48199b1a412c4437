// The command line end to end: every bad input of the foundation issue gives a clear message and
// the documented exit code (2 usage, 3 invalid input, 4 numerical failure), never a crash or hang;
// and the happy path writes the files it promises.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "tests/test_support.h"

namespace radlab {
namespace {

using testing::TempDir;

using Result = radlab::testing::CommandResult;

Result radlab(const std::string& arguments) {
  // `timeout` turns a hang into a failure (exit 124) instead of a stuck test.
  return radlab::testing::run_command("timeout 120 " + std::string(RADLAB_BINARY) + " " +
                                      arguments);
}

#define EXPECT_OUTPUT_HAS(result, text) \
  EXPECT_NE((result).output.find(text), std::string::npos) << (result).output

TEST(Cli, HelpEverywhere) {
  for (const char* command :
       {"", "scenes", "solvers", "formfactors", "reference", "solve", "run", "merge", "prepare"}) {
    Result r = radlab(std::string(command) + " --help");
    EXPECT_EQ(r.code, 0) << command << ": " << r.output;
    EXPECT_OUTPUT_HAS(r, "Usage");
  }
}

TEST(Cli, ReadmeSolverTableIsTheRegistry) {
  // The README's table is `radlab solvers --markdown`: a solver added, renamed or re-described
  // without updating the README fails here.
  Result table = radlab("solvers --markdown");
  ASSERT_EQ(table.code, 0) << table.output;
  std::ifstream file(std::string(RADLAB_SOURCE_DIR) + "/README.md");
  std::ostringstream text;
  text << file.rdbuf();
  const std::string readme = text.str();
  EXPECT_NE(readme.find(table.output), std::string::npos)
      << "README.md must contain the output of `radlab solvers --markdown`:\n"
      << table.output;
}

TEST(Cli, MissingFileIsInvalidInput) {
  Result r = radlab("solve /nonexistent/box.obj --solver gauss-seidel");
  EXPECT_EQ(r.code, 3);
  EXPECT_OUTPUT_HAS(r, "/nonexistent/box.obj");
}

TEST(Cli, MalformedObjNamesFileAndLine) {
  TempDir dir;
  dir.write("m.mtl", "newmtl a\nKd 0.5 0.5 0.5\nKe 1 1 1\n");
  const std::string obj = dir.write("bad.obj", "mtllib m.mtl\nusemtl a\nv 0 0 0\nv 1 0\n");
  Result r = radlab("solve " + obj + " --solver gauss-seidel");
  EXPECT_EQ(r.code, 3);
  EXPECT_OUTPUT_HAS(r, "bad.obj:4");
}

TEST(Cli, BadMaterialNamesTheMaterial) {
  TempDir dir;
  dir.write("m.mtl", "newmtl glossy\nKd 0.5 1.5 0.5\n");
  const std::string obj =
      dir.write("s.obj", "mtllib m.mtl\nusemtl glossy\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  Result r = radlab("scenes " + obj);
  EXPECT_EQ(r.code, 3);
  EXPECT_OUTPUT_HAS(r, "glossy");
}

TEST(Cli, DegenerateAndNonPlanarPolygonsAreRepairedWithWarnings) {
  TempDir dir;
  dir.write("m.mtl", "newmtl a\nKd 0.5 0.5 0.5\nKe 1 1 1\n");
  const std::string obj =
      dir.write("s.obj",
                "mtllib m.mtl\nusemtl a\nv 0 0 0\nv 1 0 0\nv 1 1 0.2\nv 0 1 0\nv 2 0 0\n"
                "f 1 2 3 4\nf 1 2 5\n");
  Result r = radlab("scenes " + obj);
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_OUTPUT_HAS(r, "s.obj:8: non-planar");
  EXPECT_OUTPUT_HAS(r, "s.obj:9: zero-area");
}

TEST(Cli, UnknownNamesAndKeysListTheValidOnes) {
  Result solver = radlab("solve builtin:cube --solver gauss-seidl");
  EXPECT_EQ(solver.code, 2);
  EXPECT_OUTPUT_HAS(solver, "gauss-seidel");
  Result scene = radlab("solve builtin:cub --solver gauss-seidel");
  EXPECT_EQ(scene.code, 2);
  EXPECT_OUTPUT_HAS(scene, "cornell");
  Result key = radlab("solve builtin:cube --solver gauss-seidel --set omga=1.1");
  EXPECT_EQ(key.code, 2);
  EXPECT_OUTPUT_HAS(key, "omega");
  Result scene_key = radlab("solve builtin:cube:rhoo=0.3 --solver gauss-seidel");
  EXPECT_EQ(scene_key.code, 2);
  EXPECT_OUTPUT_HAS(scene_key, "rho");
  Result ff_key = radlab("solve builtin:cube --solver gauss-seidel --ff-set rayz=3");
  EXPECT_EQ(ff_key.code, 2);
  EXPECT_OUTPUT_HAS(ff_key, "rays");
  Result option = radlab("solve builtin:cube --solver gauss-seidel --no-such-option");
  EXPECT_EQ(option.code, 2);
}

TEST(Cli, BadBudgetsAreUsageErrorsNamingTheOption) {
  // A budget that cannot mean anything must not silently fall back to the default.
  for (const char* budget : {"--steps -3", "--steps 0", "--rows -5", "--seconds -1",
                             "--seconds nan", "--seconds inf", "--tol -1", "--tol 0", "--tol 2"}) {
    Result r = radlab(std::string("solve builtin:cube --solver gauss-seidel ") + budget);
    EXPECT_EQ(r.code, 2) << budget << ": " << r.output;
    const std::string option = std::string(budget).substr(0, std::string(budget).find(' '));
    EXPECT_OUTPUT_HAS(r, option);
  }
}

TEST(Cli, SceneWithoutEmitter) {
  TempDir dir;
  dir.write("m.mtl", "newmtl a\nKd 0.5 0.5 0.5\n");
  const std::string obj =
      dir.write("s.obj", "mtllib m.mtl\nusemtl a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  Result r = radlab("solve " + obj + " --solver gauss-seidel");
  EXPECT_EQ(r.code, 3);
  EXPECT_OUTPUT_HAS(r, "no emitter");
}

TEST(Cli, ClosedSceneReflectingEverythingFailsNumericallyWithoutHanging) {
  Result r = radlab("solve builtin:furnace:rho=1 --subdiv 2 --solver gauss-seidel");
  EXPECT_EQ(r.code, 4);
  EXPECT_OUTPUT_HAS(r, "no finite solution");
}

TEST(Cli, SolveWritesTraceRadiositiesJsonAndImage) {
  TempDir dir;
  Result r = radlab(
      "-q solve builtin:cube:rho=0.7 --subdiv 2 --solver gauss-seidel --steps 500 "
      "--trace " +
      dir.file("t.csv") + " --out " + dir.file("b.csv") + " --image " + dir.file("i.exr") +
      " --width 32 --height 32");
  ASSERT_EQ(r.code, 0) << r.output;
  for (const char* f : {"t.csv", "b.csv", "t.run.json", "i.exr", "i.png"})
    EXPECT_TRUE(std::filesystem::exists(dir.file(f))) << f;
  std::ifstream b(dir.file("b.csv"));
  std::string header;
  std::getline(b, header);
  EXPECT_EQ(header, "element,area,B_r,B_g,B_b");
}

TEST(Cli, ToleranceBudgetIsCertified) {
  // Double storage: with float, its rounding floors the bound of the double system near 1.4e-8.
  Result r = radlab(
      "solve builtin:cube:rho=0.9 --subdiv 2 --precision double --solver gauss-seidel --tol 1e-8");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_OUTPUT_HAS(r, "tolerance reached");
}

TEST(Cli, ToleranceBelowTheCertifiableFloorIsRefusedNamingIt) {
  // No certified bound can go below the reference's own (rounding of B* to double and of the
  // residual sum): 1e-30 cannot be certified, and saying "stagnated" (exit 4) after solving
  // blamed solvers that had converged (issue 35.3). Refused before solving, with the floor.
  Result r = radlab("solve builtin:cube:rho=0.5 --subdiv 2 --solver gauss-seidel --tol 1e-30");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_OUTPUT_HAS(r, "below the certifiable floor");
  EXPECT_OUTPUT_HAS(r, "the reference's own certified bound is");
  // The case: 1e-9 of the reflected light on the rho 0.05 room is 4.6e-18 of max B*
  // (the lamp's), below the reference's ~1.4e-16; it used to end "stagnated", nothing written.
  r = radlab(
      "solve builtin:tiny-light:rho=0.05 --solver gauss-seidel --tol 1e-9 --tol-of reflected");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_OUTPUT_HAS(r, "of max(B* - E) is below the certifiable floor");
  EXPECT_OUTPUT_HAS(r, "of max(B* - E))");
}

TEST(Cli, NegativeRadiositiesAreSaidInTheVerdict) {
  // Over-relaxed Gauss-Seidel leaves 44 radiosities below zero on the Cornell box after 3,000
  // rows (lowest -0.150); it used to end exit 0 with no word (issue 35.5).
  Result r =
      radlab("solve builtin:cornell --subdiv 4 --solver gauss-seidel --set omega=1.9 --rows 3000");
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_OUTPUT_HAS(r, "radiosity values are negative (lowest");
  EXPECT_OUTPUT_HAS(r, "negative_radiosities");
}

TEST(Cli, ToleranceNotReachedExitsFiveAfterWritingEverything) {
  // Gauss-Seidel on the rho = 0.99 cube stops at the 1,000-sweep cap of a tolerance alone with a
  // certified bound of 3.6e-9: exit 5, said plainly, and run.json written.
  TempDir dir;
  Result r = radlab(
      "solve builtin:cube:rho=0.99 --ff exact --precision double "
      "--solver gauss-seidel --tol 1e-10 --trace " +
      dir.file("t.csv"));
  EXPECT_EQ(r.code, 5) << r.output;
  EXPECT_OUTPUT_HAS(r, "tolerance 1e-10 of max B* not reached");
  std::ifstream json(dir.file("t.run.json"));
  std::stringstream text;
  text << json.rdbuf();
  EXPECT_NE(text.str().find("\"tolerance_reached\": false"), std::string::npos) << text.str();
}

// With float storage (the default) run.json states the floor the rounding of F sets for the
// solvers beside the certificate of the double system (issue 35.6); with double storage there
// is none to state.
TEST(Cli, RunJsonStatesTheFloatStorageFloor) {
  TempDir dir;
  for (const char* precision : {"float", "double"}) {
    const std::string trace = dir.file(std::string(precision) + ".csv");
    Result r =
        radlab("solve builtin:cube:rho=0.9 --subdiv 2 --solver jacobi --steps 3 --precision " +
               std::string(precision) + " --trace " + trace);
    ASSERT_EQ(r.code, 0) << r.output;
    std::ifstream json(dir.file(std::string(precision) + ".run.json"));
    std::stringstream text;
    text << json.rdbuf();
    const bool stated = text.str().find("\"float_storage_bound_inf\"") != std::string::npos;
    EXPECT_EQ(stated, std::string(precision) == "float") << precision << "\n" << text.str();
  }
}

// --sample-rows computes only the drawn rows; drawing every row checks the same sums as the
// whole build (the same rows, computed on the fly instead of in a matrix).
TEST(Cli, FormfactorsSampledRowsCheckWhatTheWholeBuildChecks) {
  const auto row_sums = [](const std::string& output) {
    const size_t at = output.find("row sums of F [");
    return at == std::string::npos ? std::string("missing")
                                   : output.substr(at, output.find(']', at) - at);
  };
  Result whole = radlab("-q formfactors builtin:cornell");
  ASSERT_EQ(whole.code, 0) << whole.output;
  Result all = radlab("-q formfactors builtin:cornell --sample-rows 1000000 --sample-seed 3");
  ASSERT_EQ(all.code, 0) << all.output;
  EXPECT_OUTPUT_HAS(all, "(the sampled rows)");
  EXPECT_EQ(row_sums(all.output), row_sums(whole.output));
  Result some = radlab("-q formfactors builtin:cornell --sample-rows 5");
  ASSERT_EQ(some.code, 0) << some.output;
  EXPECT_OUTPUT_HAS(some, "sampled      5 of ");
  Result refused = radlab("-q formfactors builtin:cornell --sample-rows 5 --out x.csv");
  EXPECT_EQ(refused.code, 2) << refused.output;
  EXPECT_OUTPUT_HAS(refused, "drop --sample-rows");
}

TEST(Cli, FormfactorsAndReferenceWriteCsv) {
  TempDir dir;
  Result f = radlab("-q formfactors builtin:cube --subdiv 2 --out " + dir.file("f.csv"));
  ASSERT_EQ(f.code, 0) << f.output;
  EXPECT_OUTPUT_HAS(f, "visibility rays: none");
  std::ifstream in(dir.file("f.csv"));
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header, "i,j,F");
  Result ref = radlab("-q reference builtin:cube --out " + dir.file("r.csv"));
  ASSERT_EQ(ref.code, 0) << ref.output;
  EXPECT_OUTPUT_HAS(ref, "||B - B*||_inf <=");
}

}  // namespace
}  // namespace radlab
