// `radlab merge`: combines the outputs of sweep shards into one trace.csv, summary.csv and
// sweep.json, in the sweep's run order, identical to an unsplit run (times aside, and the
// command and `merged_from` in sweep.json), and gathers their run.json files, images and
// coverage files.
//
// Nothing mixed: every shard must be complete (sweep.json status) and of the same sweep — the
// experiment's name, the digest of its text, the digest of its run plan, the run count and the
// build (git SHA, form-factor source hash) must all agree, and each difference is refused by
// name. Each shard's summary rows must be the runs its sweep.json lists and belong to its shard;
// a run in two shards, a trace row repeated or of a run the summary lacks, is refused.
// Nothing lost: the shards must together hold every run of the sweep (refused otherwise, unless
// allow_incomplete, which writes status "incomplete" and the missing runs into sweep.json).
// Nothing half-written: everything is read and checked before anything is written; the result
// is built in a temporary sibling of the output folder and renamed into place at the end. An
// output folder equal to, inside, or containing a shard is refused.
// Nothing damaged: each shard's files must match the manifest in its sweep.json (size and
// SHA-256 of trace.csv, summary.csv and every file of runs/, images/, coverage/), and its
// scene_files must equal the first shard's. The output folder is locked as `radlab run` locks
// its folder, and replaced under run's rule (another experiment's sweep needs overwrite).
#pragma once

#include <string>
#include <vector>

namespace radlab {

struct MergeOptions {
  std::string command;  // goes into the merged sweep.json (empty: the first shard's command)
  bool allow_incomplete = false;
  // Replace an --out that holds another experiment's sweep, a shard, or files that are no sweep
  // (the rule of `radlab run --overwrite`); without it such a folder is refused.
  bool overwrite = false;
};

// Returns the number of runs merged. Throws InputError for everything above, and UsageError for
// an output folder that overlaps a shard or holds something other than a sweep.
size_t merge_sweeps(const std::vector<std::string>& shard_dirs, const std::string& out_dir,
                    const std::string& command = "");
size_t merge_shards(const std::vector<std::string>& shard_dirs, const std::string& out_dir,
                    const MergeOptions& options);

}  // namespace radlab
