// Experiment files and sweeps: TOML parsing and its errors (file:line), the documented CSV
// columns, identical numbers on a re-run, shards merging to the unsplit result, and the runner's
// budgets and numerical-trouble detection.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>

#include "core/csv_reader.h"
#include "core/error.h"
#include "experiments/experiment_spec.h"
#include "experiments/merge.h"
#include "experiments/summary.h"
#include "experiments/sweep.h"
#include "experiments/trace.h"
#include "solvers/registry.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

using testing::TempDir;

template <class E, class Fn>
void expect_error(Fn fn, std::initializer_list<std::string> parts) {
  try {
    fn();
    FAIL() << "expected an error";
  } catch (const E& e) {
    for (const std::string& part : parts)
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos)
          << "message '" << e.what() << "' lacks '" << part << "'";
  }
}

const char* kTwoRuns = R"(name = "tiny"
scenes = ["builtin:cube:rho=0.8"]
subdiv = 2
solvers = ["gauss-seidel"]
[form_factors]
rays = 4
[budget]
rows = 200
[parameters.gauss-seidel]
omega = [1.0, 1.3]
)";

TEST(ExperimentSpec, ParsesAxesAndPlansRuns) {
  TempDir dir;
  ExperimentSpec spec = read_experiment(dir.write("e.toml", kTwoRuns));
  EXPECT_EQ(spec.name, "tiny");
  EXPECT_EQ(*spec.budget.rows, 200);
  EXPECT_EQ(spec.ff_parameters.at("rays"), "4");
  SweepPlan plan = plan_sweep(spec);
  ASSERT_EQ(plan.runs.size(), 2u);
  EXPECT_EQ(plan.runs[0].run_id, "gauss-seidel/scene:cube:rho=0.8/omega:1");
  EXPECT_EQ(plan.runs[1].run_id, "gauss-seidel/scene:cube:rho=0.8/omega:1.3");
  EXPECT_EQ(plan.problems.size(), 1u);
}

TEST(ExperimentSpec, AllMeansEveryRegisteredSolver) {
  TempDir dir;
  ExperimentSpec spec =
      read_experiment(dir.write("e.toml", "scenes = [\"builtin:cube\"]\nsolvers = [\"all\"]\n"));
  EXPECT_EQ(spec.solvers.size(), solver_registry().size());
}

TEST(ExperimentSpec, ErrorsNameFileAndLine) {
  TempDir dir;
  expect_error<InputError>(
      [&] {
        read_experiment(dir.write("a.toml",
                                  "scenes = [\"builtin:cube\"]\nsolvers = [\"jacobi\"]\n"
                                  "budgt = 3\n"));
      },
      {"a.toml:3", "budgt", "budget"});
  expect_error<InputError>(
      [&] {
        read_experiment(dir.write("b.toml",
                                  "scenes = [\"builtin:cube\"]\nsolvers = [\"jacobi\"]\n"
                                  "[budget]\nrows = 10\nsecs = 4\n"));
      },
      {"b.toml:5", "secs", "seconds"});
  expect_error<InputError>(
      [&] {
        read_experiment(dir.write("c.toml",
                                  "scenes = [\"builtin:cube\"]\nsolvers = [\"jacobi\"]\n"
                                  "[parameters.jacobi]\nomegaa = [1]\n"));
      },
      {"c.toml:4", "omegaa", "omega"});
  expect_error<InputError>(
      [&] { read_experiment(dir.write("d.toml", "scenes = [\"builtin:cube\"\nsolvers = 3\n")); },
      {"d.toml:"});
  expect_error<InputError>(
      [&] {
        read_experiment(
            dir.write("e.toml", "scenes = [\"builtin:cube\"]\nsolvers = [\"nosuch\"]\n"));
      },
      {"e.toml:2", "nosuch", "gauss-seidel"});
  expect_error<InputError>([&] { read_experiment(dir.file("missing.toml")); },
                           {"missing.toml", "no such file"});
}

// Everything but the columns that measure time.
std::vector<std::vector<std::string>> without_time(const CsvTable& table,
                                                   const std::vector<std::string>& time_columns) {
  std::vector<size_t> keep;
  for (size_t k = 0; k < table.header.size(); ++k)
    if (std::find(time_columns.begin(), time_columns.end(), table.header[k]) == time_columns.end())
      keep.push_back(k);
  std::vector<std::vector<std::string>> out;
  for (const auto& row : table.rows) {
    std::vector<std::string> kept;
    for (size_t k : keep) kept.push_back(row[k]);
    out.push_back(kept);
  }
  return out;
}

TEST(Sweep, WritesDocumentedColumnsAndRepeatsExactly) {
  TempDir dir;
  ExperimentSpec spec = read_experiment(dir.write("e.toml", kTwoRuns));
  SweepOptions first{dir.file("first"), 0, 1, "test"};
  SweepOptions second{dir.file("second"), 0, 1, "test"};
  EXPECT_EQ(run_sweep(spec, first).runs_done, 2u);
  run_sweep(spec, second);
  CsvTable trace1 = read_csv(dir.file("first/trace.csv"));
  CsvTable trace2 = read_csv(dir.file("second/trace.csv"));
  EXPECT_EQ(trace1.header, trace_columns());
  EXPECT_GT(trace1.rows.size(), 10u);
  CsvTable summary1 = read_csv(dir.file("first/summary.csv"));
  CsvTable summary2 = read_csv(dir.file("second/summary.csv"));
  EXPECT_EQ(summary1.header, summary_columns());
  EXPECT_EQ(summary1.rows.size(), 2u);
  const std::vector<std::string> trace_time = {"seconds"};
  EXPECT_EQ(without_time(trace1, trace_time), without_time(trace2, trace_time));
  EXPECT_EQ(without_time(summary1, summary_time_columns()),
            without_time(summary2, summary_time_columns()));
  EXPECT_TRUE(std::filesystem::exists(
      dir.file("first/runs/gauss-seidel_scene_cube_rho_0.8_omega_1.run.json")));
  // Both runs end on their budget, below the initial error.
  const size_t rms = summary1.column("rms_rel");
  for (const auto& row : summary1.rows) EXPECT_LT(std::stod(row[rms]), 0.1);
}

