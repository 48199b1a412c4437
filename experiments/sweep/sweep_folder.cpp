#include "experiments/sweep/sweep_folder.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

#include "core/error.h"
#include "core/paths.h"
#include "core/sha256.h"
#include "experiments/run/outputs.h"
#include "formfactor/matrix/matrix_cache.h"
#include "scene/scene_loader.h"

namespace radlab {
namespace fs = std::filesystem;

namespace {

constexpr const char* kLockName = ".radlab.lock";
constexpr const char* kPartialName = ".radlab-partial";

// Everything a sweep writes into its folder (and the plots drawn from it), and nothing else:
// --overwrite and a replacing re-run remove exactly these.
constexpr const char* kSweepEntries[] = {
    "sweep.json", "trace.csv", "summary.csv", "aggregate.csv",     "runs",      "images",
    "coverage",   "plots",     "index.html",  "contact_sheet.png", kPartialName};

void clear_sweep_files(const fs::path& out) {
  for (const char* name : kSweepEntries) {
    std::error_code ec;
    fs::remove_all(out / name, ec);
    if (ec)
      throw InputError((out / name).string() + ": cannot remove the previous sweep's file (" +
                       ec.message() + ")");
  }
}

std::string text_of(const Json& json, const char* key) {
  auto it = json.find(key);
  return it != json.end() && it->is_string() ? it->get<std::string>() : std::string();
}

std::string build_text_of(const Json& json, const char* key) {
  auto it = json.find("build");
  return it != json.end() && it->is_object() ? text_of(*it, key) : std::string();
}

}  // namespace

std::string digest_of(const std::string& bytes) {
  char text[40];
  std::snprintf(text, sizeof text, "%016llx%016llx",
                static_cast<unsigned long long>(hash_bytes(bytes.data(), bytes.size(), 0xd1)),
                static_cast<unsigned long long>(hash_bytes(bytes.data(), bytes.size(), 0xd2)));
  return text;
}

SweepIdentity sweep_identity(const ExperimentSpec& spec, const SweepPlan& plan,
                             const std::string& shard) {
  SweepIdentity id;
  id.name = spec.name;
  std::ifstream in(spec.path, std::ios::binary);
  std::ostringstream text;
  if (in) text << in.rdbuf();
  id.experiment_digest = digest_of(text.str());
  std::string runs;
  for (const PlannedRun& run : plan.runs) runs += run.run_id + '\n';
  id.plan_digest = digest_of(runs);
  id.shard = shard;
  id.git_sha = build_git_sha();
  id.source_hash = formfactor_code_version();
  // Each scene read once, now, for the files it reads: an unreadable one is recorded as such
  // (its runs then fail when their problem is prepared, naming the file, and the sweep goes on).
  for (const PlannedProblem& problem : plan.problems) {
    const std::string& scene = problem.spec.scene;
    if (id.scene_files.count(scene)) continue;
    try {
      id.scene_files[scene] = scene_source_files(scene);
    } catch (const Error&) {
      id.scene_files[scene] = {SourceFile{scene, "unreadable"}};
    }
  }
  return id;
}

std::vector<SourceFile> all_scene_files(const SweepIdentity& identity) {
  std::vector<SourceFile> files;
  for (const auto& [scene, sources] : identity.scene_files)
    for (const SourceFile& f : sources)
      if (std::find(files.begin(), files.end(), f) == files.end()) files.push_back(f);
  return files;
}

std::string scene_files_difference(const std::vector<SourceFile>& before,
                                   const std::vector<SourceFile>& now) {
  for (const SourceFile& b : before) {
    auto same_path =
        std::find_if(now.begin(), now.end(), [&](const SourceFile& n) { return n.path == b.path; });
    if (same_path == now.end()) return "the scene file " + b.path + " is no longer read";
    if (same_path->sha256 != b.sha256)
      return "the scene file " + b.path + " changed (SHA-256 " + b.sha256.substr(0, 12) +
             "... before, " + same_path->sha256.substr(0, 12) + "... now)";
  }
  for (const SourceFile& n : now)
    if (std::none_of(before.begin(), before.end(),
                     [&](const SourceFile& b) { return b.path == n.path; }))
      return "the scene file " + n.path + " is read now and was not before";
  return std::string();
}

void write_source_files(JsonWriter& json, const char* key, const std::vector<SourceFile>& files) {
  json.key(key).begin_array();
  for (const SourceFile& f : files) {
    json.begin_object();
    json.field("path", f.path);
    json.field("sha256", f.sha256);
    json.end_object();
  }
  json.end_array();
}

std::optional<std::vector<SourceFile>> read_source_files(const Json& array) {
  if (!array.is_array()) return std::nullopt;
  std::vector<SourceFile> files;
  for (const Json& item : array) {
    if (!item.is_object()) return std::nullopt;
    const std::string path = text_of(item, "path"), sha = text_of(item, "sha256");
    if (path.empty() || sha.empty()) return std::nullopt;
    files.push_back(SourceFile{path, sha});
  }
  return files;
}

void write_identity(JsonWriter& json, const SweepIdentity& identity) {
  json.field("experiment_digest", identity.experiment_digest);
  json.field("plan_digest", identity.plan_digest);
  write_source_files(json, "scene_files", all_scene_files(identity));
}

namespace {

// The folders of a sweep whose files belong to its runs (the manifest covers them all).
constexpr const char* kRunFolders[] = {"runs", "images", "coverage"};
constexpr const char* kTables[] = {"trace.csv", "summary.csv"};

ManifestEntry manifest_entry(const fs::path& folder, const std::string& relative) {
  std::error_code ec;
  const auto bytes = fs::file_size(folder / relative, ec);
  if (ec)
    throw InputError((folder / relative).string() + ": cannot read its size (" + ec.message() +
                     ")");
  return ManifestEntry{relative, file_sha256((folder / relative).string()), bytes};
}

// The files of the run folders, as relative paths (temporaries of a killed writer left out).
std::vector<std::string> run_folder_files(const fs::path& folder) {
  std::vector<std::string> files;
  for (const char* sub : kRunFolders) {
    std::error_code ec;
    if (!fs::is_directory(folder / sub, ec)) continue;
    for (fs::directory_iterator it(folder / sub, ec), end; !ec && it != end; it.increment(ec)) {
      const std::string name = it->path().filename().string();
      if (name.find(".tmp.") != std::string::npos) continue;
      files.push_back(std::string(sub) + "/" + name);
    }
    if (ec)
      throw InputError((folder / sub).string() + ": cannot list the folder (" + ec.message() + ")");
  }
  std::sort(files.begin(), files.end());
  return files;
}

}  // namespace

std::vector<ManifestEntry> folder_manifest(const fs::path& folder) {
  std::vector<ManifestEntry> entries;
  for (const char* table : kTables) entries.push_back(manifest_entry(folder, table));
  // Only a sweep (or merge) whose runs have solver seeds writes it (seed_aggregate.h).
  std::error_code ec;
  if (fs::is_regular_file(folder / "aggregate.csv", ec))
    entries.push_back(manifest_entry(folder, "aggregate.csv"));
  for (const std::string& file : run_folder_files(folder))
    entries.push_back(manifest_entry(folder, file));
  return entries;
}

void write_manifest(JsonWriter& json, const std::vector<ManifestEntry>& entries) {
  json.key("files").begin_array();
  for (const ManifestEntry& e : entries) {
    json.begin_object();
    json.field("path", e.path);
    json.field("sha256", e.sha256);
    json.field("bytes", e.bytes);
    json.end_object();
  }
  json.end_array();
}

std::vector<ManifestEntry> verify_manifest(const fs::path& folder, const Json& sweep) {
  const std::string where = (folder / "sweep.json").string();
  auto files = sweep.find("files");
  if (files == sweep.end() || !files->is_array())
    throw InputError(where +
                     ": no manifest ('files': written by an older radlab? run the shard again)");
  std::vector<ManifestEntry> entries;
  std::set<std::string> listed;
  for (const Json& item : *files) {
    auto bytes = item.is_object() ? item.find("bytes") : item.end();
    if (!item.is_object() || text_of(item, "path").empty() || text_of(item, "sha256").empty() ||
        bytes == item.end() || !bytes->is_number_unsigned())
      throw InputError(where + ": a manifest entry lacks its path, sha256 or bytes");
    ManifestEntry e{text_of(item, "path"), text_of(item, "sha256"),
                    bytes->get<unsigned long long>()};
    // Only the sweep's own files, by a relative path inside the folder.
    const fs::path relative(e.path);
    if (relative.is_absolute() ||
        !path_within((folder / relative).lexically_normal(), folder.lexically_normal()))
      throw InputError(where + ": the manifest names '" + e.path + "', outside the folder");
    listed.insert(e.path);
    entries.push_back(std::move(e));
  }
  for (const char* table : kTables)
    if (!listed.count(table)) throw InputError(where + ": the manifest does not list " + table);
  for (const ManifestEntry& e : entries) {
    const fs::path file = folder / e.path;
    std::error_code ec;
    if (!fs::is_regular_file(file, ec))
      throw InputError(file.string() + ": listed in " + where +
                       "'s manifest but missing (the folder lost files after the sweep finished)");
    const auto size = fs::file_size(file, ec);
    if (ec || size != e.bytes || file_sha256(file.string()) != e.sha256)
      throw InputError(file.string() + ": differs from " + where + "'s manifest (" +
                       (ec || size != e.bytes
                            ? std::to_string(ec ? 0 : size) + " bytes, the manifest says " +
                                  std::to_string(e.bytes)
                            : std::string("same size, another SHA-256")) +
                       "): edited, cut or damaged after the sweep finished");
  }
  for (const std::string& file : run_folder_files(folder))
    if (!listed.count(file))
      throw InputError((folder / file).string() + ": not in " + where +
                       "'s manifest (a file added after the sweep finished)");
  return entries;
}

SweepFolderLock::SweepFolderLock(const fs::path& folder) {
  std::error_code ec;
  fs::create_directories(folder, ec);
  if (ec) throw InputError(folder.string() + ": cannot create folder (" + ec.message() + ")");
  const fs::path lock = folder / kLockName;
  fd_ = ::open(lock.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0)
    throw InputError(folder.string() + ": cannot write into the output folder (" +
                     std::strerror(errno) + ")");
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    const int error = errno;
    ::close(fd_);
    fd_ = -1;
    if (error == EWOULDBLOCK)
      throw UsageError(folder.string() +
                       ": another radlab process is writing a sweep into this folder; wait for "
                       "it to finish or choose another --out");
    throw InputError(folder.string() + ": cannot lock the output folder (" + std::strerror(error) +
                     ")");
  }
}

