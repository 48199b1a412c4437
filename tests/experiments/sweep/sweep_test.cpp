// Experiment files and sweeps: TOML parsing and its errors (file:line), every shipped experiment
// file, the documented CSV columns, identical numbers on a re-run, failed runs recorded while the
// sweep goes on, shards merging to the unsplit result (coverage and sweep.json included), the
// coverage export, the summary's fits, and the runner's budgets and numerical-trouble detection.
#include "experiments/sweep/sweep.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "core/csv_reader.h"
#include "core/error.h"
#include "experiments/run/summary.h"
#include "experiments/run/trace.h"
#include "experiments/sweep/experiment_spec.h"
#include "experiments/sweep/merge.h"
#include "formfactor/form_factor_method.h"
#include "formfactor/registry.h"
#include "scene/scene_loader.h"
#include "solvers/registry.h"
#include "tests/experiment_fixtures.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

using testing::TempDir;

using testing::expect_error;

using radlab::testing::kTwoRuns;  // tests/experiment_fixtures.h

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
  // One level: every registered solver but adaptive-shooting, which needs patches (two levels
  // narrow "all" differently: tests/solvers/two_level/two_level_test.cpp), and the Monte Carlo
  // solvers, which a shared budget in rows would never end (needs_step_or_time_budget).
  EXPECT_EQ(spec.solvers.size(), solver_registry().size() - 3);
  for (const SolverSweep& s : spec.solvers) {
    EXPECT_NE(s.name, "stochastic-jacobi");
    EXPECT_NE(s.name, "random-walk");
  }
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
  // Budgets that cannot mean anything (a NaN time limit used to run forever).
  for (const char* budget :
       {"steps = -3", "rows = 0", "seconds = -1.0", "seconds = nan", "tol = 2.0", "tol = 0.0"}) {
    const std::string key = std::string(budget).substr(0, std::string(budget).find(' '));
    expect_error<InputError>(
        [&] {
          read_experiment(dir.write("f.toml",
                                    "scenes = [\"builtin:cube\"]\nsolvers = "
                                    "[\"jacobi\"]\n[budget]\n" +
                                        std::string(budget) + "\n"));
        },
        {"f.toml:4", "budget." + key});
  }
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
  const std::vector<std::string> trace_time = trace_time_columns();
  EXPECT_EQ(testing::without_columns(trace1, trace_time),
            testing::without_columns(trace2, trace_time));
  EXPECT_EQ(testing::without_columns(summary1, summary_time_columns()),
            testing::without_columns(summary2, summary_time_columns()));
  EXPECT_TRUE(std::filesystem::exists(
      dir.file("first/runs/gauss-seidel_scene_cube_rho_0.8_omega_1.run.json")));
  // Both runs end on their budget, below the initial error.
  const size_t rms = summary1.column("rms_rel");
  for (const auto& row : summary1.rows) EXPECT_LT(std::stod(row[rms]), 0.1);
}

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

// sweep.json without the lines that name how it was made (command, shard) and without the
// merged file's `merged_from` (the last key).
std::string sweep_json_content(const std::string& path) {
  std::string text = read_text(path);
  const size_t merged = text.find(",\n  \"merged_from\"");
  if (merged != std::string::npos) text = text.substr(0, merged) + "\n}\n";
  // The manifest: the digests of trace.csv, summary.csv and run.json hold the time columns.
  const size_t files = text.find(",\n  \"files\": [");
  if (files != std::string::npos) text.erase(files, text.find("\n  ]", files) + 4 - files);
  std::istringstream lines(text);
  std::string line, out;
  while (std::getline(lines, line))
    if (line.rfind("  \"command\":", 0) != 0 && line.rfind("  \"shard\":", 0) != 0)
      out += line + "\n";
  return out;
}

