// `radlab merge`: combines the outputs of sweep shards into one trace.csv, summary.csv and
// sweep.json, in the sweep's run order, identical to an unsplit run (times aside, and the
// command and `merged_from` in sweep.json), and gathers their run.json files, images and
// coverage files.
#pragma once

#include <string>
#include <vector>

namespace radlab {

// Returns the number of runs merged. Throws InputError on missing files, mismatched headers,
// shards of different experiments, or a run present in two shards. `command` goes into the
// merged sweep.json (empty: the first shard's command).
size_t merge_sweeps(const std::vector<std::string>& shard_dirs, const std::string& out_dir,
                    const std::string& command = "");

}  // namespace radlab
