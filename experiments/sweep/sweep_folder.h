// The output folder of `radlab run`: who may write it, what it holds, and what a re-run does.
//
// - A lock (flock on OUT/.radlab.lock) keeps two processes from writing one folder: the second
//   is refused at once, naming the folder (two sweeps used to interleave their rows).
// - sweep.json says what the folder holds: the experiment's name, a digest of its text and of
//   its run plan (the run ids in order), the SHA-256 of every scene file its scenes read, the
//   shard, the build (git SHA and the form-factor source hash) and a status, "running" from the
//   start of a sweep and "complete" once every output is in place. A killed sweep therefore
//   never looks complete. A complete one lists its files with their SHA-256 (the manifest
//   `radlab merge` and the workflow check).
// - Re-running into a folder: one holding a killed ("running") sweep of the same experiment
//   text, plan, scene files, shard and build is resumed (runs already complete, verified by their
//   run.json, are skipped); one holding another sweep of the same experiment is replaced (its runs,
//   images and coverage are removed first, so nothing stale remains); anything else — a folder that
//   is not empty and holds another experiment, another shard of this one, or no sweep at all — is
//   refused unless --overwrite (which removes only the files a sweep writes).
#pragma once

#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "core/json.h"
#include "core/json_reader.h"
#include "experiments/sweep/experiment_spec.h"
#include "scene/scene.h"

namespace radlab {

// What must match for runs of two folders to belong to one sweep.
struct SweepIdentity {
  std::string name;
  std::string experiment_digest;  // of the experiment file's bytes
  std::string plan_digest;        // of every run id of the whole sweep, in order
  std::string shard;              // "i/N"
  std::string git_sha, source_hash;
  // Every file the experiment's scenes read (OBJ, MTL, MGF and its includes) with its SHA-256,
  // per scene spec as the experiment names it: an edited box.mtl is another sweep.
  std::map<std::string, std::vector<SourceFile>> scene_files;
};

// The scene files of `identity` as one list (scenes in spec order), each file once.
std::vector<SourceFile> all_scene_files(const SweepIdentity& identity);

// The first difference between two lists of scene files, said for a person ("box.mtl changed
// (SHA-256 1a2b… then, 3c4d… now)"), or empty when they are equal.
std::string scene_files_difference(const std::vector<SourceFile>& before,
                                   const std::vector<SourceFile>& now);

// sweep.json's and run.json's "scene_files" / "files" array, and back.
void write_source_files(JsonWriter& json, const char* key, const std::vector<SourceFile>& files);
std::optional<std::vector<SourceFile>> read_source_files(const Json& array);

// The manifest of a finished sweep folder: every file it holds for its runs (trace.csv,
// summary.csv, runs/, images/, coverage/), relative path -> SHA-256 and size, in path order.
struct ManifestEntry {
  std::string path;
  std::string sha256;
  unsigned long long bytes = 0;
};
std::vector<ManifestEntry> folder_manifest(const std::filesystem::path& folder);
void write_manifest(JsonWriter& json, const std::vector<ManifestEntry>& entries);

// Checks `folder` against the manifest in its sweep.json (`sweep`): every file listed is there
// with its size and SHA-256, and no file of the kinds listed (runs/, images/, coverage/) is
// there unlisted. InputError naming the file and what is wrong. Returns the entries.
std::vector<ManifestEntry> verify_manifest(const std::filesystem::path& folder, const Json& sweep);

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
// list the scene files `scene_files` lists (when its problem was prepared), and its trace and
// summary rows must be waiting in the partial folder.
std::optional<Json> completed_run(const std::filesystem::path& out, const PlannedRun& run,
                                  const std::string& stem,
                                  const std::vector<SourceFile>& scene_files);

// Who may replace the sweep folder `out` with a sweep `name`, shard `shard` (run and merge, one
// rule): a folder that is empty or holds a sweep of the same experiment and shard may be
// replaced; one holding another experiment's sweep, another shard, or files but no sweep is a
// UsageError naming what it holds, unless `overwrite`. The folder's lock file does not count.
void check_replaceable(const std::filesystem::path& out, const std::string& name,
                       const std::string& shard, bool overwrite, const char* command);

// The name of the folder's lock file (ignored when deciding whether a folder is empty).
const char* lock_file_name();

}  // namespace radlab
