// The output folder of `radlab run`: who may write it, what it holds, and what a re-run does.
//
// - A lock (flock on OUT/.radlab.lock) keeps two processes from writing one folder: the second
//   is refused at once, naming the folder (two sweeps used to interleave their rows).
// - sweep.json says what the folder holds: the experiment's name, a digest of its text and of
//   its run plan (the run ids in order), the shard, the build (git SHA and the form-factor source
//   hash) and a status, "running" from the start of a sweep and "complete" once every output is
//   in place. A killed sweep therefore never looks complete.
// - Re-running into a folder: one holding a killed ("running") sweep of the same experiment
//   text, plan, shard and build is resumed (runs already complete, verified by their run.json,
//   are skipped); one holding another sweep of the same experiment is replaced (its runs, images
//   and coverage are removed first, so nothing stale remains); anything else — a folder that is
//   not empty and holds another experiment, another shard of this one, or no sweep at all — is
//   refused unless --overwrite (which removes only the files a sweep writes).
#pragma once

#include <filesystem>
#include <set>
#include <string>

#include "core/json.h"
#include "core/json_reader.h"
#include "experiments/sweep/experiment_spec.h"

namespace radlab {

// What must match for runs of two folders to belong to one sweep.
struct SweepIdentity {
  std::string name;
  std::string experiment_digest;  // of the experiment file's bytes
  std::string plan_digest;        // of every run id of the whole sweep, in order
  std::string shard;              // "i/N"
  std::string git_sha, source_hash;
};

// 32 hex digits over `bytes` (two independent 64-bit hashes; not cryptographic).
std::string digest_of(const std::string& bytes);

SweepIdentity sweep_identity(const ExperimentSpec& spec, const SweepPlan& plan,
                             const std::string& shard);

// The identity's fields (experiment_digest, plan_digest) for sweep.json; the build and shard are
// written by the sweep beside them.
void write_identity(JsonWriter& json, const SweepIdentity& identity);

// Holds the folder's lock for its lifetime. Throws UsageError if another process holds it,
// InputError if the folder cannot be created or written.
class SweepFolderLock {
 public:
  explicit SweepFolderLock(const std::filesystem::path& folder);
  ~SweepFolderLock();
  SweepFolderLock(const SweepFolderLock&) = delete;
  SweepFolderLock& operator=(const SweepFolderLock&) = delete;

 private:
  int fd_ = -1;
};

// Where a run's trace and summary rows wait until the sweep assembles trace.csv and summary.csv.
std::filesystem::path partial_folder(const std::filesystem::path& out);
std::filesystem::path partial_file(const std::filesystem::path& out, size_t run_index,
                                   const char* kind);

// Decides what a sweep with `identity` does with `out` (see the top of the file), clearing it
// when it starts afresh. Returns true to resume. `note` receives what was decided, for the log.
bool prepare_sweep_folder(const std::filesystem::path& out, const SweepIdentity& identity,
                          bool overwrite, std::string& note);

// The run.json of a run that completed in an earlier, killed attempt of this sweep, or nullopt:
// it must parse, name this run (id and index), end with a `run` object holding a stop_reason,
// and its trace and summary rows must be waiting in the partial folder.
std::optional<Json> completed_run(const std::filesystem::path& out, const PlannedRun& run,
                                  const std::string& stem);

}  // namespace radlab
