// The one page to open after a sweep: OUT/index.html, written by `radlab run` at the end of a
// complete sweep, by `radlab merge`, and on demand by `radlab report OUT` (e.g. after the plots
// are drawn). It shows the experiment's name, description and command, the summary table, the
// convergence plots (plots/*.png; when there are none, the command that draws them), the
// contact sheet and every run's images, and links to sweep.json, trace.csv, summary.csv and each
// run's run.json and radiosity.csv.
//
// The page is self-contained: inline CSS, no script, no network, every link relative to OUT (so
// the folder can be moved, copied or opened from disk without a server), and everything taken
// from the folder's files (names, descriptions, CSV fields) HTML-escaped. It links only files
// that exist when it is written.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

namespace radlab {

// What write_report_page wrote.
struct ReportPage {
  std::filesystem::path path;  // OUT/index.html
  size_t runs = 0;             // rows of summary.csv
  size_t plots = 0;            // plots/*.png shown
  size_t images = 0;           // images/*.png shown
};

// Why `folder` is not a complete sweep folder (no sweep.json, a sweep.json that does not parse,
// a status other than "complete", trace.csv or summary.csv missing), or "" when it is one.
std::string incomplete_sweep_reason(const std::filesystem::path& folder);

// Writes folder/index.html. Throws InputError (exit 3) naming the folder and the reason when it
// is not a complete sweep, or when a file cannot be read or the page cannot be written.
ReportPage write_report_page(const std::filesystem::path& folder);

// `text` with & < > " ' replaced by their character references.
std::string html_escape(std::string_view text);

// A relative path as a URL path: every byte outside A-Z a-z 0-9 - . _ ~ / percent-encoded.
std::string url_path(std::string_view relative_path);

}  // namespace radlab
