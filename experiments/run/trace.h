// The trace CSV (DESIGN §7): long format, one row per checkpoint and channel, frozen columns.
// The columns are a table (trace_table(): name, meaning, how it is computed; columns.h): the
// header, every row and docs/outputs.md's column table come from it. Columns are only ever
// appended, never renamed or reordered.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/csv.h"
#include "core/radiosity.h"
#include "experiments/run/columns.h"
#include "metrics/error_metrics.h"

namespace radlab {

struct Problem;
class Solver;
struct RunLabels;

// What one trace row is computed from: the run, the checkpoint, the field (the mean of the colour
// channels or one channel) and the metrics every error column shares, computed once.
struct TraceCheckpoint {
  const RunLabels& labels;
  const Problem& problem;
  const Solver& solver;
  int field = 0;        // kMeanOfChannels, or a channel
  std::string channel;  // "mean" (of the colour channels), or "r", "g", "b"
  long long step = 0;
  unsigned long long ff_rows = 0, rays = 0, pair_evals = 0;
  double seconds = 0.0;
  double seconds_with_setup = 0.0;  // seconds + setup_seconds() (runner.h)
  double cpu_seconds = 0.0;         // the process's CPU time over the same span as `seconds`
  const Radiosity& B;               // solution()
  const Radiosity* unshot;          // unshot(), for shooting solvers
  bool measured = false;            // a reference exists: the error columns apply
  ErrorMetrics errors;              // of solution() against the reference
  ErrorMetrics display;             // of display()
  ReflectedRms reflected;           // of solution() - E against B* - E
  double residual_inf = 0.0;        // NaN without a matrix or patch rows to take it with
  double bound_inf = 0.0;
  std::string statistics;  // statistics_field(solver.statistics()) at this checkpoint
};

// The trace's columns, in order.
const ColumnTable<TraceCheckpoint>& trace_table();
// Their names: the trace's header.
std::vector<std::string> trace_columns();
// Those whose values measure the machine (`seconds`, `seconds_with_setup`, `cpu_seconds`): left out
// when re-runs
// are compared.
std::vector<std::string> trace_time_columns();

class TraceWriter {
 public:
  // A table other than trace_table() (a tool's own, or a test's with a metric appended).
  explicit TraceWriter(const std::string& path,
                       const ColumnTable<TraceCheckpoint>& table = trace_table());
  void write(const TraceCheckpoint& checkpoint) { write_columns(csv_, table_, checkpoint); }
  void flush() { csv_.flush(); }
  // Closes, checks and renames the file into place (core/csv.h); throws InputError on
  // failure.
  void close() {
    closed_ = true;  // a failure to close is not retried
    csv_.close();
  }
  bool closed() const { return closed_; }

 private:
  ColumnTable<TraceCheckpoint> table_;
  CsvWriter csv_;
  bool closed_ = false;
};

}  // namespace radlab