SweepFolderLock::~SweepFolderLock() {
  if (fd_ >= 0) ::close(fd_);  // releases the flock
}

fs::path partial_folder(const fs::path& out) {
  return out / kPartialName;
}

fs::path partial_file(const fs::path& out, size_t run_index, const char* kind) {
  char name[48];
  std::snprintf(name, sizeof name, "%06zu.%s.csv", run_index, kind);
  return partial_folder(out) / name;
}

const char* lock_file_name() {
  return kLockName;
}

namespace {

// True when `out` holds nothing but the lock and a partial folder (or does not exist).
bool holds_nothing(const fs::path& out) {
  std::error_code ec;
  if (!fs::exists(out, ec)) return true;
  bool empty = true;
  for (fs::directory_iterator it(out, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name != kLockName && name != kPartialName) empty = false;
  }
  if (ec) throw InputError(out.string() + ": cannot read the output folder (" + ec.message() + ")");
  return empty;
}

// The folder's sweep.json, or nullopt (`unreadable` says why when it exists but does not parse).
std::optional<Json> read_sweep_json(const fs::path& out, std::string& unreadable) {
  if (!fs::exists(out / "sweep.json")) return std::nullopt;
  try {
    Json old = read_json_file((out / "sweep.json").string());
    if (old.is_object()) return old;
    unreadable = "not a JSON object";
  } catch (const Error& e) {
    unreadable = e.what();
  }
  return std::nullopt;
}

// The refusals of check_replaceable, given what the folder holds.
void refuse_unless_same_sweep(const fs::path& out, const std::optional<Json>& old,
                              const std::string& unreadable, const std::string& name,
                              const std::string& shard, const char* command) {
  const std::string old_name = old ? text_of(*old, "name") : std::string();
  const std::string cmd = command;
  if (!old || old_name != name) {
    const std::string holds = old ? "a sweep of experiment '" + old_name + "'"
                              : !unreadable.empty()
                                  ? "an unreadable sweep.json (" + unreadable + ")"
                                  : "no sweep (files, but no sweep.json)";
    throw UsageError((cmd == "run" ? "" : cmd + ": --out ") + out.string() +
                     " is not empty and holds " + holds + ", not experiment '" + name +
                     "'; choose another --out, or pass --overwrite to replace its sweep files");
  }
  const std::string old_shard = text_of(*old, "shard");
  if (old_shard != shard)
    throw UsageError(
        (cmd == "run" ? "" : cmd + ": --out ") + out.string() + " holds shard " + old_shard +
        " of experiment '" + name + "', not " +
        (cmd == "run" ? "shard " + shard + "; give each shard its own --out (then `radlab merge`)"
                      : "a merged sweep (" + shard + ")") +
        ", or pass --overwrite");
}

}  // namespace

