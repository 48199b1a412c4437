#include "cli/cli_common.h"

#include <tbb/global_control.h>
#include <tbb/info.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>

#include "core/error.h"
#include "core/text.h"

namespace radlab::cli {

void add_scene_options(CLI::App& command, SceneOptions& o) {
  command
      .add_option("scene", o.scene,
                  "builtin:NAME[:key=value,...] (see `radlab scenes`), or an .obj or .mgf file")
      ->required();
  add_mesh_options(command, o);
}

void add_mesh_options(CLI::App& command, SceneOptions& o) {
  // Checked on the text, in 64 bits / double, before CLI11 narrows it: 0, NaN, infinities and
  // values that do not fit an int are refused, not turned into a default or wrapped.
  auto* subdiv =
      command
          .add_option("--subdiv", o.subdiv,
                      "split each quad K x K, each triangle into K^2 (default 1; the "
                      "element count is estimated first, see --limits)")
          ->check(CLI::Validator(
              [](std::string& value) -> std::string {
                auto k = text::parse_int(value);
                if (!k || *k < 1 || *k > std::numeric_limits<int>::max())
                  return "--subdiv must be a whole number in [1, 2147483647], got '" + value + "'";
                return {};
              },
              "K >= 1", "subdivision"));
  command
      .add_option("--element-size", o.element_size,
                  "split polygons so element edges are at most H metres (H > 0)")
      ->check(CLI::Validator(
          [](std::string& value) -> std::string {
            auto h = text::parse_double(value);
            if (!h || !std::isfinite(*h) || !(*h > 0))
              return "--element-size must be a finite number > 0, got '" + value + "'";
            return {};
          },
          "H > 0", "element size"))
      ->excludes(subdiv);
  command.add_option("--patches", o.patches,
                     "two levels (Cohen 1988 §3.4): elements (default, one level), polygons (a "
                     "patch per input polygon) or size (patches of edge --patch-size)");
  command.add_option("--patch-size", o.patch_size,
                     "patch edge length in metres, with --patches size");
  command.add_option("--patch-rows", o.patch_rows,
                     "two levels: centre (one hemicube at each patch's centre, as the paper; "
                     "hemicube only), mean (area-weighted mean of the element rows) or auto "
                     "(default: centre with --ff hemicube, else mean)");
  command.add_flag("--keep-overlaps", o.keep_overlaps,
                   "keep coincident polygons as they are (default: of two same-facing ones the "
                   "later loses the overlap, of two face to face (a contact) both do, with a "
                   "warning)");
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

void add_threads_option(CLI::App& app, int& threads) {
  app.add_option("--threads", threads,
                 "the most threads radlab uses (matrix build, on-the-fly rows, the reference's "
                 "LU and GMRES); default 0 = every core (" +
                     std::to_string(tbb::info::default_concurrency()) +
                     " here). Results are the same bits whatever N (docs/performance.md)")
      ->check(CLI::Validator(
          [](std::string& value) -> std::string {
            auto k = text::parse_int(value);
            if (!k || *k < 0 || *k > 4096)
              return "--threads must be a whole number in [0, 4096], got '" + value + "'";
            return {};
          },
          "N >= 0", "threads"));
}

void apply_threads(int threads) {
  // Kept for the life of the process: TBB honours the strictest live global_control.
  static std::unique_ptr<tbb::global_control> control;
  control.reset();
  if (threads > 0)
    control = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                    size_t(threads));
}

void ensure_parent_folder(const std::string& path) {
  const auto parent = std::filesystem::path(path).parent_path();
  if (parent.empty()) return;
  std::error_code ec;
  std::filesystem::create_directories(parent, ec);
  if (ec) throw InputError(parent.string() + ": cannot create folder (" + ec.message() + ")");
}

}  // namespace radlab::cli
