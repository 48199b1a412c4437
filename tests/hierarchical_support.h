// The fixture the hierarchical tests share (tests/solvers/hierarchical/): a
// built-in scene, its mesh, the dense raycast matrix in double (symmetrised) and its certified
// reference, against which the hierarchical solution is measured.
#pragma once

#include <memory>
#include <string>

#include "formfactor/matrix/matrix.h"
#include "formfactor/methods/raycast.h"
#include "scene/builtin/builtin_scenes.h"
#include "scene/mesh.h"
#include "scene/validate.h"
#include "solvers/reference/reference.h"
#include "solvers/system.h"

namespace radlab::testing {

struct HierarchicalSetup {
  Scene scene;
  Mesh mesh;
  FormFactorMatrix matrix;
  std::unique_ptr<System> system;
  Reference reference;
};

inline std::unique_ptr<HierarchicalSetup> hierarchical_setup(const std::string& spec, int subdiv) {
  auto s = std::make_unique<HierarchicalSetup>();
  s->scene = make_builtin_scene(spec);
  validate_scene(s->scene);
  s->mesh = build_mesh(s->scene, {subdiv, 0.0});
  RaycastFormFactors ff(s->scene, s->mesh, RaycastOptions{});
  BuildReport report;
  s->matrix = build_matrix(ff, s->mesh.size(), Precision::kDouble, report);
  symmetrise(s->matrix, s->mesh.area);
  s->system = std::make_unique<System>(s->scene, s->mesh, s->matrix);
  s->reference = compute_reference(*s->system, s->matrix);
  return s;
}

}  // namespace radlab::testing