void check_replaceable(const fs::path& out, const std::string& name, const std::string& shard,
                       bool overwrite, const char* command) {
  if (holds_nothing(out) || overwrite) return;
  std::string unreadable;
  const std::optional<Json> old = read_sweep_json(out, unreadable);
  refuse_unless_same_sweep(out, old, unreadable, name, shard, command);
}

bool prepare_sweep_folder(const fs::path& out, const SweepIdentity& identity, bool overwrite,
                          std::string& note) {
  if (holds_nothing(out)) {
    clear_sweep_files(out);
    return false;
  }
  if (overwrite) {
    note = "--overwrite: removing the previous sweep files in " + out.string();
    clear_sweep_files(out);
    return false;
  }
  std::string unreadable;
  const std::optional<Json> old = read_sweep_json(out, unreadable);
  refuse_unless_same_sweep(out, old, unreadable, identity.name, identity.shard, "run");

  // The same experiment: resume a killed attempt of exactly this sweep, else replace it.
  std::string differs;
  if (!old->contains("experiment_digest") || !old->contains("scene_files"))
    differs = "written by an older radlab";
  else if (text_of(*old, "experiment_digest") != identity.experiment_digest)
    differs = "the experiment file changed";
  else if (text_of(*old, "plan_digest") != identity.plan_digest)
    differs = "the run plan changed";
  else if (build_text_of(*old, "git_sha") != identity.git_sha ||
           build_text_of(*old, "source_hash") != identity.source_hash)
    differs = "radlab was rebuilt from other sources";
  else if (auto files = read_source_files((*old)["scene_files"]); !files)
    differs = "its scene_files are unreadable";
  else
    differs = scene_files_difference(*files, all_scene_files(identity));
  const std::string status = text_of(*old, "status");
  if (status == "running" && differs.empty()) {
    note = "resuming the interrupted sweep in " + out.string();
    return true;
  }
  note = "replacing the previous sweep in " + out.string() + " (" +
         (status == "running" ? "interrupted, and " + (differs.empty() ? "" : differs)
          : differs.empty()   ? "complete; ran again"
                              : differs) +
         ")";
  clear_sweep_files(out);
  return false;
}