TEST(Sweep, ShardsMergeToTheUnsplitResult) {
  TempDir dir;
  const std::string text = std::string(kTwoRuns) + "";
  std::string three = text;
  three.replace(three.find("solvers = [\"gauss-seidel\"]"), 26,
                "solvers = [\"gauss-seidel\", \"jacobi\"]");
  ExperimentSpec spec = read_experiment(dir.write("e.toml", three));
  ASSERT_EQ(plan_sweep(spec).runs.size(), 3u);
  run_sweep(spec, {dir.file("whole"), 0, 1, "test"});
  run_sweep(spec, {dir.file("s0"), 0, 2, "test"});
  run_sweep(spec, {dir.file("s1"), 1, 2, "test"});
  EXPECT_EQ(merge_sweeps({dir.file("s1"), dir.file("s0")}, dir.file("merged")), 3u);
  const std::vector<std::string> trace_time = {"seconds"};
  EXPECT_EQ(without_time(read_csv(dir.file("merged/trace.csv")), trace_time),
            without_time(read_csv(dir.file("whole/trace.csv")), trace_time));
  EXPECT_EQ(without_time(read_csv(dir.file("merged/summary.csv")), summary_time_columns()),
            without_time(read_csv(dir.file("whole/summary.csv")), summary_time_columns()));
  // A run in two shards is refused.
  expect_error<InputError>(
      [&] {
        merge_sweeps({dir.file("s0"), dir.file("whole")}, dir.file("bad"));
      },
      {"is in"});
}

TEST(Sweep, PlotScriptRunsOnATrace) {
  if (std::system("/usr/bin/python3 -c 'import matplotlib, pandas' 2>/dev/null") != 0)
    GTEST_SKIP() << "python3-matplotlib/pandas not installed";
  TempDir dir;
  ExperimentSpec spec = read_experiment(dir.write("e.toml", kTwoRuns));
  run_sweep(spec, {dir.file("out"), 0, 1, "test"});
  const std::string script = std::string(RADLAB_SOURCE_DIR) + "/scripts/plot_traces.py";
  const std::string command =
      "/usr/bin/python3 " + script + " " + dir.file("out") + " --formats png,pdf > /dev/null";
  ASSERT_EQ(std::system(command.c_str()), 0);
  for (const char* name : {"cube_rho_0.8_rms_rel_vs_rows.png", "cube_rho_0.8_rms_rel_vs_rows.pdf",
                           "cube_rho_0.8_p_mean_vs_seconds.png"})
    EXPECT_TRUE(std::filesystem::exists(dir.file(std::string("out/plots/") + name))) << name;
}

// A solver that breaks after a few steps, to check the runner notices.
class BreakingSolver final : public Solver {
 public:
  void init(const System& system) override { B_ = system.emission(); }
  StepInfo step() override {
    if (++steps_ == 3) B_.at(0, 1) = std::nan("");
    return {};
  }
  const Radiosity& solution() const override { return B_; }

 private:
  Radiosity B_;
  int steps_ = 0;
};

TEST(Runner, NonFiniteSolutionIsANumericalError) {
  ProblemSpec spec;
  spec.scene = "builtin:cube";
  auto problem = prepare_problem(spec);
  BreakingSolver solver;
  Budget budget;
  budget.steps = 10;
  RunLabels labels{"breaking", "builtin:cube", "breaking", ""};
  try {
    run_solver(solver, *problem, budget, CheckpointSchedule{}, labels, nullptr);
    FAIL() << "expected a NumericalError";
  } catch (const NumericalError& e) {
    EXPECT_NE(std::string(e.what()).find("non-finite"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("step 3"), std::string::npos) << e.what();
  }
}

TEST(Runner, BudgetsStopWhereAsked) {
  ProblemSpec spec;
  spec.scene = "builtin:cube";
  spec.mesh.subdivisions = 2;
  auto problem = prepare_problem(spec);
  ParamBag none("test");
  for (long long rows : {1LL, 7LL, 100LL}) {
    auto solver = make_solver("gauss-seidel", none);
    Budget budget;
    budget.rows = rows;
    RunResult r =
        run_solver(*solver, *problem, budget, CheckpointSchedule{}, {"r", "", "", ""}, nullptr);
    EXPECT_EQ(static_cast<long long>(r.rows), rows);
    EXPECT_EQ(r.stop_reason, "row budget");
    EXPECT_EQ(r.history.back().rows, r.rows);  // the last step is always a checkpoint
  }
}

TEST(Summary, FirstReachInterpolatesInLogError) {
  std::vector<CheckpointRecord> history(3);
  history[0].rows = 0, history[0].rms_rel = 1.0;
  history[1].rows = 100, history[1].rms_rel = 1e-1;
  history[2].rows = 200, history[2].rms_rel = 1e-3;
  EXPECT_DOUBLE_EQ(first_reach(history, 1e-1, true, false), 100.0);
  EXPECT_NEAR(first_reach(history, 1e-2, true, false), 150.0, 1e-9);
  EXPECT_TRUE(std::isnan(first_reach(history, 1e-4, true, false)));
}

}  // namespace
}  // namespace radlab
