// The trace CSV (DESIGN §7): long format, one row per checkpoint and channel, frozen columns.
// Columns are only ever appended, never renamed or reordered (docs/outputs.md lists them).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/csv.h"

namespace radlab {

// The frozen trace columns, in order.
const std::vector<std::string>& trace_columns();

struct TraceRow {
  std::string run_id, scene, solver, params;
  std::string channel;  // "mean" (of the colour channels), or "r", "g", "b"
  long long step = 0;
  unsigned long long ff_rows = 0;
  double seconds = 0.0;
  double rms, rms_rel, p_mean, p_rms, p_max, p_over, p_under;
  unsigned long long p_excluded = 0;
  double rms_display, rms_rel_display, p_mean_display, p_rms_display, p_max_display;
  double residual_inf, bound_inf, unshot_power, total_power;
  unsigned long long rays = 0;
  // Appended columns (docs/outputs.md):
  unsigned long long pair_evals = 0;  // element-pair form factors evaluated (a flat row counts n)
  double rms_reflected, rms_rel_reflected;  // eq. 14 on B - E (metrics/error_metrics.h)
  std::string reference_kind;               // "certified", an uncertified stand-in, or "none"
  unsigned long long solver_elements = 0;   // unknowns the solver holds (a change = new mesh)
};

class TraceWriter {
 public:
  explicit TraceWriter(const std::string& path);
  void write(const TraceRow& row);
  void flush() { csv_.flush(); }
  // Closes, checks and renames the file into place (core/csv.h); throws InputError on
  // failure.
  void close() {
    closed_ = true;  // a failure to close is not retried
    csv_.close();
  }
  bool closed() const { return closed_; }

 private:
  CsvWriter csv_;
  bool closed_ = false;
};

}  // namespace radlab
