// summary.csv: one row per run (DESIGN §7): final errors, the rows and seconds needed to reach
// rms_rel 1e-1/1e-2/1e-3 and p_mean 1e-2, and the Ceres-fitted convergence rate. For gathering
// solvers the fitted per-sweep rate sits beside the spectral radius of diag(rho)F.
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include "core/csv.h"
#include "experiments/run/columns.h"
#include "experiments/run/runner.h"
#include "metrics/convergence_fit.h"

namespace radlab {

struct SummaryInputs {
  size_t run_index = 0;
  RunLabels labels;
  size_t elements = 0;
  int channels = 1;
  bool gathering = false;        // one step = one gather: a sweep is n steps
  double spectral_radius = 0.0;  // of diag(rho)F, worst channel (NaN if not estimated): the
                                 // Collatz–Wielandt upper bound, and below the lower bound
  double spectral_radius_lower = std::nan("");
  // The run id without the solver's `seed` parameter, and that seed (empty when not given):
  // runs over several seeds of one configuration are aggregated (seed_aggregate.h).
  std::string configuration;
  std::string solver_seed;
};

// What first_reach measures, and against which x.
enum class ReachMetric { kRmsRel, kPMean, kRmsRelReflected };
enum class ReachAxis { kRows, kSeconds, kPairEvals };

// The x at which a decreasing trace first reaches `threshold`, interpolated linearly in
// log(error) between the bracketing checkpoints (NaN if never reached).
double first_reach(const std::vector<CheckpointRecord>& history, double threshold, ReachAxis axis,
                   ReachMetric metric);

// What one summary row is computed from: the run's inputs, its result (null for a failed run:
// then only the columns that need none are filled, the rest are empty) and the convergence fits,
// computed once.
struct SummaryRecord {
  const SummaryInputs& in;
  const RunResult* result = nullptr;
  std::string stop_reason;  // the result's, or "failed: ..."
  std::string error;        // empty unless the run failed
  ConvergenceFit by_rows, by_seconds, by_sweeps;
};

// summary.csv's columns, in order (columns.h); the header, every row and docs/outputs.md's table
// come from it.
const ColumnTable<SummaryRecord>& summary_table();
std::vector<std::string> summary_columns();
// Columns whose values depend on the machine's speed (left out when comparing re-runs).
std::vector<std::string> summary_time_columns();

void write_summary_row(CsvWriter& csv, const SummaryInputs& in, const RunResult& result);

// The row of a run that failed: its labels (and elements/channels if the problem was prepared),
// `stop_reason` (e.g. "failed: numerical error") and the message in `error`; the rest empty.
void write_failed_summary_row(CsvWriter& csv, const SummaryInputs& in,
                              const std::string& stop_reason, const std::string& error);

}  // namespace radlab
