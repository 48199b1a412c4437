// `radlab report OUT`: writes OUT/index.html, the page to open after a sweep (summary table,
// plots, images, links to every result file; experiments/run/report_page.h). `radlab run` and
// `radlab merge` write it too; run it again after drawing the plots so that the page shows them.
#include <cstdio>

#include "cli/cli_common.h"
#include "experiments/run/report_page.h"

namespace radlab::cli {

void add_report_command(CLI::App& app) {
  auto* command = app.add_subcommand(
      "report",
      "write OUT/index.html for a complete sweep: its command, summary table, convergence plots "
      "(plots/*.png), images and links to trace.csv, summary.csv and each run's run.json; "
      "self-contained, opens from disk (exit 3 if OUT is not a complete sweep)");
  auto folder = std::make_shared<std::string>();
  command->add_option("out", *folder, "the --out folder of `radlab run` or `radlab merge`")
      ->required();
  command->callback([folder]() {
    const ReportPage page = write_report_page(*folder);
    std::printf("wrote %s: %zu runs, %zu plots, %zu images\n", page.path.string().c_str(),
                page.runs, page.plots, page.images);
  });
}

}  // namespace radlab::cli
