// Options shared by the subcommands that take a scene (--subdiv, --element-size, --ff, ...), and
// the glue from parsed options to a ProblemSpec.
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "experiments/problem/problem.h"
#include "experiments/problem/problem_options.h"

namespace radlab::cli {

void add_scene_options(CLI::App& command, SceneOptions& options);
// --subdiv and --element-size alone (add_scene_options adds them too), range-checked on the
// text before narrowing.
void add_mesh_options(CLI::App& command, SceneOptions& options);
void add_form_factor_options(CLI::App& command, FormFactorOptions& options, bool with_mode);

// --threads N, a global option (every subcommand): the most threads radlab's parallel parts
// (matrix build, on-the-fly rows, the reference's LU and GMRES) may use; 0 or absent = every core.
// Checked on the text: N must be a whole number in [0, 4096].
void add_threads_option(CLI::App& app, int& threads);
// Sets the limit for the rest of the process (a tbb::global_control kept until exit); 0 keeps
// TBB's default (every core the process may run on).
void apply_threads(int threads);

// Creates the parent folder of `path` if it has one.
void ensure_parent_folder(const std::string& path);

// The subcommands; each registers itself on `app` and runs from its callback.
void add_scenes_command(CLI::App& app);
void add_solvers_command(CLI::App& app);
void add_formfactors_command(CLI::App& app);
void add_reference_command(CLI::App& app);
void add_solve_command(CLI::App& app, int argc, char** argv);
void add_run_command(CLI::App& app, int argc, char** argv);
void add_merge_command(CLI::App& app);
void add_prepare_command(CLI::App& app);
void add_report_command(CLI::App& app);

}  // namespace radlab::cli
