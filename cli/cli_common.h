// Options shared by the subcommands that take a scene (--subdiv, --element-size, --ff, ...), and
// the glue from parsed options to a ProblemSpec.
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "experiments/problem/problem.h"

namespace radlab::cli {

struct SceneOptions {
  std::string scene;
  int subdiv = 1;
  double element_size = 0.0;
  std::string patches = "elements";  // --patches: two levels (solvers/two_level/patches.h)
  double patch_size = 0.0;           // --patch-size, with --patches size
  std::string patch_rows = "auto";   // --patch-rows: centre | mean (solvers/two_level/patch_rows.h)
  bool keep_overlaps = false;        // --keep-overlaps: coincident polygons as they are (overlap.h)
};

struct FormFactorOptions {
  std::string method = kDefaultFormFactorMethod;
  std::vector<std::string> set;
  std::string precision = "float";
  std::string mode = "cached";
};

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

ProblemSpec make_spec(const SceneOptions& scene, const FormFactorOptions& ff);

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
