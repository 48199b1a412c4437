// The radlab command line. Exit codes (DESIGN §7): 0 ok, 2 usage, 3 invalid input,
// 4 numerical failure, 5 tolerance not reached (`radlab solve --tol`, outputs written); errors are
// printed to stderr and name what is at fault.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>
#include <filesystem>

#include "cli/cli_common.h"
#include "core/error.h"
#include "core/limits.h"
#include "core/log.h"
#include "experiments/run/version_info.h"
#include "scene/scene_loader.h"
#include "solvers/kernels/kernels.h"
#include "solvers/plugin_loader.h"

namespace {

// The options every subcommand takes (they may also follow the subcommand).
struct GlobalOptions {
  bool quiet = false;
  std::string limits;
  std::string include_root;
  std::vector<std::string> plugins;
  bool scalar_kernels = false;
  int threads = 0;
};

void add_global_options(CLI::App& app, GlobalOptions& o) {
  app.add_flag("-q,--quiet", o.quiet, "no progress or information on stderr (errors still print)");
  app.add_option("--limits", o.limits,
                 "raise or lower the work radlab accepts before refusing it (estimated before "
                 "allocating), key=value,...: " +
                     radlab::limits_help());
  app.add_option("--mgf-include-root", o.include_root,
                 "let MGF scenes include files anywhere inside this folder (default: only inside "
                 "the scene file's own folder)");
  app.add_option("--plugin", o.plugins,
                 "load solvers from a plugin (a shared library, see docs/library.md); "
                 "repeatable; RADLAB_PLUGIN_PATH lists more (files or folders, ':'-separated)");
  app.add_flag_callback(
      "--version",
      [] {
        std::printf("%sCLI11: %s\n", radlab::version_text().c_str(), CLI11_VERSION);
        throw CLI::Success();
      },
      "print radlab's version, git revision and dependency versions, and exit");
  app.add_flag("--scalar-kernels", o.scalar_kernels,
               "run the solvers' portable scalar kernels instead of the AVX2 ones the CPU offers "
               "(the same results bit for bit, slower; also RADLAB_KERNELS=scalar; "
               "RADLAB_KERNELS=avx512 runs the AVX-512 ones where the CPU has them)");
  radlab::cli::add_threads_option(app, o.threads);
  app.fallthrough();
}

// Before any subcommand runs: its callback reads the solver table, the limits, the threads.
void apply_global_options(const GlobalOptions& o) {
  radlab::log::set_quiet(o.quiet);
  if (!o.limits.empty()) radlab::set_limits(o.limits);
  radlab::set_mgf_include_root(o.include_root);
  // Loaded on the first use of the solver or method table, so a command that uses neither
  // (`radlab scenes`) cannot be broken by a bad plugin (solvers/plugin_loader.h).
  radlab::request_plugins(o.plugins);
  radlab::cli::apply_threads(o.threads);
  radlab::kernels::check_kernel_environment();
  if (o.scalar_kernels) radlab::kernels::use_vector_kernels(false);
}

void add_commands(CLI::App& app, int argc, char** argv) {
  radlab::cli::add_scenes_command(app);
  radlab::cli::add_solvers_command(app);
  radlab::cli::add_formfactors_command(app);
  radlab::cli::add_reference_command(app);
  radlab::cli::add_solve_command(app, argc, argv);
  radlab::cli::add_run_command(app, argc, argv);
  radlab::cli::add_merge_command(app);
  radlab::cli::add_prepare_command(app);
  radlab::cli::add_report_command(app);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "radlab: a research harness for comparing radiosity solvers against a certified reference"};
  app.require_subcommand(1);
  GlobalOptions options;
  add_global_options(app, options);
  add_commands(app, argc, argv);
  app.parse_complete_callback([&options]() { apply_global_options(options); });
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : int(radlab::ExitCode::kUsage);
  } catch (const radlab::Error& e) {
    std::fprintf(stderr, "radlab: error: %s\n", e.what());
    return int(e.code());
  } catch (const std::filesystem::filesystem_error& e) {
    // A file or folder that cannot be created, read or renamed: the input (a path) is at fault.
    std::fprintf(stderr, "radlab: error: %s\n", e.what());
    return int(radlab::ExitCode::kInvalidInput);
  } catch (const std::bad_alloc&) {
    // radlab estimates the large allocations (mesh, dense matrix, runs, images) and refuses
    // them above --limits first, so this is an allocation it did not foresee: no advice that
    // could be wrong for the cause.
    std::fprintf(stderr,
                 "radlab: error: out of memory: an allocation failed that the limits "
                 "(--limits, see --help) did not foresee; lower the limits or the input's size\n");
    return int(radlab::ExitCode::kNumerical);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "radlab: internal error: %s\n", e.what());
    return 1;
  }
  return 0;
}
