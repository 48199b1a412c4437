#include "experiments/sweep/sweep_folder.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

#include "core/error.h"
#include "experiments/run/outputs.h"
#include "formfactor/matrix/matrix_cache.h"

namespace radlab {
namespace fs = std::filesystem;

namespace {

constexpr const char* kLockName = ".radlab.lock";
constexpr const char* kPartialName = ".radlab-partial";

// Everything a sweep writes into its folder (and the plots drawn from it), and nothing else:
// --overwrite and a replacing re-run remove exactly these.
constexpr const char* kSweepEntries[] = {
    "sweep.json", "trace.csv",  "summary.csv",       "runs",      "images", "coverage",
    "plots",      "index.html", "contact_sheet.png", kPartialName};

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
  return id;
}

void write_identity(JsonWriter& json, const SweepIdentity& identity) {
  json.field("experiment_digest", identity.experiment_digest);
  json.field("plan_digest", identity.plan_digest);
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

bool prepare_sweep_folder(const fs::path& out, const SweepIdentity& identity, bool overwrite,
                          std::string& note) {
  bool empty = true;
  std::error_code ec;
  for (fs::directory_iterator it(out, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name != kLockName && name != kPartialName) empty = false;
  }
  if (ec) throw InputError(out.string() + ": cannot read the output folder (" + ec.message() + ")");
  if (empty) {
    clear_sweep_files(out);
    return false;
  }

  std::optional<Json> old;
  std::string unreadable;
  if (fs::exists(out / "sweep.json")) {
    try {
      old = read_json_file((out / "sweep.json").string());
      if (!old->is_object()) old.reset();
    } catch (const Error& e) {
      unreadable = e.what();
    }
  }
  const std::string old_name = old ? text_of(*old, "name") : std::string();
  if (overwrite) {
    note = "--overwrite: removing the previous sweep files in " + out.string();
    clear_sweep_files(out);
    return false;
  }
  if (!old || old_name != identity.name) {
    const std::string holds = old ? "a sweep of experiment '" + old_name + "'"
                              : !unreadable.empty()
                                  ? "an unreadable sweep.json (" + unreadable + ")"
                                  : "files but no sweep.json";
    throw UsageError(out.string() + " is not empty and holds " + holds + ", not experiment '" +
                     identity.name +
                     "'; choose another --out, or pass --overwrite to replace its sweep files");
  }
  const std::string old_shard = text_of(*old, "shard");
  if (old_shard != identity.shard)
    throw UsageError(out.string() + " holds shard " + old_shard + " of experiment '" +
                     identity.name + "', not shard " + identity.shard +
                     "; give each shard its own --out (then `radlab merge`), or pass --overwrite");

  // The same experiment: resume a killed attempt of exactly this sweep, else replace it.
  std::string differs;
  if (!old->contains("experiment_digest"))
    differs = "written by an older radlab";
  else if (text_of(*old, "experiment_digest") != identity.experiment_digest)
    differs = "the experiment file changed";
  else if (text_of(*old, "plan_digest") != identity.plan_digest)
    differs = "the run plan changed";
  else if (build_text_of(*old, "git_sha") != identity.git_sha ||
           build_text_of(*old, "source_hash") != identity.source_hash)
    differs = "radlab was rebuilt from other sources";
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
                                  const std::string& stem) {
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
    return json;
  } catch (const Error&) {
    return std::nullopt;  // missing or damaged: the run is done again
  }
}

}  // namespace radlab
