#include "experiments/problem/problem_options.h"

#include <cmath>

#include "core/error.h"
#include "core/text.h"

namespace radlab {

ProblemSpec make_problem_spec(const SceneOptions& scene, const FormFactorOptions& ff) {
  ProblemSpec spec;
  spec.scene = scene.scene;
  spec.mesh.subdivisions = scene.subdiv;
  spec.mesh.element_size = scene.element_size;
  spec.keep_overlaps = scene.keep_overlaps;
  if (scene.subdiv < 1)
    throw UsageError("--subdiv must be >= 1, got " + std::to_string(scene.subdiv));
  if (!(scene.element_size >= 0) || !std::isfinite(scene.element_size))
    throw UsageError("--element-size must be a finite number > 0, got " +
                     text::format_double(scene.element_size));
  spec.patches.from = scene.patches;
  spec.patches.size = scene.patch_size;
  spec.patches.rows = scene.patch_rows;
  spec.patches.validate();
  spec.ff_method = ff.method;
  spec.ff_set = ff.set;
  spec.precision = ff.precision == "double" ? Precision::kDouble : Precision::kFloat;
  spec.row_mode = ff.mode == "on-the-fly" ? RowMode::kOnTheFly : RowMode::kCached;
  return spec;
}

}  // namespace radlab
