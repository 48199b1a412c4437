// Runs an experiment: the Cartesian product of its runs (or one shard of it), sharing each
// scene's form factors and reference among the runs on it, and writes trace.csv, summary.csv,
// runs/*.run.json, images/ and sweep.json into the output folder.
#pragma once

#include <string>

#include "experiments/experiment_spec.h"

namespace radlab {

struct SweepOptions {
  std::string out_dir;
  int shard_index = 0;  // run the runs with index % shard_count == shard_index
  int shard_count = 1;
  std::string command;  // for sweep.json
};

struct SweepReport {
  size_t runs_done = 0;
  size_t runs_total = 0;
};

SweepReport run_sweep(const ExperimentSpec& spec, const SweepOptions& options);

// "i/N" -> (i, N); UsageError unless 0 <= i < N.
std::pair<int, int> parse_shard(const std::string& text);

// A run id made safe as a file name ("/" and ":" become "_").
std::string file_stem(const std::string& run_id);

}  // namespace radlab