std::optional<Json> completed_run(const fs::path& out, const PlannedRun& run,
                                  const std::string& stem,
                                  const std::vector<SourceFile>& scene_files) {
  std::error_code ec;
  if (!fs::is_regular_file(partial_file(out, run.index, "trace"), ec) ||
      !fs::is_regular_file(partial_file(out, run.index, "summary"), ec))
    return std::nullopt;
  try {
    Json json = read_json_file((out / "runs" / (stem + ".run.json")).string());
    if (!json.is_object() || text_of(json, "run_id") != run.run_id) return std::nullopt;
    auto index = json.find("run_index");
    if (index == json.end() || !index->is_number_unsigned() ||
        index->get<unsigned long long>() != run.index)
      return std::nullopt;
    auto result = json.find("run");
    if (result == json.end() || !result->is_object() || text_of(*result, "stop_reason").empty())
      return std::nullopt;
    // A run computed on other scene files is done again (its problem was prepared if the
    // run.json has a scene; one that failed before that read nothing worth keeping).
    auto scene = json.find("scene");
    if (scene != json.end() && scene->is_object()) {
      auto files = scene->find("files");
      if (files == scene->end()) return std::nullopt;
      auto recorded = read_source_files(*files);
      if (!recorded || *recorded != scene_files) return std::nullopt;
    }
    return json;
  } catch (const Error&) {
    return std::nullopt;  // missing or damaged: the run is done again
  }
}

}  // namespace radlab
