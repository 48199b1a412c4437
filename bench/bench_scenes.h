// The meshes the benchmarks share, built once per process: the Cornell box at --subdiv 16 (5,120
// elements) with its Embree scene, and builtin:office at --subdiv 4 (7,008 elements, Cohen et
// al. 1988's ~7,000), without and with its Embree scene.
#pragma once

#include <memory>

#include "formfactor/visibility/embree_scene.h"
#include "scene/builtin/builtin_scenes.h"
#include "scene/mesh.h"
#include "scene/validate.h"

namespace radlab::bench {

struct SceneMesh {
  Scene scene;
  Mesh mesh;
  std::unique_ptr<EmbreeScene> embree;  // when made with_embree
};

inline SceneMesh* make_scene_mesh(const char* name, int subdivisions, bool with_embree) {
  auto* result = new SceneMesh;
  result->scene = make_builtin_scene(name);
  validate_scene(result->scene);
  result->mesh = build_mesh(result->scene, {subdivisions, 0.0});
  if (with_embree) result->embree = std::make_unique<EmbreeScene>(result->mesh);
  return result;
}

inline const SceneMesh& cornell() {
  static const SceneMesh* c = make_scene_mesh("cornell", 16, true);
  return *c;
}

inline const SceneMesh& office() {
  static const SceneMesh* o = make_scene_mesh("office", 4, false);
  return *o;
}

// The office again with its Embree scene: a second, occluded scene for the ray benchmarks, so a
// ratio tuned on the Cornell box is also measured where it was not tuned.
inline const SceneMesh& office_traced() {
  static const SceneMesh* o = make_scene_mesh("office", 4, true);
  return *o;
}

}  // namespace radlab::bench
