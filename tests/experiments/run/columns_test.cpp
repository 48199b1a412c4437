// Output columns as data (experiments/run/columns.h): docs/outputs.md's column tables are the
// tables the CSVs are written from, the frozen columns keep their names and order, and adding a
// metric is one entry.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include "core/csv_reader.h"
#include "core/param_bag.h"
#include "experiments/problem/problem.h"
#include "experiments/run/runner.h"
#include "experiments/run/seed_aggregate.h"
#include "experiments/run/summary.h"
#include "experiments/run/trace.h"
#include "solvers/registry.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

std::string outputs_page() {
  std::ifstream file(std::string(RADLAB_SOURCE_DIR) + "/docs/outputs.md");
  std::ostringstream text;
  text << file.rdbuf();
  return text.str();
}

TEST(Columns, DocsTablesAreTheColumnTables) {
  const std::string page = outputs_page();
  ASSERT_FALSE(page.empty()) << "docs/outputs.md";
  const std::string trace = column_table_markdown(trace_table());
  const std::string summary = column_table_markdown(summary_table());
  EXPECT_NE(page.find(trace), std::string::npos)
      << "docs/outputs.md must hold trace.csv's column table, as trace_table() makes it:\n"
      << trace;
  EXPECT_NE(page.find(summary), std::string::npos)
      << "docs/outputs.md must hold summary.csv's column table, as summary_table() makes it:\n"
      << summary;
  const std::string aggregate = column_table_markdown(aggregate_table());
  EXPECT_NE(page.find(aggregate), std::string::npos)
      << "docs/outputs.md must hold aggregate.csv's column table, as aggregate_table() makes it:\n"
      << aggregate;
}

// The frozen rule (docs/outputs.md): columns already published keep their names and order; new
// ones go at the end. The lists below are the columns as first published and appended over time.
TEST(Columns, PublishedColumnsKeepTheirNamesAndOrder) {
  const std::vector<std::string> trace_published = {"run_id",
                                                    "scene",
                                                    "solver",
                                                    "params",
                                                    "channel",
                                                    "step",
                                                    "ff_rows",
                                                    "seconds",
                                                    "rms",
                                                    "rms_rel",
                                                    "p_mean",
                                                    "p_rms",
                                                    "p_max",
                                                    "p_over",
                                                    "p_under",
                                                    "p_excluded",
                                                    "rms_display",
                                                    "rms_rel_display",
                                                    "p_mean_display",
                                                    "p_rms_display",
                                                    "p_max_display",
                                                    "residual_inf",
                                                    "bound_inf",
                                                    "unshot_power",
                                                    "total_power",
                                                    "rays",
                                                    "pair_evals",
                                                    "rms_reflected",
                                                    "rms_rel_reflected",
                                                    "reference_kind",
                                                    "solver_elements",
                                                    "solver_statistics",
                                                    "seconds_with_setup",
                                                    "cpu_seconds"};
  const std::vector<std::string> trace = trace_columns();
  ASSERT_GE(trace.size(), trace_published.size());
  EXPECT_EQ(std::vector<std::string>(trace.begin(), trace.begin() + long(trace_published.size())),
            trace_published);
  const std::vector<std::string> summary = summary_columns();
  ASSERT_GE(summary.size(), 58u);
  EXPECT_EQ(summary[0], "run_index");
  EXPECT_EQ(summary[10], "stop_reason");
  EXPECT_EQ(summary[17], "rows_to_rms_rel_1e-1");
  EXPECT_EQ(summary[24], "seconds_to_p_mean_1e-2");
  EXPECT_EQ(summary[41], "error");
  EXPECT_EQ(summary[46], "seconds_to_rms_rel_reflected_1e-1");
  EXPECT_EQ(summary[55], "bound_relative_reflected");
  EXPECT_EQ(summary[56], "solver_statistics");
  EXPECT_EQ(summary[57], "p_excluded_area");
  EXPECT_EQ(summary[58], "seconds_with_setup");
  EXPECT_EQ(summary[59], "configuration");
  EXPECT_EQ(summary[60], "solver_seed");
  EXPECT_EQ(summary[61], "cpu_seconds");
}

// A new metric is one entry: the area-weighted L1 error relative to the reference's area-weighted
// mean, appended to the trace's table. The run writes it beside every other column, and its last
// `mean` row is the value computed directly from the final solution.
TEST(Columns, AddingAMetricIsOneEntry) {
  testing::TempDir dir;
  ProblemSpec spec;
  spec.scene = "builtin:cornell";
  spec.cache_dir = dir.path().string();
  auto problem = prepare_problem(spec);

  auto l1_rel = [](const Problem& p, const Radiosity& B, int field) {
    const auto area = p.system->area();
    double diff = 0.0, total = 0.0;
    for (size_t i = 0; i < area.size(); ++i) {
      const double b = field == kMeanOfChannels ? B.mean(i) : B.at(field, i);
      const double r =
          field == kMeanOfChannels ? p.reference->B.mean(i) : p.reference->B.at(field, i);
      diff += area[i] * std::abs(b - r);
      total += area[i] * r;
    }
    return diff / total;
  };
  ColumnTable<TraceCheckpoint> table = trace_table();
  table.push_back({"l1_rel", "area-weighted L1 error relative to the reference's",
                   [&](CsvWriter& csv, const TraceCheckpoint& r) {
                     csv.add(l1_rel(r.problem, r.B, r.field));
                   }});

  ParamBag bag = ParamBag::from_assignments({}, "solver");
  auto solver = make_solver("jacobi", bag);
  RunLabels labels{"jacobi/scene:cornell", spec.scene, "jacobi", bag.canonical()};
  Budget budget;
  budget.steps = 40;
  TraceWriter trace(dir.file("t.csv"), table);
  run_solver(*solver, *problem, budget, CheckpointSchedule{}, labels, &trace);
  trace.close();

  const CsvTable written = read_csv(dir.file("t.csv"));
  std::vector<std::string> expected = trace_columns();
  expected.push_back("l1_rel");
  EXPECT_EQ(written.header, expected);
  const size_t column = written.column("l1_rel"), channel = written.column("channel");
  const auto& last_mean = written.rows[written.rows.size() - 4];  // mean, r, g, b
  ASSERT_EQ(last_mean[channel], "mean");
  // Written "%.17g": the double read back is the one computed.
  EXPECT_EQ(std::stod(last_mean[column]), l1_rel(*problem, solver->solution(), kMeanOfChannels));
  // Jacobi from B = E gathers light: after 40 rows the error has fallen from its initial value,
  // and the emitters' share keeps it below 1 throughout.
  const double first = std::stod(written.rows[0][column]);
  EXPECT_LT(std::stod(last_mean[column]), first);
  EXPECT_LT(first, 1.0);
}

}  // namespace
}  // namespace radlab
