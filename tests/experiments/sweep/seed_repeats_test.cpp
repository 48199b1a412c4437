// Solver seeds as a sweep dimension (docs/experiments.md, `solver_seeds` / `repeats`): each seed
// is its own run id and reaches the solver as `seed`; a solver without a seed is refused; the
// aggregate's mean and band are those of the summary rows; a resumed sweep and a merge of shards
// give the unsplit sweep's aggregate.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "core/csv.h"
#include "core/csv_reader.h"
#include "core/error.h"
#include "core/json.h"
#include "core/json_reader.h"
#include "core/text.h"
#include "experiments/run/seed_aggregate.h"
#include "experiments/run/summary.h"
#include "experiments/sweep/experiment_spec.h"
#include "experiments/sweep/merge.h"
#include "experiments/sweep/sweep.h"
#include "experiments/sweep/sweep_folder.h"
#include "tests/experiment_fixtures.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

namespace fs = std::filesystem;
using testing::expect_error;
using testing::TempDir;

// Four seeds of stochastic Jacobi on a small cube: 8 steps of 2000 rays each.
constexpr const char* kRepeats = R"(name = "repeats"
scenes = ["builtin:cube:rho=0.8"]
subdiv = 2
solvers = ["stochastic-jacobi"]
repeats = 4
[budget]
steps = 8
[parameters.stochastic-jacobi]
rays = 2000
)";

