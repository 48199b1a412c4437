#include "experiments/merge.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>

#include "core/csv.h"
#include "core/csv_reader.h"
#include "core/error.h"
#include "core/text.h"

namespace radlab {
namespace {

void write_rows(const std::string& path, const std::vector<std::string>& header,
                const std::vector<const std::vector<std::string>*>& rows) {
  std::ofstream out(path);
  if (!out) throw InputError(path + ": cannot write file");
  for (size_t k = 0; k < header.size(); ++k) out << (k ? "," : "") << csv_field(header[k]);
  out << '\n';
  for (const auto* row : rows) {
    for (size_t k = 0; k < row->size(); ++k) out << (k ? "," : "") << csv_field((*row)[k]);
    out << '\n';
  }
}

void copy_folder(const std::filesystem::path& from, const std::filesystem::path& to) {
  namespace fs = std::filesystem;
  if (!fs::exists(from)) return;
  fs::create_directories(to);
  for (const auto& entry : fs::directory_iterator(from))
    if (entry.is_regular_file())
      fs::copy_file(entry.path(), to / entry.path().filename(),
                    fs::copy_options::overwrite_existing);
}

}  // namespace

size_t merge_sweeps(const std::vector<std::string>& dirs, const std::string& out_dir) {
  namespace fs = std::filesystem;
  if (dirs.empty()) throw UsageError("merge: give at least one shard folder");
  std::vector<CsvTable> summaries, traces;
  for (const std::string& dir : dirs) {
    summaries.push_back(read_csv((fs::path(dir) / "summary.csv").string()));
    traces.push_back(read_csv((fs::path(dir) / "trace.csv").string()));
    if (summaries.back().header != summaries.front().header)
      throw InputError(summaries.back().path + ": summary columns differ from " +
                       summaries.front().path);
    if (traces.back().header != traces.front().header)
      throw InputError(traces.back().path + ": trace columns differ from " + traces.front().path);
  }

  // Summary rows in the sweep's run order.
  std::vector<std::pair<long long, const std::vector<std::string>*>> ordered;
  std::map<std::string, std::string> seen;  // run_id -> shard
  for (size_t s = 0; s < summaries.size(); ++s) {
    const size_t index_column = summaries[s].column("run_index");
    const size_t id_column = summaries[s].column("run_id");
    for (const auto& row : summaries[s].rows) {
      auto index = text::parse_int(row[index_column]);
      if (!index)
        throw InputError(summaries[s].path + ": bad run_index '" + row[index_column] + "'");
      if (!seen.emplace(row[id_column], dirs[s]).second)
        throw InputError("merge: run '" + row[id_column] + "' is in " + seen[row[id_column]] +
                         " and in " + dirs[s]);
      ordered.emplace_back(*index, &row);
    }
  }
  std::sort(ordered.begin(), ordered.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });

  // Trace rows grouped by run, each run's rows in their original order.
  std::map<std::string, std::vector<const std::vector<std::string>*>> by_run;
  for (const CsvTable& t : traces) {
    const size_t id = t.column("run_id");
    for (const auto& row : t.rows) by_run[row[id]].push_back(&row);
  }

  fs::create_directories(out_dir);
  std::vector<const std::vector<std::string>*> summary_rows, trace_rows;
  const size_t id_column = summaries.front().column("run_id");
  for (const auto& [index, row] : ordered) {
    summary_rows.push_back(row);
    for (const auto* t : by_run[(*row)[id_column]]) trace_rows.push_back(t);
  }
  write_rows((fs::path(out_dir) / "summary.csv").string(), summaries.front().header, summary_rows);
  write_rows((fs::path(out_dir) / "trace.csv").string(), traces.front().header, trace_rows);
  for (const std::string& dir : dirs) {
    copy_folder(fs::path(dir) / "runs", fs::path(out_dir) / "runs");
    copy_folder(fs::path(dir) / "images", fs::path(out_dir) / "images");
  }
  return ordered.size();
}

}  // namespace radlab
