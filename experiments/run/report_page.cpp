// OUT/index.html for a complete sweep (report_page.h).
#include "experiments/run/report_page.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "core/csv_reader.h"
#include "core/error.h"
#include "core/json_reader.h"
#include "core/output_file.h"
#include "core/text.h"
#include "experiments/sweep/sweep.h"

namespace radlab {
namespace fs = std::filesystem;

namespace {

// Inline, so the page needs no other file; wide tables scroll inside their box.
constexpr const char* kStyle = R"(body{font-family:sans-serif;margin:1.5em auto;max-width:78em;
padding:0 1em;color:#222;line-height:1.4}
h1{margin-bottom:.2em}h2{margin-top:1.6em;border-bottom:1px solid #ccc}
code{background:#f3f3f3;padding:0 .25em}
.scroll{overflow-x:auto}
table{border-collapse:collapse;font-size:.85em}
th,td{border:1px solid #ccc;padding:.2em .45em;text-align:left;white-space:nowrap}
th{background:#eee}tr:nth-child(even) td{background:#fafafa}
.grid{display:flex;flex-wrap:wrap;gap:.8em}
figure{margin:0;font-size:.8em}figure img{max-width:100%;border:1px solid #ddd}
.plots figure{width:38em}.images figure{width:15em}
.failed{color:#a00}
)";

// The overview table's columns, when summary.csv has them (the details hold every column).
const std::vector<std::string> kOverviewColumns = {"run_id",
                                                   "solver",
                                                   "params",
                                                   "elements",
                                                   "ff_rows",
                                                   "seconds",
                                                   "stop_reason",
                                                   "rms_rel",
                                                   "p_mean",
                                                   "p_max",
                                                   "rows_to_rms_rel_1e-3",
                                                   "fit_rate_per_row"};

std::string string_field(const Json& json, const char* key) {
  auto it = json.find(key);
  if (it == json.end() || it->is_null()) return "";
  return it->is_string() ? it->get<std::string>() : it->dump();
}

// Files directly in folder/sub whose names end with `extension`, as "sub/name", sorted.
std::vector<std::string> files_in(const fs::path& folder, const std::string& sub,
                                  const std::string& extension) {
  std::vector<std::string> names;
  std::error_code ec;
  if (!fs::is_directory(folder / sub, ec)) return names;
  for (const auto& entry : fs::directory_iterator(folder / sub, ec)) {
    const std::string name = entry.path().filename().string();
    if (!entry.is_regular_file(ec) || name.size() < extension.size() ||
        name.compare(name.size() - extension.size(), extension.size(), extension) != 0)
      continue;
    // Temporaries of an unfinished writer are not results.
    if (name.find(".tmp.") != std::string::npos) continue;
    names.push_back(sub + "/" + name);
  }
  std::sort(names.begin(), names.end());
  return names;
}

bool is_file(const fs::path& path) {
  std::error_code ec;
  return fs::is_regular_file(path, ec);
}

// A number with more digits than a reader compares at a glance, printed with four significant
// digits (the overview only; the details and summary.csv keep every digit).
std::string overview_value(const std::string& field) {
  const std::optional<double> value = text::parse_double(field);
  const bool integer = field.find_first_of(".eE") == std::string::npos;
  if (!value || integer || field.size() <= 7) return field;
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.4g", *value);
  return buffer;
}

std::string link(const std::string& relative, const std::string& label) {
  return "<a href=\"" + url_path(relative) + "\">" + html_escape(label) + "</a>";
}

std::string figure(const std::string& relative) {
  const std::string url = url_path(relative);
  const std::string name = html_escape(fs::path(relative).filename().string());
  return "<figure><a href=\"" + url + "\"><img src=\"" + url + "\" alt=\"" + name +
         "\" loading=\"lazy\"></a><figcaption>" + name + "</figcaption></figure>\n";
}

// The run's own files (runs/STEM.run.json, runs/STEM.radiosity.csv), those that exist.
std::string run_links(const fs::path& folder, const std::string& run_id) {
  const std::string stem = file_stem(run_id);
  std::string html;
  for (const char* kind : {"run.json", "radiosity.csv"}) {
    const std::string relative = "runs/" + stem + "." + kind;
    if (!is_file(folder / relative)) continue;
    if (!html.empty()) html += " ";
    html += link(relative, kind);
  }
  return html;
}

// An HTML table of `columns` of the summary, one row per run, with each run's files.
std::string summary_table(const fs::path& folder, const CsvTable& summary,
                          const std::vector<size_t>& columns, bool overview) {
  const size_t run_id = summary.column("run_id");
  std::string html = "<div class=\"scroll\"><table>\n<tr>";
  for (size_t c : columns) html += "<th>" + html_escape(summary.header[c]) + "</th>";
  html += "<th>files</th></tr>\n";
  for (const auto& row : summary.rows) {
    html += "<tr>";
    for (size_t c : columns)
      html += "<td>" + html_escape(overview ? overview_value(row[c]) : row[c]) + "</td>";
    html += "<td>" + run_links(folder, row[run_id]) + "</td></tr>\n";
  }
  return html + "</table></div>\n";
}

std::string files_section(const fs::path& folder, const std::vector<std::string>& others) {
  std::string html = "<h2>Files</h2>\n<ul>\n";
  const std::pair<const char*, const char*> top[] = {
      {"summary.csv",
       "one row per run: final errors, rows and seconds to each threshold, fitted "
       "rates"},
      {"trace.csv", "every run's errors at every checkpoint"},
      {"aggregate.csv",
       "per configuration repeated over solver seeds: mean, standard deviation and 90% band of "
       "the final errors"},
      {"sweep.json", "what the folder holds: experiment, digests, build, runs, failures"},
      {"contact_sheet.png", "every run's images side by side"}};
  for (const auto& [name, what] : top)
    if (is_file(folder / name))
      html += "<li>" + link(name, name) + ": " + html_escape(what) + "</li>\n";
  html +=
      "<li>runs/: each run's run.json (how to reproduce it) and radiosity.csv (its final "
      "radiosities), linked from the table above; columns in docs/outputs.md</li>\n";
  for (const std::string& other : others) html += "<li>" + link(other, other) + "</li>\n";
  return html + "</ul>\n";
}

}  // namespace

std::string html_escape(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&#39;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::string url_path(std::string_view relative_path) {
  static const char* kHex = "0123456789ABCDEF";
  std::string out;
  for (char c : relative_path) {
    const auto byte = static_cast<unsigned char>(c);
    if ((byte >= 'A' && byte <= 'Z') || (byte >= 'a' && byte <= 'z') ||
        (byte >= '0' && byte <= '9') || c == '-' || c == '.' || c == '_' || c == '~' || c == '/') {
      out += c;
    } else {
      out += '%';
      out += kHex[byte >> 4];
      out += kHex[byte & 15];
    }
  }
  return out;
}

std::string incomplete_sweep_reason(const fs::path& folder) {
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) return folder.string() + ": not a folder";
  if (!is_file(folder / "sweep.json"))
    return folder.string() +
           ": holds no sweep (no sweep.json); give the --out folder of `radlab run` or "
           "`radlab merge`";
  Json sweep;
  try {
    sweep = read_json_file((folder / "sweep.json").string());
  } catch (const Error& e) {
    return e.what();
  }
  const std::string status = sweep.is_object() ? string_field(sweep, "status") : "";
  if (status != "complete")
    return (folder / "sweep.json").string() + ": the sweep is not complete (status \"" + status +
           "\"); finish it by re-running `radlab run` into the folder";
  for (const char* name : {"summary.csv", "trace.csv"})
    if (!is_file(folder / name))
      return (folder / name).string() + ": missing, though sweep.json says \"complete\"";
  return "";
}

namespace {

// The page's head and its first paragraph: the sweep's name, description, command, experiment
// file, shard, runs and radlab's version.
std::string header_section(const Json& sweep, size_t runs) {
  const std::string name = string_field(sweep, "name");
  std::string html = "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n";
  html += "<title>radlab: " + html_escape(name) + "</title>\n<style>" + kStyle + "</style>\n";
  html += "</head>\n<body>\n<h1>" + html_escape(name) + "</h1>\n";
  const std::string description = string_field(sweep, "description");
  if (!description.empty()) html += "<p>" + html_escape(description) + "</p>\n";
  html += "<p>Command: <code>" + html_escape(string_field(sweep, "command")) + "</code><br>\n";
  html += "Experiment file: <code>" + html_escape(string_field(sweep, "experiment")) + "</code>";
  html += ", shard " + html_escape(string_field(sweep, "shard")) + ", " + std::to_string(runs) +
          " of " + html_escape(string_field(sweep, "runs_total")) + " runs";
  auto build = sweep.find("build");
  if (build != sweep.end() && build->is_object())
    html += ", radlab " + html_escape(string_field(*build, "git_sha"));
  html += "</p>\n";
  auto failed = sweep.find("failed");
  if (failed != sweep.end() && failed->is_array() && !failed->empty()) {
    html += "<h2 class=\"failed\">Failed runs</h2>\n<ul class=\"failed\">\n";
    for (const Json& f : *failed)
      html += "<li><code>" + html_escape(string_field(f, "run_id")) +
              "</code>: " + html_escape(string_field(f, "error")) + "</li>\n";
    html += "</ul>\n";
  }
  return html;
}

// The summary: the overview columns, then every column folded away.
std::string summary_section(const fs::path& folder, const CsvTable& summary) {
  std::string html = "<h2>Summary</h2>\n";
  std::vector<size_t> overview, every;
  for (const std::string& column : kOverviewColumns) {
    auto it = std::find(summary.header.begin(), summary.header.end(), column);
    if (it != summary.header.end()) overview.push_back(size_t(it - summary.header.begin()));
  }
  for (size_t c = 0; c < summary.header.size(); ++c) every.push_back(c);
  html += summary_table(folder, summary, overview, true);
  html += "<details><summary>every column of summary.csv (docs/outputs.md)</summary>\n" +
          summary_table(folder, summary, every, false) + "</details>\n";
  return html;
}

// The convergence plots, or how to draw them.
std::string plots_section(const fs::path& folder, ReportPage& page) {
  std::string html = "<h2>Convergence</h2>\n";
  const std::vector<std::string> plots = files_in(folder, "plots", ".png");
  page.plots = plots.size();
  if (plots.empty()) {
    const std::string out = html_escape(folder.string());
    html +=
        "<p>No plots yet. Draw them from the repository's root, then write this page "
        "again:<br>\n<code>/usr/bin/python3 scripts/plot_traces.py " +
        out + "</code><br>\n<code>radlab report " + out + "</code></p>\n";
  } else {
    html += "<div class=\"grid plots\">\n";
    for (const std::string& plot : plots) html += figure(plot);
    html += "</div>\n";
  }
  return html;
}

// The contact sheet and each run's images, when there are any.
std::string images_section(const fs::path& folder, ReportPage& page) {
  const std::vector<std::string> images = files_in(folder, "images", ".png");
  page.images = images.size();
  const bool sheet = is_file(folder / "contact_sheet.png");
  if (!sheet && images.empty()) return {};
  std::string html = "<h2>Images</h2>\n";
  if (sheet) html += "<div class=\"grid plots\">\n" + figure("contact_sheet.png") + "</div>\n";
  if (!images.empty()) {
    html +=
        "<p>Each run's display solution, its error in Cohen's colours and its p-error "
        "(EXR beside each PNG; docs/outputs.md, \"Images\").</p>\n<div class=\"grid "
        "images\">\n";
    for (const std::string& image : images) html += figure(image);
    html += "</div>\n";
  }
  return html;
}

}  // namespace

ReportPage write_report_page(const fs::path& folder) {
  const std::string reason = incomplete_sweep_reason(folder);
  if (!reason.empty()) throw InputError(reason);
  const Json sweep = read_json_file((folder / "sweep.json").string());
  const CsvTable summary = read_csv((folder / "summary.csv").string());

  ReportPage page;
  page.path = folder / "index.html";
  page.runs = summary.rows.size();
  std::string html = header_section(sweep, page.runs);
  html += summary_section(folder, summary);
  html += plots_section(folder, page);
  html += images_section(folder, page);
  std::vector<std::string> others = files_in(folder, "plots", ".pdf");
  for (const std::string& file : files_in(folder, "coverage", "")) others.push_back(file);
  html += files_section(folder, others);
  html += "</body>\n</html>\n";

  OutputFile file(page.path.string());
  file.write(html);
  file.commit();
  return page;
}

}  // namespace radlab
