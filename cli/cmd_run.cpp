// `radlab run EXPERIMENT.toml [--out DIR] [--shard i/N]` and `radlab merge DIR... --out DIR`.
#include <cstdio>
#include <filesystem>

#include "cli/cli_common.h"
#include "core/error.h"
#include "core/log.h"
#include "experiments/run/outputs.h"
#include "experiments/run/report_page.h"
#include "experiments/sweep/merge.h"
#include "experiments/sweep/sweep.h"

namespace radlab::cli {

void add_run_command(CLI::App& app, int argc, char** argv) {
  auto* command = app.add_subcommand(
      "run", "run an experiment file: scenes x solvers x parameter axes, with a shared reference");
  struct Options {
    std::string file, out, shard = "0/1";
    bool list = false, overwrite = false;
  };
  auto o = std::make_shared<Options>();
  command->add_option("experiment", o->file, "experiment file (experiments/*.toml)")->required();
  command->add_option("--out", o->out, "output folder (default out/NAME)");
  command->add_option("--shard", o->shard,
                      "run every N-th run only: i/N (merge with `radlab merge`)");
  command->add_flag("--list", o->list, "list the runs and exit");
  command->add_flag("--overwrite", o->overwrite,
                    "replace the sweep files in a --out that holds another experiment, another "
                    "shard or no sweep (a re-run of the same experiment needs no flag: it "
                    "resumes an interrupted sweep, or replaces a finished one)");
  command->callback([o, argc, argv]() {
    ExperimentSpec spec = read_experiment(o->file);
    if (o->list) {
      SweepPlan plan = plan_sweep(spec);
      for (const PlannedRun& run : plan.runs)
        std::printf("%zu %s\n", run.index, run.run_id.c_str());
      return;
    }
    SweepOptions options;
    options.out_dir = o->out.empty() ? "out/" + spec.name : o->out;
    std::tie(options.shard_index, options.shard_count) = parse_shard(o->shard);
    options.command = command_line(argc, argv);
    options.overwrite = o->overwrite;
    SweepReport report = run_sweep(spec, options);
    if (report.runs_resumed > 0)
      std::printf("resumed: %zu runs were already complete from an interrupted attempt\n",
                  report.runs_resumed);
    // The sweep is complete (failed runs included, in its summary): the page to open first.
    write_report_page(options.out_dir);
    std::printf(
        "ran %zu of %zu runs; results in %s (index.html, trace.csv, summary.csv, runs/%s%s)\n",
        report.runs_done, report.runs_total, options.out_dir.c_str(),
        spec.images.steps.empty() ? "" : ", images/",
        spec.coverage_steps.empty() ? "" : ", coverage/");
    if (!report.failures.empty()) {
      // The others finished and everything is written; the exit code says a run failed
      // (4 if any failed numerically, else 3 or 2).
      std::string message = std::to_string(report.failures.size()) + " of " +
                            std::to_string(report.runs_done) +
                            " runs failed (stop_reason and error in summary.csv):";
      for (const RunFailure& f : report.failures) message += "\n  " + f.run_id + ": " + f.message;
      throw Error(ExitCode(report.exit_code()), message);
    }
  });
}

void add_merge_command(CLI::App& app) {
  auto* command = app.add_subcommand("merge", "combine the outputs of sweep shards");
  auto dirs = std::make_shared<std::vector<std::string>>();
  auto out = std::make_shared<std::string>();
  auto allow_incomplete = std::make_shared<bool>(false);
  auto overwrite = std::make_shared<bool>(false);
  command->add_option("shards", *dirs, "shard output folders")->required();
  command->add_option("--out", *out, "merged output folder")->required();
  command->add_flag("--allow-incomplete", *allow_incomplete,
                    "merge shards that do not hold every run of the sweep (sweep.json then says "
                    "status \"incomplete\" and counts the missing runs)");
  command->add_flag("--overwrite", *overwrite,
                    "replace an --out that holds another experiment's sweep, a shard, or files "
                    "that are no sweep (as `radlab run --overwrite`)");
  command->callback([dirs, out, allow_incomplete, overwrite]() {
    MergeOptions options;
    options.command = "radlab merge";
    for (const std::string& dir : *dirs) options.command += " " + dir;
    options.command += " --out " + *out;
    if (*allow_incomplete) options.command += " --allow-incomplete";
    if (*overwrite) options.command += " --overwrite";
    options.allow_incomplete = *allow_incomplete;
    options.overwrite = *overwrite;
    const size_t runs = merge_shards(*dirs, *out, options);
    // An --allow-incomplete merge that lacks runs gets no page (radlab report refuses it too).
    if (incomplete_sweep_reason(*out).empty()) write_report_page(*out);
    std::printf("merged %zu runs from %zu shards into %s\n", runs, dirs->size(), out->c_str());
  });
}

}  // namespace radlab::cli