std::string read_text_file(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

double number(const std::string& field) {
  return field.empty() ? std::nan("") : std::stod(field);
}

TEST(SolverSeeds, RepeatsAndSolverSeedsBecomeTheSeedAxis) {
  TempDir dir;
  const SweepPlan plan = plan_sweep(read_experiment(dir.write("e.toml", kRepeats)));
  ASSERT_EQ(plan.runs.size(), 4u);
  std::set<std::string> ids;
  for (size_t k = 0; k < plan.runs.size(); ++k) {
    const PlannedRun& run = plan.runs[k];
    EXPECT_EQ(run.parameters.at("seed"), std::to_string(k));
    EXPECT_NE(run.run_id.find("/seed:" + std::to_string(k)), std::string::npos) << run.run_id;
    EXPECT_EQ(run.configuration, "stochastic-jacobi/scene:cube:rho=0.8/rays:2000");
    ids.insert(run.run_id);
  }
  EXPECT_EQ(ids.size(), 4u);

  std::string listed = kRepeats;
  listed.replace(listed.find("repeats = 4"), 11, "solver_seeds = [7, 3]");
  const SweepPlan seeds = plan_sweep(read_experiment(dir.write("s.toml", listed)));
  ASSERT_EQ(seeds.runs.size(), 2u);
  EXPECT_EQ(seeds.runs[0].parameters.at("seed"), "7");
  EXPECT_EQ(seeds.runs[1].parameters.at("seed"), "3");
}

TEST(SolverSeeds, ErrorsNameTheSolverAndTheKey) {
  TempDir dir;
  // A solver without a seed would give K identical runs.
  std::string unseeded = kRepeats;
  unseeded.replace(unseeded.find("[\"stochastic-jacobi\"]"), 21,
                   "[\"stochastic-jacobi\", \"jacobi\"]");
  expect_error<InputError>([&] { read_experiment(dir.write("u.toml", unseeded)); },
                           {"u.toml:5", "repeats", "'jacobi'", "no 'seed' parameter"});
  std::string both = kRepeats + std::string("seed = [1, 2]\n");
  expect_error<InputError>([&] { read_experiment(dir.write("b.toml", both)); },
                           {"b.toml:5", "[parameters.stochastic-jacobi]", "seed"});
  std::string two_keys = kRepeats;
  two_keys.replace(two_keys.find("repeats = 4"), 11, "repeats = 4\nsolver_seeds = [1]");
  expect_error<InputError>([&] { read_experiment(dir.write("t.toml", two_keys)); },
                           {"t.toml:", "not both"});
  for (const char* bad : {"repeats = 0", "repeats = 2.5", "solver_seeds = [-1]",
                          "solver_seeds = [1, 1]", "solver_seeds = []"}) {
    std::string text = kRepeats;
    text.replace(text.find("repeats = 4"), 11, bad);
    expect_error<InputError>([&] { read_experiment(dir.write("x.toml", text)); }, {"x.toml:5"});
  }
}

// The unsplit sweep: four run ids with four different results, and an aggregate whose mean and
// band are those of the four summary rows.
TEST(SolverSeeds, AggregateIsTheMeanAndBandOfTheSummaryRows) {
  TempDir dir;
  const ExperimentSpec spec = read_experiment(dir.write("e.toml", kRepeats));
  const SweepReport report = run_sweep(spec, {dir.file("out"), 0, 1, "test"});
  ASSERT_EQ(report.exit_code(), 0);
  const CsvTable summary = read_csv(dir.file("out/summary.csv"));
  ASSERT_EQ(summary.rows.size(), 4u);
  std::set<std::string> ids, results;
  double sum = 0.0;
  std::vector<double> values;
  for (const auto& row : summary.rows) {
    ids.insert(row[summary.column("run_id")]);
    results.insert(row[summary.column("rms_rel")]);
    EXPECT_EQ(row[summary.column("configuration")],
              "stochastic-jacobi/scene:cube:rho=0.8/rays:2000");
    values.push_back(number(row[summary.column("rms_rel")]));
    sum += values.back();
  }
  EXPECT_EQ(ids.size(), 4u);
  EXPECT_EQ(results.size(), 4u) << "each seed must reach the solver and change its result";

  const CsvTable aggregate = read_csv(dir.file("out/aggregate.csv"));
  ASSERT_EQ(aggregate.rows.size(), 1u);
  const auto& row = aggregate.rows[0];
  EXPECT_EQ(row[aggregate.column("seeds")], "4");
  EXPECT_EQ(row[aggregate.column("seed_list")], "0;1;2;3");
  EXPECT_EQ(row[aggregate.column("params")], "rays=2000");
  const double mean = sum / 4.0;
  // Both are sums of the same four doubles read back at 17 digits: equal to rounding.
  EXPECT_NEAR(number(row[aggregate.column("rms_rel_mean")]), mean, 1e-14 * mean);
  double squares = 0.0;
  for (double v : values) squares += (v - mean) * (v - mean);
  const double sd = std::sqrt(squares / 3.0);
  EXPECT_NEAR(number(row[aggregate.column("rms_rel_sd")]), sd, 1e-12 * mean);
  // t(0.95, 3 degrees of freedom) = 2.353363 (every Student-t table, e.g. NIST/SEMATECH
  // e-Handbook 1.3.6.7.2); the table gives 7 digits.
  EXPECT_NEAR(student_t_90(4), 2.353363, 1e-6);
  EXPECT_NEAR(number(row[aggregate.column("t90")]), 2.353363, 1e-6);
  EXPECT_NEAR(number(row[aggregate.column("rms_rel_band_low")]), mean - 2.353363 * sd / 2.0,
              1e-6 * mean);
  EXPECT_NEAR(number(row[aggregate.column("rms_rel_band_high")]), mean + 2.353363 * sd / 2.0,
              1e-6 * mean);
  EXPECT_TRUE(std::isnan(student_t_90(1)));
  // The aggregate is one of the sweep's files: in its manifest.
  EXPECT_NE(read_text_file(dir.file("out/sweep.json")).find("\"aggregate.csv\""),
            std::string::npos);

  // A sweep without solver seeds writes none.
  const ExperimentSpec plain = read_experiment(dir.write("p.toml", testing::kTwoRuns));
  run_sweep(plain, {dir.file("plain"), 0, 1, "test"});
  EXPECT_FALSE(fs::exists(dir.file("plain/aggregate.csv")));
}

// Shards hold some seeds each and write no aggregate; their merge writes the unsplit one's.
TEST(SolverSeeds, MergedShardsGiveTheUnsplitAggregate) {
  TempDir dir;
  const ExperimentSpec spec = read_experiment(dir.write("e.toml", kRepeats));
  run_sweep(spec, {dir.file("whole"), 0, 1, "test"});
  run_sweep(spec, {dir.file("s0"), 0, 2, "test"});
  run_sweep(spec, {dir.file("s1"), 1, 2, "test"});
  EXPECT_FALSE(fs::exists(dir.file("s0/aggregate.csv")));
  EXPECT_EQ(merge_sweeps({dir.file("s1"), dir.file("s0")}, dir.file("merged"), "radlab merge"), 4u);
  const CsvTable merged = read_csv(dir.file("merged/aggregate.csv"));
  const CsvTable whole = read_csv(dir.file("whole/aggregate.csv"));
  EXPECT_EQ(merged.header, whole.header);
  EXPECT_EQ(merged.rows, whole.rows);
}

// An interrupted sweep (runs 0 and 1 complete, 2 and 3 not started) resumes by run id: the
// seeds already done are kept, the others run, and the aggregate is the unsplit one's.
TEST(SolverSeeds, ResumedSweepKeepsTheSeedsDoneAndGivesTheSameAggregate) {
  TempDir dir;
  const ExperimentSpec spec = read_experiment(dir.write("e.toml", kRepeats));
  run_sweep(spec, {dir.file("whole"), 0, 1, "test"});
  const fs::path out = dir.file("out");
  fs::copy(dir.file("whole"), out, fs::copy_options::recursive);
  // The folder as an attempt killed after two runs leaves it: sweep.json "running", the two
  // runs' rows in the partial folder, no tables, no run.json of the runs not started.
  Json sweep = read_json_file((out / "sweep.json").string());
  sweep["status"] = "running";
  sweep.erase("files");
  JsonWriter json;
  write_json_value(json, sweep);
  json.save((out / "sweep.json").string());
  const CsvTable summary = read_csv((out / "summary.csv").string());
  const CsvTable trace = read_csv((out / "trace.csv").string());
  fs::create_directories(partial_folder(out));
  const SweepPlan plan = plan_sweep(spec);
  for (size_t index : {size_t(0), size_t(1)}) {
    const std::string& id = plan.runs[index].run_id;
    for (const auto& [table, kind] : {std::pair{&summary, "summary"}, std::pair{&trace, "trace"}}) {
      std::ofstream part(partial_file(out, index, kind));
      part << text::join(table->header, ",") << "\n";
      for (const auto& row : table->rows)
        if (row[table->column("run_id")] == id) {
          std::vector<std::string> fields;
          for (const std::string& f : row) fields.push_back(csv_field(f));
          part << text::join(fields, ",") << "\n";
        }
    }
  }
  for (size_t index : {size_t(2), size_t(3)})
    fs::remove(out / "runs" / (file_stem(plan.runs[index].run_id) + ".run.json"));
  for (const char* table : {"trace.csv", "summary.csv", "aggregate.csv"}) fs::remove(out / table);

  const SweepReport resumed = run_sweep(spec, {out.string(), 0, 1, "test"});
  EXPECT_EQ(resumed.runs_resumed, 2u);
  EXPECT_EQ(resumed.exit_code(), 0);
  EXPECT_EQ(
      testing::without_columns(read_csv((out / "summary.csv").string()), summary_time_columns()),
      testing::without_columns(read_csv(dir.file("whole/summary.csv")), summary_time_columns()));
  EXPECT_EQ(read_csv((out / "aggregate.csv").string()).rows,
            read_csv(dir.file("whole/aggregate.csv")).rows);
}

// The trace plots draw a repeated configuration as its mean with a shaded band.
TEST(SolverSeeds, PlotScriptDrawsTheBand) {
  if (std::system("/usr/bin/python3 -c 'import matplotlib, pandas' 2>/dev/null") != 0)
    GTEST_SKIP() << "python3-matplotlib/pandas not installed";
  TempDir dir;
  run_sweep(read_experiment(dir.write("e.toml", kRepeats)), {dir.file("out"), 0, 1, "test"});
  const std::string command = "/usr/bin/python3 " + std::string(RADLAB_SOURCE_DIR) +
                              "/scripts/plot_traces.py " + dir.file("out") +
                              " --formats png > /dev/null";
  ASSERT_EQ(std::system(command.c_str()), 0);
  EXPECT_TRUE(fs::exists(dir.file("out/plots/cube_rho_0.8_rms_rel_reflected_vs_pair_evals.png")));
}

// scripts/seed_variance.py reads the runs' radiosities by configuration: one row for the four
// seeds, the baseline's ratio to itself exactly 1.
TEST(SolverSeeds, SeedVarianceScriptReadsTheRuns) {
  if (std::system("/usr/bin/python3 -c 'import numpy' 2>/dev/null") != 0)
    GTEST_SKIP() << "python3-numpy not installed";
  TempDir dir;
  run_sweep(read_experiment(dir.write("e.toml", kRepeats)), {dir.file("out"), 0, 1, "test"});
  const std::string command = "/usr/bin/python3 " + std::string(RADLAB_SOURCE_DIR) +
                              "/scripts/seed_variance.py " + dir.file("out") + " > " +
                              dir.file("variance.md");
  ASSERT_EQ(std::system(command.c_str()), 0);
  const std::string table = read_text_file(dir.file("variance.md"));
  EXPECT_NE(table.find("| builtin:cube:rho=0.8 | stochastic-jacobi rays=2000 | 4 | 1.6e+04 |"),
            std::string::npos)
      << table;
  EXPECT_NE(table.find("| 1 ["), std::string::npos) << table;
}

}  // namespace
}  // namespace radlab
