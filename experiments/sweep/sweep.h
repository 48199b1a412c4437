// Runs an experiment: the Cartesian product of its runs (or one shard of it), sharing each
// scene's form factors and reference among the runs on it, and writes trace.csv, summary.csv,
// runs/*.run.json, images/, coverage/ and sweep.json into the output folder. sweep.json says
// "running" from the start and "complete" at the end; trace.csv and summary.csv appear only when
// every run is done (experiments/sweep/sweep_folder.h: the lock, resuming, replacing,
// refusing).
//
// A run that fails (a UsageError, InputError or NumericalError from preparing its problem,
// creating its solver, or a step) does not stop the sweep: its summary row says why
// (stop_reason "failed: ...", the message in `error`), sweep.json lists it under "failed", and
// the sweep goes on with the other runs. SweepReport::exit_code() gives the command line's code.
#pragma once

#include <string>
#include <vector>

#include "core/error.h"
#include "experiments/sweep/experiment_spec.h"

namespace radlab {

struct SweepOptions {
  std::string out_dir;
  int shard_index = 0;  // run the runs with index % shard_count == shard_index
  int shard_count = 1;
  std::string command;  // for sweep.json
  // Replace the sweep files of a folder that holds another experiment's sweep, another shard,
  // or no sweep (experiments/sweep/sweep_folder.h); without it such a folder is refused.
  bool overwrite = false;
};

struct RunFailure {
  size_t run_index = 0;
  std::string run_id;
  ExitCode code = ExitCode::kNumerical;
  std::string message;
};

struct SweepReport {
  size_t runs_done = 0;  // runs attempted in this shard, failed ones included
  size_t runs_total = 0;
  size_t runs_resumed = 0;  // of runs_done: complete from an interrupted attempt, skipped
  std::vector<RunFailure> failures;

  // 0 if every run succeeded; else 4 if any failed numerically, else the worst of the input (3)
  // and usage (2) codes (DESIGN §7).
  int exit_code() const;
};

SweepReport run_sweep(const ExperimentSpec& spec, const SweepOptions& options);

// The stop_reason of a failed run: "failed: numerical error" and so on.
std::string failure_stop_reason(ExitCode code);

// "i/N" -> (i, N); UsageError unless 0 <= i < N.
std::pair<int, int> parse_shard(const std::string& text);

// A run id made safe as a file name ("/" and ":" become "_").
std::string file_stem(const std::string& run_id);

}  // namespace radlab
