#include "experiments/run/summary.h"

#include <cmath>

#include "metrics/convergence_fit.h"

namespace radlab {

const std::vector<std::string>& summary_columns() {
  // Columns are only ever appended (the second group came later), never reordered.
  // clang-format off
  static const std::vector<std::string> columns = {
      "run_index",
      "run_id",
      "scene",
      "solver",
      "params",
      "elements",
      "channels",
      "steps",
      "ff_rows",
      "seconds",
      "stop_reason",
      "rms_rel",
      "p_mean",
      "p_max",
      "rms_rel_display",
      "p_mean_display",
      "bound_relative",
      "rows_to_rms_rel_1e-1",
      "seconds_to_rms_rel_1e-1",
      "rows_to_rms_rel_1e-2",
      "seconds_to_rms_rel_1e-2",
      "rows_to_rms_rel_1e-3",
      "seconds_to_rms_rel_1e-3",
      "rows_to_p_mean_1e-2",
      "seconds_to_p_mean_1e-2",
      "fit_points",
      "fit_rate_per_row",
      "fit_rate_per_row_sigma",
      "fit_rows_per_decade",
      "fit_rows_to_rms_rel_1e-6",
      "fit_rows_to_rms_rel_1e-6_sigma",
      "fit_seconds_per_decade",
      "fit_seconds_to_rms_rel_1e-6",
      "fit_rate_per_sweep",
      "spectral_radius",
      "fit_seconds_points",
      "fit_seconds_per_decade_sigma",
      "fit_seconds_to_rms_rel_1e-6_sigma",
      "fit_sweep_points",
      "fit_rate_per_sweep_sigma",
      "spectral_radius_lower",
      "error",
      "pair_evals",
      "reference_kind",
      "rms_rel_reflected",
      "rows_to_rms_rel_reflected_1e-1",
      "seconds_to_rms_rel_reflected_1e-1",
      "pair_evals_to_rms_rel_reflected_1e-1",
      "rows_to_rms_rel_reflected_1e-2",
      "seconds_to_rms_rel_reflected_1e-2",
      "pair_evals_to_rms_rel_reflected_1e-2",
      "rows_to_rms_rel_reflected_1e-3",
      "seconds_to_rms_rel_reflected_1e-3",
      "pair_evals_to_rms_rel_reflected_1e-3",
      "tolerance_reached",
      "bound_relative_reflected",
      "p_excluded_area"};
  // clang-format on
  return columns;
}

const std::vector<std::string>& summary_time_columns() {
  static const std::vector<std::string> columns = {
      "seconds",
      "seconds_to_rms_rel_1e-1",
      "seconds_to_rms_rel_1e-2",
      "seconds_to_rms_rel_1e-3",
      "seconds_to_p_mean_1e-2",
      "fit_seconds_per_decade",
      "fit_seconds_to_rms_rel_1e-6",
      "fit_seconds_points",
      "fit_seconds_per_decade_sigma",
      "fit_seconds_to_rms_rel_1e-6_sigma",
      "seconds_to_rms_rel_reflected_1e-1",
      "seconds_to_rms_rel_reflected_1e-2",
      "seconds_to_rms_rel_reflected_1e-3",
      "stop_reason"};  // a time budget makes the stop reason machine-dependent too
  return columns;
}

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

void write_summary_row(CsvWriter& csv, const SummaryInputs& in, const RunResult& r) {
  const double nan = std::nan("");
  csv.add(in.run_index).add(in.labels.run_id).add(in.labels.scene).add(in.labels.solver);
  csv.add(in.labels.params).add(in.elements).add(in.channels).add(r.steps).add(r.rows);
  csv.add(r.seconds).add(r.stop_reason);
  csv.add(r.final_errors.rms_rel).add(r.final_errors.p_mean).add(r.final_errors.p_max);
  csv.add(r.final_display_errors.rms_rel).add(r.final_display_errors.p_mean);
  csv.add(r.final_bound_relative);
  using enum ReachAxis;
  for (double threshold : {1e-1, 1e-2, 1e-3}) {
    csv.add(first_reach(r.history, threshold, kRows, ReachMetric::kRmsRel));
    csv.add(first_reach(r.history, threshold, kSeconds, ReachMetric::kRmsRel));
  }
  csv.add(first_reach(r.history, 1e-2, kRows, ReachMetric::kPMean));
  csv.add(first_reach(r.history, 1e-2, kSeconds, ReachMetric::kPMean));

  std::vector<double> rows, seconds, error;
  for (const CheckpointRecord& c : r.history) {
    if (c.step == 0) continue;  // the initial state is not part of the convergence
    rows.push_back(double(c.rows));
    seconds.push_back(c.seconds);
    error.push_back(c.rms_rel);
  }
  const ConvergenceFit by_rows = fit_convergence(rows, error, 1e-6);
  const ConvergenceFit by_seconds = fit_convergence(seconds, error, 1e-6);
  csv.add(by_rows.points);
  csv.add(by_rows.valid ? by_rows.rate : nan);
  csv.add(by_rows.valid ? by_rows.rate * by_rows.log_rate_sigma : nan);  // sigma of exp(b)
  csv.add(by_rows.valid ? -std::log(10.0) / by_rows.log_rate : nan);
  csv.add(by_rows.valid ? by_rows.x_to_tolerance : nan);
  csv.add(by_rows.valid ? by_rows.x_to_tolerance_sigma : nan);
  csv.add(by_seconds.valid ? -std::log(10.0) / by_seconds.log_rate : nan);
  csv.add(by_seconds.valid ? by_seconds.x_to_tolerance : nan);
  // Per sweep: fitted on the checkpoints at the end of a sweep only (rows a multiple of n), where
  // a gathering method's iterate is a whole sweep's; mid-sweep errors depend on which elements
  // the sweep has reached. Needs 3 sweep ends in the tail (the second half of the sweeps).
  ConvergenceFit by_sweeps;
  if (in.gathering && in.elements > 0) {
    std::vector<double> sweeps, sweep_error;
    for (const CheckpointRecord& c : r.history)
      if (c.rows > 0 && c.rows % in.elements == 0) {
        sweeps.push_back(double(c.rows / in.elements));
        sweep_error.push_back(c.rms_rel);
      }
    FitOptions options;
    options.min_points = 3;
    by_sweeps = fit_convergence(sweeps, sweep_error, 1e-6, options);
  }
  csv.add(by_sweeps.valid ? by_sweeps.rate : nan);
  csv.add(in.spectral_radius);
  csv.add(by_seconds.points);
  // per decade = -ln 10 / b, so its sigma is ln 10 sigma_b / b^2.
  csv.add(by_seconds.valid ? std::log(10.0) * by_seconds.log_rate_sigma /
                                 (by_seconds.log_rate * by_seconds.log_rate)
                           : nan);
  csv.add(by_seconds.valid ? by_seconds.x_to_tolerance_sigma : nan);
  csv.add(in.gathering ? by_sweeps.points : 0);
  csv.add(by_sweeps.valid ? by_sweeps.rate * by_sweeps.log_rate_sigma : nan);
  csv.add(in.spectral_radius_lower);
  csv.add(std::string());  // error: none
  csv.add(r.pair_evals).add(r.reference_kind).add(r.final_reflected.rms_rel);
  for (double threshold : {1e-1, 1e-2, 1e-3})
    for (ReachAxis axis : {kRows, kSeconds, kPairEvals})
      csv.add(first_reach(r.history, threshold, axis, ReachMetric::kRmsRelReflected));
  // true / false with a tolerance in the budget; empty without one.
  csv.add(std::string(r.tolerance_asked ? (r.tolerance_reached ? "true" : "false") : ""));
  csv.add(r.final_bound_relative_reflected);  // ||B-B*||_inf / max(B* - E), as in run.json
  csv.add(r.final_errors.p_excluded_area);    // area fraction left out of p-error
  csv.end_row();
}

void write_failed_summary_row(CsvWriter& csv, const SummaryInputs& in,
                              const std::string& stop_reason, const std::string& error) {
  const double nan = std::nan("");
  csv.add(in.run_index).add(in.labels.run_id).add(in.labels.scene).add(in.labels.solver);
  csv.add(in.labels.params);
  if (in.elements > 0)
    csv.add(in.elements).add(in.channels);
  else
    csv.add(nan).add(nan);
  csv.add(nan).add(nan).add(nan);  // steps, ff_rows, seconds: see the trace up to the failure
  csv.add(stop_reason);
  // The 11 columns above and `error`; everything else is empty.
  for (size_t k = 11; k < csv.columns().size(); ++k) {
    if (csv.columns()[k] == "error")
      csv.add(error);
    else
      csv.add(nan);
  }
  csv.end_row();
}

}  // namespace radlab
