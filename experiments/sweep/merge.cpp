#include "experiments/sweep/merge.h"

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <set>

#include "core/csv.h"
#include "core/csv_reader.h"
#include "core/error.h"
#include "core/json.h"
#include "core/json_reader.h"
#include "core/output_file.h"
#include "core/text.h"
#include "experiments/run/seed_aggregate.h"
#include "experiments/sweep/sweep.h"
#include "experiments/sweep/sweep_folder.h"

namespace radlab {
namespace {
namespace fs = std::filesystem;

struct Shard {
  std::string dir;
  Json sweep;
  CsvTable summary, trace;
  int index = 0, count = 1;
  std::set<std::string> stems;          // file stems of its runs
  std::vector<ManifestEntry> manifest;  // its files, verified against their SHA-256
};

std::string text_at(const Json& json, const std::string& key) {
  auto it = json.find(key);
  if (it == json.end()) return std::string();
  return it->is_string() ? it->get<std::string>() : it->dump();
}

// The value of `key` (or build.`key`) in a shard's sweep.json, refused when missing.
std::string required(const Shard& s, const std::string& key, bool in_build = false) {
  const Json* object = &s.sweep;
  if (in_build) {
    auto build = s.sweep.find("build");
    if (build == s.sweep.end() || !build->is_object())
      throw InputError(s.dir + "/sweep.json: no 'build' (written by an older radlab?)");
    object = &*build;
  }
  auto it = object->find(key);
  if (it == object->end())
    throw InputError(s.dir + "/sweep.json: no '" + (in_build ? "build." : "") + key +
                     "' (written by an older radlab? run the shard again)");
  return it->is_string() ? it->get<std::string>() : it->dump();
}

// a is b, or lies inside it.
bool within(const fs::path& a, const fs::path& b) {
  auto ai = a.begin();
  for (auto bi = b.begin(); bi != b.end(); ++bi, ++ai) {
    if (bi->empty()) continue;  // trailing separator
    if (ai == a.end() || *ai != *bi) return false;
  }
  return true;
}

fs::path absolute_path(const std::string& dir) {
  std::error_code ec;
  fs::path p = fs::weakly_canonical(fs::absolute(dir), ec);
  return ec ? fs::absolute(dir).lexically_normal() : p;
}

Shard read_shard(const std::string& dir) {
  Shard s;
  s.dir = dir;
  if (!fs::is_directory(dir)) throw InputError(dir + ": no such shard folder");
  s.sweep = read_json_file((fs::path(dir) / "sweep.json").string());
  if (!s.sweep.is_object()) throw InputError(dir + "/sweep.json: not a JSON object");
  const std::string status = required(s, "status");
  if (status != "complete")
    throw InputError(dir + "/sweep.json: status '" + status +
                     "': the shard is not complete (interrupted or still running); run it again "
                     "with the same command to finish it");
  auto shard = text::split(required(s, "shard"), '/');
  auto i = shard.size() == 2 ? text::parse_int(shard[0]) : std::nullopt;
  auto n = shard.size() == 2 ? text::parse_int(shard[1]) : std::nullopt;
  if (!i || !n || *n < 1 || *i < 0 || *i >= *n || *n > (1 << 30))
    throw InputError(dir + "/sweep.json: bad shard '" + required(s, "shard") + "'");
  s.index = int(*i);
  s.count = int(*n);
  // Every file as the shard left it (a cut summary, deleted trace rows, an emptied runs/ are
  // refused here, naming the file), before any is read.
  s.manifest = verify_manifest(fs::path(dir), s.sweep);
  s.summary = read_csv((fs::path(dir) / "summary.csv").string());
  s.trace = read_csv((fs::path(dir) / "trace.csv").string());
  return s;
}

// Copies the files of `shard`'s runs (its manifest's files in runs/, images/ and coverage/,
// whose names start with a run's file stem).
void copy_run_files(const Shard& shard, const fs::path& to) {
  for (const ManifestEntry& e : shard.manifest) {
    const fs::path relative(e.path);
    if (!relative.has_parent_path()) continue;  // trace.csv, summary.csv: merged, not copied
    const std::string name = relative.filename().string();
    bool ours = false;
    for (const std::string& stem : shard.stems)
      if (name.rfind(stem + ".", 0) == 0 || name.rfind(stem + "_step", 0) == 0) ours = true;
    if (!ours)
      throw InputError(shard.dir + "/" + e.path + ": a file of no run its sweep.json lists");
    fs::create_directories(to / relative.parent_path());
    fs::copy_file(fs::path(shard.dir) / relative, to / relative,
                  fs::copy_options::overwrite_existing);
  }
}

void write_rows(const std::string& path, const std::vector<std::string>& header,
                const std::vector<const std::vector<std::string>*>& rows) {
  OutputFile out(path);
  auto line = [](const std::vector<std::string>& fields) {
    std::string text;
    for (size_t k = 0; k < fields.size(); ++k) text += (k ? "," : "") + csv_field(fields[k]);
    return text + '\n';
  };
  out.write(line(header));
  for (const auto* row : rows) out.write(line(*row));
  out.commit();
}

// Array items of `key` from every shard, ordered by their integer field `order_key` (items
// with the same order value, e.g. one problem seen by two shards, are kept once).
Json merged_array(const std::vector<Shard>& shards, const std::string& key,
                  const std::string& order_key) {
  std::map<long long, Json> by_order;
  for (const Shard& s : shards) {
    auto array = s.sweep.find(key);
    if (array == s.sweep.end()) continue;
    if (!array->is_array()) throw InputError(s.dir + "/sweep.json: '" + key + "' is not an array");
    for (const Json& item : *array) {
      if (!item.is_object() || !item.contains(order_key) || !item[order_key].is_number_integer())
        throw InputError(s.dir + "/sweep.json: an item of '" + key + "' has no integer '" +
                         order_key + "'");
      by_order.emplace(item[order_key].get<long long>(), item);
    }
  }
  Json out = Json::array();
  for (auto& [order, item] : by_order) out.push_back(item);
  return out;
}

// The output may not be, lie in, or contain a shard (writing it would damage the shard), and
// must be new, empty or a previous sweep.
void check_output_folder(const std::vector<std::string>& dirs, const std::string& out_dir,
                         const fs::path& out) {
  for (const std::string& dir : dirs) {
    const fs::path shard = absolute_path(dir);
    if (within(out, shard))
      throw UsageError("merge: --out " + out_dir + " is " + (out == shard ? "" : "inside ") +
                       "the shard " + dir + "; choose a folder outside every shard");
    if (within(shard, out))
      throw UsageError("merge: the shard " + dir + " lies inside --out " + out_dir +
                       "; choose a folder outside every shard");
  }
  if (fs::exists(out)) {
    if (!fs::is_directory(out)) throw UsageError("merge: --out " + out_dir + " is not a folder");
  }
}

// The shards read the same scene files, byte for byte: refused naming the first file that
// differs (an edited box.mtl between two shards).
void check_same_scene_files(const Shard& first, const Shard& s) {
  auto files_of = [](const Shard& shard) {
    auto it = shard.sweep.find("scene_files");
    std::optional<std::vector<SourceFile>> files;
    if (it != shard.sweep.end()) files = read_source_files(*it);
    if (!files)
      throw InputError(shard.dir +
                       "/sweep.json: no readable 'scene_files' (written by an older radlab? run "
                       "the shard again)");
    return *files;
  };
  const std::string difference = scene_files_difference(files_of(first), files_of(s));
  if (!difference.empty())
    throw InputError("merge: " + s.dir + "/sweep.json against " + first.dir +
                     "/sweep.json: " + difference +
                     " between the shards: they computed on different versions "
                     "of the scene (run the shards again on one version)");
}

// The shards are of one sweep: the same experiment, plan, build and columns, and one split.
void check_shards_agree(const std::vector<Shard>& shards) {
  const Shard& first = shards.front();
  struct Check {
    const char* key;
    bool in_build;
    const char* meaning;
  };
  const Check checks[] = {
      {"name", false, "shards of different experiments"},
      {"experiment_digest", false, "the experiment file was edited between the shards"},
      {"plan_digest", false, "the shards planned different runs"},
      {"runs_total", false, "the shards planned different runs"},
      {"git_sha", true, "the shards were run by different builds"},
      {"source_hash", true, "the shards were run by different form-factor code"}};
  for (const Shard& s : shards) {
    for (const Check& c : checks) {
      const std::string a = required(first, c.key, c.in_build);
      const std::string b = required(s, c.key, c.in_build);
      if (a != b)
        throw InputError("merge: " + s.dir + "/sweep.json: " + (c.in_build ? "build." : "") +
                         c.key + " '" + b + "' differs from " + first.dir + "/sweep.json ('" + a +
                         "'): " + c.meaning);
    }
    check_same_scene_files(first, s);
    if (s.summary.header != first.summary.header)
      throw InputError(s.summary.path + ": summary columns differ from " + first.summary.path);
    if (s.trace.header != first.trace.header)
      throw InputError(s.trace.path + ": trace columns differ from " + first.trace.path);
    if (s.count != first.count)
      throw InputError("merge: " + s.dir + " is shard " + std::to_string(s.index) + "/" +
                       std::to_string(s.count) + " of a " + std::to_string(s.count) +
                       "-way split, " + first.dir + " of a " + std::to_string(first.count) +
                       "-way split");
  }
}

using Row = std::vector<std::string>;
using OrderedRows = std::vector<std::pair<long long, const Row*>>;

// The run ids a shard's sweep.json lists (their file stems are noted for copying its files).
std::set<std::string> listed_runs(Shard& s) {
  std::set<std::string> listed;
  auto runs = s.sweep.find("runs");
  if (runs == s.sweep.end() || !runs->is_array())
    throw InputError(s.dir + "/sweep.json: no 'runs' list");
  for (const Json& id : *runs) {
    if (!id.is_string()) throw InputError(s.dir + "/sweep.json: a run id is not a string");
    listed.insert(id.get<std::string>());
    s.stems.insert(file_stem(id.get<std::string>()));
  }
  return listed;
}

// One shard's summary rows, by run index: the runs its sweep.json lists, of its shard, none in
// another shard (`seen`: run id -> shard folder).
void add_summary_rows(Shard& s, long long runs_total, std::map<std::string, std::string>& seen,
                      OrderedRows& ordered) {
  const size_t index_column = s.summary.column("run_index");
  const size_t id_column = s.summary.column("run_id");
  const std::set<std::string> listed = listed_runs(s);
  std::set<std::string> in_summary;
  for (const auto& row : s.summary.rows) {
    auto index = text::parse_int(row[index_column]);
    if (!index || *index < 0 || *index >= runs_total)
      throw InputError(s.summary.path + ": bad run_index '" + row[index_column] + "'");
    if (*index % s.count != s.index)
      throw InputError(s.summary.path + ": run " + row[id_column] + " (index " + row[index_column] +
                       ") does not belong to shard " + std::to_string(s.index) + "/" +
                       std::to_string(s.count));
    if (!seen.emplace(row[id_column], s.dir).second)
      throw InputError("merge: run '" + row[id_column] + "' is in " + seen[row[id_column]] +
                       " and in " + s.dir);
    in_summary.insert(row[id_column]);
    ordered.emplace_back(*index, &row);
  }
  if (in_summary != listed)
    throw InputError("merge: " + s.summary.path + " holds " + std::to_string(in_summary.size()) +
                     " runs but " + s.dir + "/sweep.json lists " + std::to_string(listed.size()) +
                     " (a damaged or mixed folder)");
}

// Every shard's summary rows in run order; no shard twice, no run index twice.
OrderedRows ordered_summary_rows(std::vector<Shard>& shards, long long runs_total,
                                 std::map<int, std::string>& shard_seen) {
  OrderedRows ordered;
  std::map<std::string, std::string> seen;  // run_id -> shard folder
  for (Shard& s : shards) {
    if (!shard_seen.emplace(s.index, s.dir).second)
      throw InputError("merge: " + s.dir + " and " + shard_seen[s.index] + " are both shard " +
                       std::to_string(s.index) + "/" + std::to_string(s.count));
    add_summary_rows(s, runs_total, seen, ordered);
  }
  std::sort(ordered.begin(), ordered.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  for (size_t k = 1; k < ordered.size(); ++k)
    if (ordered[k].first == ordered[k - 1].first)
      throw InputError("merge: two runs have run_index " + std::to_string(ordered[k].first));
  return ordered;
}

// Trace rows grouped by run in their original order; none repeated, none of an unknown run.
std::map<std::string, std::vector<const Row*>> trace_rows_by_run(const std::vector<Shard>& shards) {
  const Shard& first = shards.front();
  const size_t trace_id = first.trace.column("run_id");
  const size_t trace_step = first.trace.column("step");
  const size_t trace_channel = first.trace.column("channel");
  std::map<std::string, std::vector<const Row*>> by_run;
  for (const Shard& s : shards) {
    std::set<std::tuple<std::string, std::string, std::string>> rows_seen;
    const size_t id_column = s.summary.column("run_id");
    std::set<std::string> ids;
    for (const auto& row : s.summary.rows) ids.insert(row[id_column]);
    for (size_t r = 0; r < s.trace.rows.size(); ++r) {
      const auto& row = s.trace.rows[r];
      if (!ids.count(row[trace_id]))
        throw InputError(s.trace.path + ": a row of run '" + row[trace_id] + "', which is not in " +
                         s.summary.path);
      if (!rows_seen.emplace(row[trace_id], row[trace_step], row[trace_channel]).second)
        throw InputError(s.trace.path + ": row " + std::to_string(r + 2) + " repeats run '" +
                         row[trace_id] + "' step " + row[trace_step] + " channel " +
                         row[trace_channel]);
      by_run[row[trace_id]].push_back(&row);
    }
  }
  return by_run;
}

// What the merge writes: the tables' rows in run order and sweep.json.
struct MergedSweep {
  std::vector<const Row*> summary_rows, trace_rows;
  Json sweep;
};

// sweep.json: the unsplit run's, with every shard's runs, failures and problems in the sweep's
// order; `merged_from` names the shards and their commands. `missing` runs (and shards) make it
// "incomplete".
Json merged_sweep_json(const std::vector<Shard>& shards, const std::vector<std::string>& run_ids,
                       long long missing, const std::vector<std::string>& missing_shards,
                       const MergeOptions& options) {
  Json merged = shards.front().sweep;
  if (!options.command.empty()) merged["command"] = options.command;
  merged["shard"] = "0/1";
  merged["status"] = missing == 0 ? "complete" : "incomplete";
  merged["runs"] = run_ids;
  if (merged.contains("failed")) merged["failed"] = merged_array(shards, "failed", "run_index");
  if (merged.contains("problems")) merged["problems"] = merged_array(shards, "problems", "index");
  if (missing != 0) {
    merged["missing_runs"] = missing;
    merged["missing_shards"] = missing_shards;
  }
  Json from = Json::array();
  for (const Shard& s : shards)
    from.push_back({{"folder", s.dir},
                    {"shard", text_at(s.sweep, "shard")},
                    {"command", text_at(s.sweep, "command")}});
  merged["merged_from"] = from;
  return merged;
}

// Writes into a temporary sibling, then puts it in place (a previous sweep there is moved aside,
// replaced, then removed).
void write_merged_folder(const std::vector<Shard>& shards, const MergedSweep& merged,
                         const fs::path& out, const std::string& out_dir) {
  const Shard& first = shards.front();
  const fs::path temp = out.string() + ".tmp." + std::to_string(::getpid());
  try {
    fs::remove_all(temp);
    fs::create_directories(temp);
    // Locked too: renamed into place, its lock file is --out's, held until the merge is done.
    SweepFolderLock temp_lock(temp);
    write_rows((temp / "summary.csv").string(), first.summary.header, merged.summary_rows);
    write_rows((temp / "trace.csv").string(), first.trace.header, merged.trace_rows);
    // Over every shard's seeds of each configuration (a shard writes none).
    write_seed_aggregate(read_csv((temp / "summary.csv").string()),
                         (temp / "aggregate.csv").string());
    for (const Shard& s : shards) copy_run_files(s, temp);
    // The merged folder's own manifest, like a sweep's (a merged folder is a complete sweep).
    Json sweep = merged.sweep;
    Json files = Json::array();
    for (const ManifestEntry& e : folder_manifest(temp))
      files.push_back({{"path", e.path}, {"sha256", e.sha256}, {"bytes", e.bytes}});
    sweep["files"] = files;
    JsonWriter json;
    write_json_value(json, sweep);
    json.save((temp / "sweep.json").string());
    if (fs::exists(out)) {
      const fs::path old = out.string() + ".old." + std::to_string(::getpid());
      fs::rename(out, old);
      fs::rename(temp, out);
      fs::remove_all(old);
    } else {
      if (out.has_parent_path()) fs::create_directories(out.parent_path());
      fs::rename(temp, out);
    }
  } catch (const fs::filesystem_error& e) {
    std::error_code ignored;
    fs::remove_all(temp, ignored);
    throw InputError("merge: cannot write " + out_dir + " (" + e.code().message() + ": " +
                     e.path1().string() + ")");
  } catch (...) {
    std::error_code ignored;
    fs::remove_all(temp, ignored);
    throw;
  }
}

}  // namespace

size_t merge_sweeps(const std::vector<std::string>& dirs, const std::string& out_dir,
                    const std::string& command) {
  MergeOptions options;
  options.command = command;
  return merge_shards(dirs, out_dir, options);
}

size_t merge_shards(const std::vector<std::string>& dirs, const std::string& out_dir,
                    const MergeOptions& options) {
  if (dirs.empty()) throw UsageError("merge: give at least one shard folder");
  if (out_dir.empty()) throw UsageError("merge: give an output folder (--out)");
  const fs::path out = absolute_path(out_dir);
  check_output_folder(dirs, out_dir, out);

  // Read and check everything before writing anything.
  std::vector<Shard> shards;
  for (const std::string& dir : dirs) shards.push_back(read_shard(dir));
  check_shards_agree(shards);
  const Shard& first = shards.front();
  const long long runs_total = std::stoll(required(first, "runs_total"));
  std::map<int, std::string> shard_seen;  // shard index -> folder
  const OrderedRows ordered = ordered_summary_rows(shards, runs_total, shard_seen);

  // Every run of the sweep, or a visible refusal.
  std::vector<std::string> missing_shards;
  for (int i = 0; i < first.count; ++i)
    if (!shard_seen.count(i))
      missing_shards.push_back(std::to_string(i) + "/" + std::to_string(first.count));
  const long long missing = runs_total - static_cast<long long>(ordered.size());
  if (missing != 0 && !options.allow_incomplete)
    throw InputError("merge: the shards hold " + std::to_string(ordered.size()) + " of the " +
                     std::to_string(runs_total) + " runs of the sweep" +
                     (missing_shards.empty()
                          ? std::string()
                          : "; missing shards: " + text::join(missing_shards, ", ")) +
                     " (--allow-incomplete merges them, marked incomplete)");

  std::map<std::string, std::vector<const Row*>> by_run = trace_rows_by_run(shards);
  MergedSweep merged;
  const size_t id_column = first.summary.column("run_id");
  std::vector<std::string> run_ids;
  for (const auto& [index, row] : ordered) {
    merged.summary_rows.push_back(row);
    run_ids.push_back((*row)[id_column]);
    for (const auto* t : by_run[(*row)[id_column]]) merged.trace_rows.push_back(t);
  }
  merged.sweep = merged_sweep_json(shards, run_ids, missing, missing_shards, options);

  // The lock a `radlab run` takes: no run writes --out while the merge replaces it, and no merge
  // replaces a folder a run is writing. Then the rule `radlab run` follows: another experiment's
  // sweep (or a shard, or files that are no sweep) is replaced only with --overwrite. A folder
  // created for the lock goes again if the merge fails.
  std::error_code ec;
  const bool created = !fs::exists(out, ec);
  try {
    SweepFolderLock lock(out);
    check_replaceable(out, required(first, "name"), "0/1", options.overwrite, "merge");
    write_merged_folder(shards, merged, out, out_dir);
  } catch (...) {
    if (created) fs::remove_all(out, ec);
    throw;
  }
  return ordered.size();
}

}  // namespace radlab
