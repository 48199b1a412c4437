#include "formfactor/integrate/point_polygon.h"

#include <cmath>
#include <glm/geometric.hpp>
#include <numbers>

#include "formfactor/integrate/fast_atan.h"
#include "scene/geometry.h"

namespace radlab {

double point_to_polygon_form_factor(const Vec3& x, const Vec3& n, std::span<const Vec3> polygon,
                                    const Vec3& polygon_normal, std::vector<Vec3>& scratch) {
  // x must be in front of the polygon (one-sided emitters and receivers).
  if (glm::dot(x - polygon[0], polygon_normal) <= 0.0) return 0.0;
  bool all_above = true;
  for (const Vec3& v : polygon)
    if (below_tangent_plane(v - x, n)) {
      all_above = false;
      break;
    }
  std::span<const Vec3> p = polygon;
  if (!all_above) {
    geometry::clip_to_halfspace(polygon, x, n, scratch);
    if (scratch.size() < 3) return 0.0;
    p = scratch;
  }
  // The angles by the inline atan2 (fast_atan.h, within ~2.5 ulp of libm's, which was an opaque
  // call and ~15% of a raycast build on hospital.mgf).
  double sum = 0.0;
  const size_t count = p.size();
  for (size_t k = 0; k < count; ++k) {
    const Vec3 a = p[k] - x;
    const Vec3 b = p[(k + 1) % count] - x;
    const Vec3 c = glm::cross(a, b);
    const double len = glm::length(c);
    if (len <= 0.0) continue;  // x on the edge's line: the edge subtends no solid angle
    sum += atan2_upper(len, glm::dot(a, b)) * glm::dot(n, c) / len;
  }
  // The sign depends on the winding as seen from x; the magnitude is the form factor.
  return std::abs(sum) / (2.0 * std::numbers::pi);
}

}  // namespace radlab
