// The radlab command line. Exit codes (DESIGN §7): 0 ok, 2 usage, 3 invalid input,
// 4 numerical failure, 5 tolerance not reached (`radlab solve --tol`, outputs written); errors are
// printed to stderr and name what is at fault.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>
#include <filesystem>

#include "core/error.h"
#include "core/log.h"
#include "experiments/cli_common.h"

int main(int argc, char** argv) {
  CLI::App app{
      "radlab: a research harness for comparing radiosity solvers against a certified reference"};
  app.require_subcommand(1);
  bool quiet = false;
  app.add_flag("-q,--quiet", quiet, "no progress or information on stderr (errors still print)");
  radlab::cli::add_scenes_command(app);
  radlab::cli::add_solvers_command(app);
  radlab::cli::add_formfactors_command(app);
  radlab::cli::add_reference_command(app);
  radlab::cli::add_solve_command(app, argc, argv);
  radlab::cli::add_run_command(app, argc, argv);
  radlab::cli::add_merge_command(app);
  radlab::cli::add_prepare_command(app);
  app.parse_complete_callback([&]() { radlab::log::set_quiet(quiet); });
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
    std::fprintf(stderr,
                 "radlab: error: out of memory (try a coarser mesh or --ff-mode on-the-fly)\n");
    return int(radlab::ExitCode::kNumerical);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "radlab: internal error: %s\n", e.what());
    return 1;
  }
  return 0;
}