std::vector<std::string> files_in(const std::string& folder) {
  std::vector<std::string> names;
  if (!std::filesystem::exists(folder)) return names;
  for (const auto& entry : std::filesystem::directory_iterator(folder))
    names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

TEST(Sweep, ShardsMergeToTheUnsplitResult) {
  TempDir dir;
  // Four runs over two shards; interleaved writes coverage files, and every run images.
  std::string text = kTwoRuns;
  text.replace(text.find("solvers = [\"gauss-seidel\"]"), 26,
               "solvers = [\"gauss-seidel\", \"jacobi\", \"interleaved\"]");
  text +=
      "[parameters.interleaved]\nshots = 6\ngathers = 4\n"
      "[coverage]\nsteps = [3, 8]\n[images]\nsteps = [2]\nwidth = 16\nheight = 16\n";
  ExperimentSpec spec = read_experiment(dir.write("e.toml", text));
  ASSERT_EQ(plan_sweep(spec).runs.size(), 4u);
  run_sweep(spec, {dir.file("whole"), 0, 1, "test"});
  run_sweep(spec, {dir.file("s0"), 0, 2, "test"});
  run_sweep(spec, {dir.file("s1"), 1, 2, "test"});
  EXPECT_EQ(merge_sweeps({dir.file("s1"), dir.file("s0")}, dir.file("merged"), "radlab merge"), 4u);
  const std::vector<std::string> trace_time = trace_time_columns();
  EXPECT_EQ(testing::without_columns(read_csv(dir.file("merged/trace.csv")), trace_time),
            testing::without_columns(read_csv(dir.file("whole/trace.csv")), trace_time));
  EXPECT_EQ(
      testing::without_columns(read_csv(dir.file("merged/summary.csv")), summary_time_columns()),
      testing::without_columns(read_csv(dir.file("whole/summary.csv")), summary_time_columns()));
  // The same files in runs/, images/ and coverage/, and the coverage files byte for byte.
  for (const char* folder : {"runs", "images", "coverage"}) {
    const auto whole = files_in(dir.file(std::string("whole/") + folder));
    EXPECT_FALSE(whole.empty()) << folder;
    EXPECT_EQ(files_in(dir.file(std::string("merged/") + folder)), whole) << folder;
  }
  const auto coverage = files_in(dir.file("whole/coverage"));
  ASSERT_EQ(coverage.size(), 2u);
  for (const std::string& name : coverage)
    EXPECT_EQ(read_text(dir.file("merged/coverage/" + name)),
              read_text(dir.file("whole/coverage/" + name)))
        << name;
  // sweep.json: the unsplit one, but for how it was made.
  EXPECT_EQ(sweep_json_content(dir.file("merged/sweep.json")),
            sweep_json_content(dir.file("whole/sweep.json")));
  const std::string merged_json = read_text(dir.file("merged/sweep.json"));
  EXPECT_NE(merged_json.find("\"command\": \"radlab merge\""), std::string::npos);
  EXPECT_NE(merged_json.find("\"merged_from\""), std::string::npos);
  EXPECT_NE(merged_json.find("\"shard\": \"0/1\""), std::string::npos);
  // A run in two shards (here a whole sweep and one of its shards) is refused.
  expect_error<InputError>(
      [&] {
        merge_sweeps({dir.file("s0"), dir.file("whole")}, dir.file("bad"));
      },
      {"1-way split", "2-way split"});
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

// Every shipped experiment file parses, plans, names registered solvers with valid parameters,
// names scenes that load and form-factor settings the method accepts: a broken file in
// experiments/ fails here, not in a user's hands.
TEST(ShippedExperiments, EveryFileParsesAndItsRunsValidate) {
  namespace fs = std::filesystem;
  const fs::path folder = fs::path(RADLAB_SOURCE_DIR) / "experiments";
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(folder))
    if (entry.path().extension() == ".toml") files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  ASSERT_GE(files.size(), 4u) << "quick, cohen1988_fig7, wu2002_fig1 and an MGF experiment";
  std::set<std::string> names;
  for (const fs::path& file : files) {
    SCOPED_TRACE(file.string());
    ExperimentSpec spec;
    ASSERT_NO_THROW(spec = read_experiment(file.string()));
    names.insert(file.stem().string());
    SweepPlan plan = plan_sweep(spec);
    ASSERT_FALSE(plan.runs.empty());
    EXPECT_FALSE(spec.budget.empty()) << "a shipped experiment states its budget";
    std::set<std::string> ids;
    for (const PlannedRun& run : plan.runs) {
      SCOPED_TRACE(run.run_id);
      EXPECT_TRUE(ids.insert(run.run_id).second) << "duplicate run id";
      std::vector<std::string> assignments;
      for (const auto& [k, v] : run.parameters) assignments.push_back(k + "=" + v);
      ParamBag bag = ParamBag::from_assignments(assignments, "solver '" + run.solver + "'");
      EXPECT_NO_THROW(make_solver(run.solver, bag));
    }
    // Image and coverage steps a run can reach under a step budget.
    if (spec.budget.steps) {
      for (long long s : spec.images.steps) EXPECT_LE(s, *spec.budget.steps);
      for (long long s : spec.coverage_steps) EXPECT_LE(s, *spec.budget.steps);
    }
    for (const PlannedProblem& problem : plan.problems) {
      SCOPED_TRACE(problem.spec.scene);
      const bool builtin = problem.spec.scene.rfind("builtin:", 0) == 0;
      if (!builtin && !fs::exists(problem.spec.scene)) {
        // A file scene: from the shared folder beside the checkout. Missing only if that
        // folder is missing altogether (a clone without ../shared).
        const char* shared = std::getenv("RADLAB_SHARED_SCENES");
        EXPECT_FALSE(shared && fs::exists(shared))
            << problem.spec.scene << " does not exist although " << shared << " does";
        EXPECT_FALSE(radlab::testing::ci())
            << problem.spec.scene << " is missing (CI=true: the shared scenes are required)";
        continue;
      }
      LoadedScene loaded;
      ASSERT_NO_THROW(loaded = load_scene(problem.spec.scene, false));
      // The method's parameters validate (on the coarsest mesh: cheap).
      const Mesh mesh = build_mesh(loaded.scene, MeshOptions{});
      ParamBag ff = ParamBag::from_assignments(problem.spec.ff_set, "form factors");
      ff.get_bool("symmetrise", true);  // generic, read by prepare_problem (problem.cpp)
      EXPECT_NO_THROW(make_form_factor_method(problem.spec.ff_method, ff, loaded.scene, mesh));
    }
  }
  for (const char* required : {"quick", "cohen1988_fig7", "wu2002_fig1"})
    EXPECT_TRUE(names.count(required)) << required << ".toml is missing";
}

// Runs that fail are recorded and the sweep goes on: a problem whose reference cannot exist
// (closed box with reflectance 1: NumericalError), a solver parameter out of range (UsageError
// when the solver is made), and a run that stagnates mid-way (NumericalError from a step).
TEST(Sweep, FailedRunsAreRecordedAndTheSweepGoesOn) {
  TempDir dir;
  ExperimentSpec spec = read_experiment(dir.write("e.toml", R"(name = "failing"
scenes = ["builtin:cube:rho=1", "builtin:cube:rho=0.8"]
subdiv = 2
solvers = ["gauss-seidel", "jacobi"]
[form_factors]
rays = 4
[budget]
rows = 200
[parameters.jacobi]
omega = [1.0, 1.5]
)"));
  ASSERT_EQ(plan_sweep(spec).runs.size(), 6u);
  SweepReport report;
  ASSERT_NO_THROW(report = run_sweep(spec, {dir.file("out"), 0, 1, "test"}));
  EXPECT_EQ(report.runs_done, 6u);
  ASSERT_EQ(report.failures.size(), 4u);  // 3 on the rho=1 box, jacobi omega 1.5 on the other
  EXPECT_EQ(report.exit_code(), 4);       // a numerical failure outranks the usage error
  CsvTable summary = read_csv(dir.file("out/summary.csv"));
  EXPECT_EQ(summary.header, summary_columns());
  ASSERT_EQ(summary.rows.size(), 6u);
  const size_t stop = summary.column("stop_reason"), error = summary.column("error"),
               id = summary.column("run_id"), rms = summary.column("rms_rel");
  std::map<std::string, std::vector<std::string>> by_id;
  for (const auto& row : summary.rows) by_id[row[id]] = row;
  for (const char* failed : {"gauss-seidel/scene:cube:rho=1", "jacobi/scene:cube:rho=1/omega:1",
                             "jacobi/scene:cube:rho=1/omega:1.5"}) {
    ASSERT_TRUE(by_id.count(failed)) << failed;
    EXPECT_EQ(by_id[failed][stop], "failed: numerical error") << failed;
    EXPECT_NE(by_id[failed][error].find("no finite solution"), std::string::npos)
        << by_id[failed][error];
    EXPECT_EQ(by_id[failed][rms], "");
  }
  const auto& usage = by_id["jacobi/scene:cube:rho=0.8/omega:1.5"];
  EXPECT_EQ(usage[stop], "failed: usage error");
  EXPECT_NE(usage[error].find("omega"), std::string::npos) << usage[error];
  for (const char* ok : {"gauss-seidel/scene:cube:rho=0.8", "jacobi/scene:cube:rho=0.8/omega:1"}) {
    EXPECT_EQ(by_id[ok][stop], "row budget") << ok;
    EXPECT_EQ(by_id[ok][error], "") << ok;
    EXPECT_LT(std::stod(by_id[ok][rms]), 0.5) << ok;
  }
  // sweep.json is written and lists the failures; every run has its run.json.
  const std::string sweep = read_text(dir.file("out/sweep.json"));
  EXPECT_NE(sweep.find("\"failed\""), std::string::npos);
  EXPECT_NE(sweep.find("jacobi/scene:cube:rho=0.8/omega:1.5"), std::string::npos);
  EXPECT_EQ(files_in(dir.file("out/runs")).size(), 6u + 2u);  // + radiosity of the 2 ok runs
  const std::string failed_json =
      read_text(dir.file("out/runs/jacobi_scene_cube_rho_0.8_omega_1.5.run.json"));
  EXPECT_NE(failed_json.find("\"error\""), std::string::npos);
  EXPECT_NE(failed_json.find("\"exit_code\": 2"), std::string::npos);

  // Only a usage failure: exit code 2.
  ExperimentSpec usage_only = read_experiment(dir.write("u.toml", R"(scenes = ["builtin:cube"]
subdiv = 2
solvers = ["jacobi"]
[budget]
rows = 50
[parameters.jacobi]
omega = [1.5, 1.0]
)"));
  SweepReport u = run_sweep(usage_only, {dir.file("u"), 0, 1, "test"});
  EXPECT_EQ(u.runs_done, 2u);
  ASSERT_EQ(u.failures.size(), 1u);
  EXPECT_EQ(u.exit_code(), 2);
  EXPECT_EQ(u.failures[0].code, ExitCode::kUsage);

  // A failure during the steps: a tolerance below the float storage floor (F read in float,
  // ~8e-9 of max B* away; the reference's own floor is ~1.6e-15) stagnates. The trace keeps
  // the checkpoints written before it.
  ExperimentSpec stagnating = read_experiment(dir.write("s.toml", R"(scenes = ["builtin:cube"]
subdiv = 2
solvers = ["gauss-seidel"]
[budget]
tol = 1e-12
)"));
  SweepReport st = run_sweep(stagnating, {dir.file("s"), 0, 1, "test"});
  ASSERT_EQ(st.failures.size(), 1u);
  EXPECT_EQ(st.exit_code(), 4);
  EXPECT_NE(st.failures[0].message.find("stagnated"), std::string::npos) << st.failures[0].message;
  EXPECT_GT(read_csv(dir.file("s/trace.csv")).rows.size(), 10u);
  CsvTable s_summary = read_csv(dir.file("s/summary.csv"));
  ASSERT_EQ(s_summary.rows.size(), 1u);
  EXPECT_EQ(s_summary.rows[0][s_summary.column("stop_reason")], "failed: numerical error");
  EXPECT_TRUE(std::filesystem::exists(dir.file("s/sweep.json")));
}

// Wu & Wang's coverage export: the documented columns; dff non-negative and, within a shooting
// session, non-decreasing for every element; after the first shot exactly the shooter is marked
// and dff_j = F_sj A_s / A_j from the matrix.
TEST(Sweep, CoverageExportMatchesTheSolver) {
  TempDir dir;
  ExperimentSpec spec = read_experiment(dir.write("c.toml", R"(name = "coverage"
scenes = ["builtin:cornell"]
subdiv = 2
solvers = ["interleaved", "gauss-seidel"]
[form_factors]
rays = 4
[budget]
steps = 60
[parameters.interleaved]
shots = 20
gathers = 10
[coverage]
steps = [1, 5, 10, 20, 25, 35, 45]
)"));
  run_sweep(spec, {dir.file("out"), 0, 1, "test"});
  // Only the solver that tracks coverage writes files.
  const auto files = files_in(dir.file("out/coverage"));
  ASSERT_EQ(files.size(), 7u);
  for (const std::string& name : files) EXPECT_EQ(name.rfind("interleaved_", 0), 0u) << name;

  const SweepPlan plan = plan_sweep(spec);
  const std::string stem = file_stem(plan.runs[0].run_id);
  EXPECT_EQ(stem, "interleaved_scene_cornell_gathers_10_shots_20");
  ProblemSpec problem_spec = plan.problems[0].spec;
  auto problem = prepare_problem(problem_spec);
  const size_t n = problem->mesh.size();
  std::map<long long, CsvTable> by_step;
  for (long long step : spec.coverage_steps) {
    char name[64];
    std::snprintf(name, sizeof name, "_step%06lld.csv", step);
    by_step.emplace(step, read_csv(dir.file("out/coverage/" + stem + name)));
  }
  const std::vector<std::string> columns = {"step", "session", "element", "area", "dff",
                                            "shot", "p_mean",  "p_r",     "p_g",  "p_b"};
  for (const auto& [step, table] : by_step) {
    EXPECT_EQ(table.header, columns) << step;
    ASSERT_EQ(table.rows.size(), n) << step;
    for (const auto& row : table.rows) {
      EXPECT_EQ(std::stoll(row[0]), step);
      EXPECT_GE(std::stod(row[table.column("dff")]), 0.0);
      for (const char* p : {"p_mean", "p_r", "p_g", "p_b"})
        EXPECT_FALSE(row[table.column(p)].empty());
    }
  }
  // After one shot: the shooter s is the one element marked, and dff_j = F_sj A_s / A_j.
  const CsvTable& first = by_step.at(1);
  const size_t dff = first.column("dff"), shot = first.column("shot"),
               session = first.column("session");
  std::vector<size_t> shooters;
  for (size_t j = 0; j < n; ++j)
    if (first.rows[j][shot] == "1") shooters.push_back(j);
  ASSERT_EQ(shooters.size(), 1u);
  const size_t s = shooters[0];
  for (size_t j = 0; j < n; ++j) {
    const double expected =
        problem->matrix.at(s, j) * problem->mesh.area[s] / problem->mesh.area[j];
    EXPECT_NEAR(std::stod(first.rows[j][dff]), expected, 1e-12 + 1e-9 * expected) << j;
  }
  // Within a session dff only grows; a new session (after 20 shots and 10 gathers) restarts it.
  long long previous_step = -1;
  for (const auto& [step, table] : by_step) {
    if (previous_step >= 0) {
      const CsvTable& before = by_step.at(previous_step);
      if (before.rows[0][session] == table.rows[0][session]) {
        for (size_t j = 0; j < n; ++j) {
          EXPECT_GE(std::stod(table.rows[j][dff]), std::stod(before.rows[j][dff]))
              << "element " << j << " between steps " << previous_step << " and " << step;
        }
      }
    }
    previous_step = step;
  }
  EXPECT_EQ(by_step.at(25).rows[0][session], "1");  // gathering after session 1's 20 shots
  EXPECT_EQ(by_step.at(35).rows[0][session], "2");  // the second shooting session
  double session2_total = 0.0, session1_total = 0.0;
  for (size_t j = 0; j < n; ++j) {
    session1_total += std::stod(by_step.at(25).rows[j][dff]);
    session2_total += std::stod(by_step.at(35).rows[j][dff]);
  }
  EXPECT_LT(session2_total, session1_total);  // 5 shots of session 2 against 20 of session 1
}

// The summary's fits: against rows and seconds each with a sigma, and for gathering solvers the
// per-sweep rate from the sweep ends only, unbiased by where in a sweep a checkpoint falls.
TEST(Summary, FitsHaveSigmasAndThePerSweepRateUsesSweepEnds) {
  TempDir dir;
  const long long n = 50;
  const double rate = 0.6;  // per sweep
  RunResult result;
  for (long long rows = 0; rows <= 20 * n; rows += 7) {
    for (long long r : {(rows / n) * n, rows}) {  // the sweep end, then the checkpoint
      if (!result.history.empty() && r <= static_cast<long long>(result.history.back().rows))
        continue;
      CheckpointRecord c;
      c.step = r;
      c.rows = static_cast<unsigned long long>(r);
      c.seconds = 1e-3 * double(r) * (1.0 + 0.01 * std::sin(double(r)));  // a noisy clock
      // Geometric per sweep, with a staircase inside each sweep (the error falls mostly at the
      // sweep's start): what a mid-sweep checkpoint sees depends on its phase.
      const double sweeps = double(r) / double(n);
      const double phase = sweeps - std::floor(sweeps);
      c.rms_rel = std::pow(rate, std::floor(sweeps)) * (1.0 - (1.0 - rate) * std::sqrt(phase));
      c.p_mean = c.rms_rel;
      result.history.push_back(c);
    }
  }
  result.steps = static_cast<long long>(result.history.back().rows);
  result.rows = result.history.back().rows;
  result.stop_reason = "row budget";
  SummaryInputs in;
  in.labels = {"gauss-seidel/scene:x", "x", "gauss-seidel", ""};
  in.elements = size_t(n);
  in.channels = 1;
  in.gathering = true;
  in.spectral_radius = rate;
  {
    CsvWriter csv(dir.file("s.csv"), summary_columns());
    write_summary_row(csv, in, result);
  }
  CsvTable t = read_csv(dir.file("s.csv"));
  ASSERT_EQ(t.rows.size(), 1u);
  auto value = [&](const char* column) { return t.rows[0][t.column(column)]; };
  EXPECT_NEAR(std::stod(value("fit_rate_per_sweep")), rate, 1e-6);
  EXPECT_GE(std::stoi(value("fit_sweep_points")), 10);
  EXPECT_GE(std::stod(value("fit_rate_per_sweep_sigma")), 0.0);
  EXPECT_GE(std::stoi(value("fit_points")), 8);
  for (const char* sigma : {"fit_rate_per_row_sigma", "fit_rows_to_rms_rel_1e-6_sigma",
                            "fit_seconds_per_decade_sigma", "fit_seconds_to_rms_rel_1e-6_sigma"}) {
    ASSERT_FALSE(value(sigma).empty()) << sigma;
    EXPECT_GE(std::stod(value(sigma)), 0.0) << sigma;
  }
  EXPECT_GT(std::stod(value("fit_seconds_per_decade_sigma")), 0.0);  // the clock is noisy
  EXPECT_EQ(value("error"), "");
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
  EXPECT_DOUBLE_EQ(first_reach(history, 1e-1, ReachAxis::kRows, ReachMetric::kRmsRel), 100.0);
  EXPECT_NEAR(first_reach(history, 1e-2, ReachAxis::kRows, ReachMetric::kRmsRel), 150.0, 1e-9);
  EXPECT_TRUE(std::isnan(first_reach(history, 1e-4, ReachAxis::kRows, ReachMetric::kRmsRel)));
}

}  // namespace
}  // namespace radlab
