// One run is one library call (experiments/run/run_request.h): `radlab solve` and a one-run sweep
// of the same request go through execute_run alike, so they write the same trace rows (apart
// from the solver-time column, which measures the machine) and the same final radiosities.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "core/csv_reader.h"
#include "experiments/run/trace.h"
#include "tests/experiment_fixtures.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

using testing::TempDir;

testing::CommandResult radlab(const std::string& arguments) {
  return testing::run_command("timeout 300 " + std::string(RADLAB_BINARY) + " " + arguments);
}

std::string file_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// The trace's rows without its time columns.
std::vector<std::vector<std::string>> timeless_rows(const std::string& path) {
  return testing::without_columns(read_csv(path), trace_time_columns());
}

TEST(OneRun, SolveAndAOneRunSweepWriteTheSameRows) {
  TempDir dir;
  // Gauss-Seidel with a parameter, on RGB elements: every channel's row, the parameter in the
  // run id and the params column. 30 steps: below the sweep's tail-checkpoint threshold and
  // within the first sweep, so the sweep's schedule is the default one solve uses.
  const std::string experiment = dir.write("one.toml",
                                           "name = \"one\"\n"
                                           "scenes = [\"builtin:cornell\"]\n"
                                           "subdiv = 2\n"
                                           "solvers = [\"gauss-seidel\"]\n"
                                           "[budget]\nsteps = 30\n"
                                           "[parameters.gauss-seidel]\nomega = [1.2]\n");
  auto sweep = radlab("run " + experiment + " --out " + dir.file("sweep"));
  ASSERT_EQ(sweep.code, 0) << sweep.output;
  auto solve = radlab(
      "solve builtin:cornell --subdiv 2 --solver gauss-seidel --set omega=1.2 "
      "--steps 30 --trace " +
      dir.file("solve/trace.csv") + " --out " + dir.file("solve/b.csv"));
  ASSERT_EQ(solve.code, 0) << solve.output;

  const auto from_sweep = timeless_rows(dir.file("sweep/trace.csv"));
  const auto from_solve = timeless_rows(dir.file("solve/trace.csv"));
  ASSERT_EQ(read_csv(dir.file("sweep/trace.csv")).header,
            read_csv(dir.file("solve/trace.csv")).header);
  // 17 checkpoints (steps 0..10, then 20% apart, and 30) x 4 rows (mean, r, g, b).
  EXPECT_GT(from_solve.size(), 40u);
  EXPECT_EQ(from_sweep, from_solve);
  EXPECT_EQ(file_text(dir.file("sweep/runs/gauss-seidel_scene_cornell_omega_1.2.radiosity.csv")),
            file_text(dir.file("solve/b.csv")));
}

}  // namespace
}  // namespace radlab
