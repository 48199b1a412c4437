#include "experiments/run/summary.h"

#include <cmath>
#include <limits>

#include "metrics/convergence_fit.h"

namespace radlab {

double first_reach(const std::vector<CheckpointRecord>& history, double threshold, ReachAxis axis,
                   ReachMetric metric) {
  auto value = [&](const CheckpointRecord& r) {
    switch (metric) {
      case ReachMetric::kPMean:
        return r.p_mean;
      case ReachMetric::kRmsRelReflected:
        return r.rms_rel_reflected;
      case ReachMetric::kRmsRel:
        break;
    }
    return r.rms_rel;
  };
  auto x = [&](const CheckpointRecord& r) {
    switch (axis) {
      case ReachAxis::kSeconds:
        return r.seconds;
      case ReachAxis::kPairEvals:
        return double(r.pair_evals);
      case ReachAxis::kRows:
        break;
    }
    return double(r.rows);
  };
  for (size_t k = 0; k < history.size(); ++k) {
    const double v = value(history[k]);
    if (!(v <= threshold)) continue;
    if (k == 0) return x(history[0]);
    const double v0 = value(history[k - 1]);
    if (!(v0 > 0) || !(v > 0)) return x(history[k]);
    // Linear in log(error) between the two checkpoints.
    const double t = (std::log(v0) - std::log(threshold)) / (std::log(v0) - std::log(v));
    return x(history[k - 1]) + t * (x(history[k]) - x(history[k - 1]));
  }
  return std::nan("");
}

namespace {

using Record = SummaryRecord;
using Write = std::function<void(CsvWriter&, const Record&)>;
constexpr double kNan = std::numeric_limits<double>::quiet_NaN();

// A column of the run's result: empty in a failed run's row.
Write of_result(std::function<void(CsvWriter&, const Record&, const RunResult&)> write) {
  return [write](CsvWriter& csv, const Record& r) {
    if (r.result)
      write(csv, r, *r.result);
    else
      csv.add(kNan);
  };
}

// A double of the run's result.
Write number(std::function<double(const Record&, const RunResult&)> value) {
  return of_result([value](CsvWriter& csv, const Record& r, const RunResult& result) {
    csv.add(value(r, result));
  });
}

// A fit's value, empty when the fit is not valid.
Write fitted(ConvergenceFit Record::*fit, double (*value)(const ConvergenceFit&)) {
  return number([fit, value](const Record& r, const RunResult&) {
    const ConvergenceFit& f = r.*fit;
    return f.valid ? value(f) : kNan;
  });
}

const char* axis_name(ReachAxis axis) {
  switch (axis) {
    case ReachAxis::kSeconds:
      return "seconds";
    case ReachAxis::kPairEvals:
      return "pair_evals";
    case ReachAxis::kRows:
      break;
  }
  return "rows";
}

// `rows_to_rms_rel_1e-2` and the like: where the metric first reaches the threshold.
Column<SummaryRecord> reach(ReachAxis axis, ReachMetric metric, const char* metric_name,
                            const char* threshold_name, double threshold) {
  const std::string name =
      std::string(axis_name(axis)) + "_to_" + metric_name + "_" + threshold_name;
  return {name,
          std::string(axis_name(axis)) + " at which `" + metric_name + "` first reaches " +
              threshold_name + " (linear in log error between checkpoints; empty if never)",
          number([=](const Record&, const RunResult& result) {
            return first_reach(result.history, threshold, axis, metric);
          }),
          axis == ReachAxis::kSeconds};
}

ColumnTable<SummaryRecord> make_summary_table() {
  using enum ReachAxis;
  ColumnTable<SummaryRecord> t;
  auto add = [&t](std::string name, std::string meaning, Write write, bool time = false) {
    t.push_back({std::move(name), std::move(meaning), std::move(write), time});
  };
  // clang-format off
  add("run_index", "the run's position in the sweep", [](CsvWriter& c, const Record& r) { c.add(r.in.run_index); });
  add("run_id", "as in trace.csv", [](CsvWriter& c, const Record& r) { c.add(r.in.labels.run_id); });
  add("scene", "the scene spec", [](CsvWriter& c, const Record& r) { c.add(r.in.labels.scene); });
  add("solver", "the solver's name", [](CsvWriter& c, const Record& r) { c.add(r.in.labels.solver); });
  add("params", "the solver's parameters, canonical `k=v,...`", [](CsvWriter& c, const Record& r) { c.add(r.in.labels.params); });
  add("elements", "elements of the mesh (empty if the problem could not be prepared)", [](CsvWriter& c, const Record& r) {
    if (r.result || r.in.elements > 0) c.add(r.in.elements); else c.add(kNan);
  });
  add("channels", "1 (grey) or 3 (RGB)", [](CsvWriter& c, const Record& r) {
    if (r.result || r.in.elements > 0) c.add(r.in.channels); else c.add(kNan);
  });
  add("steps", "solver steps taken", of_result([](CsvWriter& c, const Record&, const RunResult& x) { c.add(x.steps); }));
  add("ff_rows", "form-factor rows read", of_result([](CsvWriter& c, const Record&, const RunResult& x) { c.add(x.rows); }));
  add("seconds", "solver seconds", number([](const Record&, const RunResult& x) { return x.seconds; }), true);
  add("stop_reason", "why the run stopped (`step budget`, `tolerance reached`, ..., or `failed: ...`); machine-dependent under a time budget",
      [](CsvWriter& c, const Record& r) { c.add(r.stop_reason); }, true);
  add("rms_rel", "final `rms_rel` (trace.csv)", number([](const Record&, const RunResult& x) { return x.final_errors.rms_rel; }));
  add("p_mean", "final `p_mean`", number([](const Record&, const RunResult& x) { return x.final_errors.p_mean; }));
  add("p_max", "final `p_max`", number([](const Record&, const RunResult& x) { return x.final_errors.p_max; }));
  add("rms_rel_display", "final `rms_rel_display`", number([](const Record&, const RunResult& x) { return x.final_display_errors.rms_rel; }));
  add("p_mean_display", "final `p_mean_display`", number([](const Record&, const RunResult& x) { return x.final_display_errors.p_mean; }));
  add("bound_relative", "the final certified bound ‖B − B*‖∞ / max B*", number([](const Record&, const RunResult& x) { return x.final_bound_relative; }));
  const std::pair<const char*, double> thresholds[] = {{"1e-1", 1e-1}, {"1e-2", 1e-2}, {"1e-3", 1e-3}};
  for (const auto& [text, threshold] : thresholds)
    for (ReachAxis axis : {kRows, kSeconds}) t.push_back(reach(axis, ReachMetric::kRmsRel, "rms_rel", text, threshold));
  for (ReachAxis axis : {kRows, kSeconds}) t.push_back(reach(axis, ReachMetric::kPMean, "p_mean", "1e-2", 1e-2));
  add("fit_points", "checkpoints in the tail (the second half) the Ceres fit of log(rms_rel) against rows used",
      of_result([](CsvWriter& c, const Record& r, const RunResult&) { c.add(r.by_rows.points); }));
  add("fit_rate_per_row", "the fitted factor of rms_rel per form-factor row", fitted(&Record::by_rows, [](const ConvergenceFit& f) { return f.rate; }));
  add("fit_rate_per_row_sigma", "its 1-σ uncertainty", fitted(&Record::by_rows, [](const ConvergenceFit& f) { return f.rate * f.log_rate_sigma; }));
  add("fit_rows_per_decade", "rows per tenfold fall of rms_rel, fitted", fitted(&Record::by_rows, [](const ConvergenceFit& f) { return -std::log(10.0) / f.log_rate; }));
  add("fit_rows_to_rms_rel_1e-6", "rows to rms_rel 1e-6, extrapolated by the fit", fitted(&Record::by_rows, [](const ConvergenceFit& f) { return f.x_to_tolerance; }));
  add("fit_rows_to_rms_rel_1e-6_sigma", "its 1-σ uncertainty", fitted(&Record::by_rows, [](const ConvergenceFit& f) { return f.x_to_tolerance_sigma; }));
  add("fit_seconds_per_decade", "seconds per tenfold fall of rms_rel, fitted against seconds", fitted(&Record::by_seconds, [](const ConvergenceFit& f) { return -std::log(10.0) / f.log_rate; }), true);
  add("fit_seconds_to_rms_rel_1e-6", "seconds to rms_rel 1e-6, extrapolated", fitted(&Record::by_seconds, [](const ConvergenceFit& f) { return f.x_to_tolerance; }), true);
  add("fit_rate_per_sweep", "gathering solvers: the factor of rms_rel per sweep, fitted on the sweep ends of the tail (three needed)",
      fitted(&Record::by_sweeps, [](const ConvergenceFit& f) { return f.rate; }));
  add("spectral_radius", "gathering solvers: the Collatz–Wielandt upper bound on the spectral radius of diag(ρ)F (worst channel, 200 power iterations)",
      number([](const Record& r, const RunResult&) { return r.in.spectral_radius; }));
  add("fit_seconds_points", "checkpoints the seconds fit used",
      of_result([](CsvWriter& c, const Record& r, const RunResult&) { c.add(r.by_seconds.points); }), true);
  // per decade = -ln 10 / b, so its sigma is ln 10 sigma_b / b^2.
  add("fit_seconds_per_decade_sigma", "1-σ of `fit_seconds_per_decade`",
      fitted(&Record::by_seconds, [](const ConvergenceFit& f) { return std::log(10.0) * f.log_rate_sigma / (f.log_rate * f.log_rate); }), true);
  add("fit_seconds_to_rms_rel_1e-6_sigma", "1-σ of `fit_seconds_to_rms_rel_1e-6`",
      fitted(&Record::by_seconds, [](const ConvergenceFit& f) { return f.x_to_tolerance_sigma; }), true);
  add("fit_sweep_points", "sweep ends the per-sweep fit used (0 for other solvers)",
      of_result([](CsvWriter& c, const Record& r, const RunResult&) { c.add(r.in.gathering ? r.by_sweeps.points : 0); }));
  add("fit_rate_per_sweep_sigma", "1-σ of `fit_rate_per_sweep`", fitted(&Record::by_sweeps, [](const ConvergenceFit& f) { return f.rate * f.log_rate_sigma; }));
  add("spectral_radius_lower", "the Collatz–Wielandt lower bound (read the two as an interval)",
      number([](const Record& r, const RunResult&) { return r.in.spectral_radius_lower; }));
  add("error", "empty unless the run failed: then why", [](CsvWriter& c, const Record& r) { c.add(r.error); });
  add("pair_evals", "element-pair form factors evaluated (trace.csv)", of_result([](CsvWriter& c, const Record&, const RunResult& x) { c.add(x.pair_evals); }));
  add("reference_kind", "as in trace.csv", of_result([](CsvWriter& c, const Record&, const RunResult& x) { c.add(x.reference_kind); }));
  add("rms_rel_reflected", "final `rms_rel_reflected`", number([](const Record&, const RunResult& x) { return x.final_reflected.rms_rel; }));
  for (const auto& [text, threshold] : thresholds)
    for (ReachAxis axis : {kRows, kSeconds, kPairEvals})
      t.push_back(reach(axis, ReachMetric::kRmsRelReflected, "rms_rel_reflected", text, threshold));
  add("tolerance_reached", "`true`/`false` with a tolerance in the budget, empty without (a missed tolerance is not a failure of `radlab run`: read this column)",
      of_result([](CsvWriter& c, const Record&, const RunResult& x) {
        c.add(std::string(x.tolerance_asked ? (x.tolerance_reached ? "true" : "false") : ""));
      }));
  add("bound_relative_reflected", "the certified bound relative to the reflected light, ‖B − B*‖∞ / max(B* − E), as in run.json",
      number([](const Record&, const RunResult& x) { return x.final_bound_relative_reflected; }));
  add("solver_statistics", "the solver's own counters at the end (`Solver::statistics()`, as run.json's `solver_statistics`) as `name=value;...`; those that measure the machine (time, peak RSS) are in run.json only",
      of_result([](CsvWriter& c, const Record&, const RunResult& x) { c.add(statistics_field(x.statistics)); }));
  add("p_excluded_area", "the area fraction of the elements left out of p-error (trace.csv's `p_excluded`) at the end",
      number([](const Record&, const RunResult& x) { return x.final_errors.p_excluded_area; }));
  add("seconds_with_setup", "solver seconds plus the set-up the run depended on (trace.csv's `seconds_with_setup`: the matrix's recorded build time for a run that read its rows, the patch rows' on two levels, nothing for rows on the fly, hierarchical or Monte Carlo runs)",
      number([](const Record&, const RunResult& x) { return x.seconds_with_setup; }), true);
  add("configuration", "the run id without the solver's `seed` parameter: the runs over seeds of one configuration share it (aggregate.csv)",
      [](CsvWriter& c, const Record& r) { c.add(r.in.configuration); });
  add("solver_seed", "the solver's `seed` parameter as the experiment gave it (`solver_seeds`, `repeats` or `[parameters.SOLVER] seed`), empty when not given",
      [](CsvWriter& c, const Record& r) { c.add(r.in.solver_seed); });
  add("cpu_seconds", "the process's CPU time over the solver seconds (trace.csv's `cpu_seconds`: every thread counted; compares runs made at different loads)",
      number([](const Record&, const RunResult& x) { return x.cpu_seconds; }), true);
  // clang-format on
  return t;
}

// The fits of the run's tail: against rows, seconds and (gathering solvers) sweeps.
void fit_tail(const SummaryInputs& in, const RunResult& result, SummaryRecord& record) {
  std::vector<double> rows, seconds, error;
  for (const CheckpointRecord& c : result.history) {
    if (c.step == 0) continue;  // the initial state is not part of the convergence
    rows.push_back(double(c.rows));
    seconds.push_back(c.seconds);
    error.push_back(c.rms_rel);
  }
  record.by_rows = fit_convergence(rows, error, 1e-6);
  record.by_seconds = fit_convergence(seconds, error, 1e-6);
  // Per sweep: fitted on the checkpoints at the end of a sweep only (rows a multiple of n), where
  // a gathering method's iterate is a whole sweep's; mid-sweep errors depend on which elements
  // the sweep has reached. Needs 3 sweep ends in the tail (the second half of the sweeps).
  if (in.gathering && in.elements > 0) {
    std::vector<double> sweeps, sweep_error;
    for (const CheckpointRecord& c : result.history)
      if (c.rows > 0 && c.rows % in.elements == 0) {
        sweeps.push_back(double(c.rows / in.elements));
        sweep_error.push_back(c.rms_rel);
      }
    FitOptions options;
    options.min_points = 3;
    record.by_sweeps = fit_convergence(sweeps, sweep_error, 1e-6, options);
  }
}

}  // namespace

const ColumnTable<SummaryRecord>& summary_table() {
  static const ColumnTable<SummaryRecord> table = make_summary_table();
  return table;
}

std::vector<std::string> summary_columns() {
  return column_names(summary_table());
}

std::vector<std::string> summary_time_columns() {
  std::vector<std::string> names;
  for (const auto& column : summary_table())
    if (column.time) names.push_back(column.name);
  return names;
}

void write_summary_row(CsvWriter& csv, const SummaryInputs& in, const RunResult& result) {
  SummaryRecord record{in, &result, result.stop_reason, {}, {}, {}, {}};
  fit_tail(in, result, record);
  write_columns(csv, summary_table(), record);
}

void write_failed_summary_row(CsvWriter& csv, const SummaryInputs& in,
                              const std::string& stop_reason, const std::string& error) {
  SummaryRecord record{in, nullptr, stop_reason, error, {}, {}, {}};
  write_columns(csv, summary_table(), record);
}

}  // namespace radlab
