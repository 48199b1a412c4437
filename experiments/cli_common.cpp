#include "experiments/cli_common.h"

#include <filesystem>

#include "core/error.h"

namespace radlab::cli {

void add_scene_options(CLI::App& command, SceneOptions& o) {
  command
      .add_option("scene", o.scene,
                  "builtin:NAME[:key=value,...] (see `radlab scenes`), or an .obj file")
      ->required();
  auto* subdiv = command.add_option("--subdiv", o.subdiv,
                                    "split each quad K x K, each triangle into K^2 (default 1)");
  command
      .add_option("--element-size", o.element_size,
                  "split polygons so element edges are at most H metres")
      ->excludes(subdiv);
  command.add_option("--patches", o.patches,
                     "two levels (Cohen 1988 §3.4): elements (default, one level), polygons (a "
                     "patch per input polygon) or size (patches of edge --patch-size)");
  command.add_option("--patch-size", o.patch_size,
                     "patch edge length in metres, with --patches size");
  command.add_flag("--keep-overlaps", o.keep_overlaps,
                   "keep coincident same-facing polygons as they are (default: the later one "
                   "loses the overlap, with a warning)");
}

void add_form_factor_options(CLI::App& command, FormFactorOptions& o, bool with_mode) {
  command.add_option("--ff", o.method, "form-factor method (default raycast)");
  command.add_option("--ff-set", o.set, "form-factor parameter key=value (repeatable)")
      ->allow_extra_args(false);
  command.add_option("--precision", o.precision, "stored precision of F: float or double")
      ->check(CLI::IsMember({"float", "double"}));
  if (with_mode)
    command
        .add_option("--ff-mode", o.mode,
                    "cached: rows from the dense matrix; on-the-fly: every row recomputed and its "
                    "time charged to the solver")
        ->check(CLI::IsMember({"cached", "on-the-fly"}));
}

ProblemSpec make_spec(const SceneOptions& scene, const FormFactorOptions& ff) {
  ProblemSpec spec;
  spec.scene = scene.scene;
  spec.mesh.subdivisions = scene.subdiv;
  spec.mesh.element_size = scene.element_size;
  spec.keep_overlaps = scene.keep_overlaps;
  if (scene.subdiv < 1)
    throw UsageError("--subdiv must be >= 1, got " + std::to_string(scene.subdiv));
  if (scene.element_size < 0)
    throw UsageError("--element-size must be > 0, got " + std::to_string(scene.element_size));
  spec.patches.from = scene.patches;
  spec.patches.size = scene.patch_size;
  spec.patches.validate();
  spec.ff_method = ff.method;
  spec.ff_set = ff.set;
  spec.precision = ff.precision == "double" ? Precision::kDouble : Precision::kFloat;
  spec.row_mode = ff.mode == "on-the-fly" ? RowMode::kOnTheFly : RowMode::kCached;
  return spec;
}

void ensure_parent_folder(const std::string& path) {
  const auto parent = std::filesystem::path(path).parent_path();
  if (parent.empty()) return;
  std::error_code ec;
  std::filesystem::create_directories(parent, ec);
  if (ec) throw InputError(parent.string() + ": cannot create folder (" + ec.message() + ")");
}

}  // namespace radlab::cli
