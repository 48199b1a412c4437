#include "scene/scene.h"

namespace radlab {

int Scene::emitter_count() const {
  int count = 0;
  for (const Polygon& p : polygons)
    if (materials[size_t(p.material)].emits()) ++count;
  return count;
}

bool Scene::is_grey() const {
  for (const Material& m : materials) {
    if (m.reflectance.x != m.reflectance.y || m.reflectance.x != m.reflectance.z) return false;
    if (m.emission.x != m.emission.y || m.emission.x != m.emission.z) return false;
  }
  return true;
}

}  // namespace radlab
