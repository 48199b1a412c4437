// A scene, its mesh and a System for the matrix-free (Monte Carlo) solvers' tests: their rows are
// never read, so the form-factor method behind the System is there only because a System needs
// one (the tests check that no row is read).
#pragma once

#include <memory>
#include <string>

#include "formfactor/methods/exact.h"
#include "formfactor/methods/raycast.h"
#include "scene/builtin/builtin_scenes.h"
#include "scene/validate.h"
#include "solvers/system.h"
#include "tests/solver_support.h"

namespace radlab::testing {

struct MatrixFree {
  Scene scene;
  Mesh mesh;
  std::unique_ptr<RaycastFormFactors> method;
  std::unique_ptr<System> system;
};

inline std::unique_ptr<MatrixFree> matrix_free(const std::string& spec, int subdiv) {
  auto s = std::make_unique<MatrixFree>();
  s->scene = make_builtin_scene(spec);
  validate_scene(s->scene);
  s->mesh = build_mesh(s->scene, {subdiv, 0.0});
  s->method = std::make_unique<RaycastFormFactors>(s->scene, s->mesh, RaycastOptions{});
  s->system = std::make_unique<System>(s->scene, s->mesh, *s->method);
  return s;
}

// The Cornell box (`--subdiv 1`: 20 elements, RGB, two occluding blocks, an open front) with the
// `exact` form factors (clipped visibility, tolerance 1e-8 per pair) and their certified reference:
// the exact-F system the Monte Carlo solvers' expectations are of.
inline std::unique_ptr<Setup> exact_cornell() {
  return setup_scene_with(make_builtin_scene("cornell"), 1, Precision::kDouble, false,
                          [](const Scene& scene, const Mesh& mesh) {
                            ExactOptions options;
                            options.visibility_clip = true;
                            options.tolerance = 1e-8;
                            return std::make_unique<ExactFormFactors>(scene, mesh, options);
                          });
}

}  // namespace radlab::testing
