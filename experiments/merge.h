// `radlab merge`: combines the outputs of sweep shards into one trace.csv and summary.csv, in
// the sweep's run order, identical to an unsplit run (times aside), and gathers their run.json
// files and images.
#pragma once

#include <string>
#include <vector>

namespace radlab {

// Returns the number of runs merged. Throws InputError on missing files, mismatched headers or
// a run present in two shards.
size_t merge_sweeps(const std::vector<std::string>& shard_dirs, const std::string& out_dir);

}  // namespace radlab
