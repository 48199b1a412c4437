#include "formfactor/visibility/occlusion.h"

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include "scene/geometry.h"

namespace radlab {

bool is_convex_enclosure(const Scene& scene, double tolerance) {
  Vec3 lo(1e300), hi(-1e300);
  for (const Polygon& p : scene.polygons)
    for (const Vec3& v : p.vertices) {
      lo = glm::min(lo, v);
      hi = glm::max(hi, v);
    }
  const double eps = tolerance * glm::length(hi - lo);
  for (const Polygon& plane : scene.polygons) {
    const Vec3 n = geometry::unit_normal(plane.vertices);
    const Vec3 origin = plane.vertices[0];
    for (const Polygon& other : scene.polygons)
      for (const Vec3& v : other.vertices)
        if (glm::dot(v - origin, n) < -eps) return false;
  }
  return true;
}

}  // namespace radlab
