#include "formfactor/integrate/pair_geometry.h"

#include <algorithm>
#include <glm/geometric.hpp>

#include "scene/geometry.h"

namespace radlab {

std::vector<double> element_radii(const Mesh& mesh) {
  std::vector<double> radius(mesh.size());
  for (size_t e = 0; e < mesh.size(); ++e) {
    double r = 0.0;
    for (uint32_t v : mesh.element_vertices(e))
      r = std::max(r, glm::distance(mesh.vertices[v], mesh.centroid[e]));
    radius[e] = r;
  }
  return radius;
}

double grazing_scale(const Mesh& mesh, size_t i, size_t j, std::span<const Vec3> from, double kept,
                     double diameter) {
  double height_max = 0.0;
  for (const Vec3& v : from)
    height_max = std::max(height_max, glm::dot(v - mesh.centroid[j], mesh.normal[j]));
  const Vec3 centre = kept < 1.0 ? geometry::centroid(from) : mesh.centroid[i];
  const double height_mean = glm::dot(centre - mesh.centroid[j], mesh.normal[j]);
  const double slope = glm::length(glm::cross(mesh.normal[i], mesh.normal[j]));
  return height_mean / (height_max + slope * diameter);
}

namespace {

// Distance between the segments p0 p1 and q0 q1 (Ericson, Real-Time Collision Detection 5.1.9):
// the closest parameters of the two lines, clamped to the segments one after the other.
double segment_distance(const Vec3& p0, const Vec3& p1, const Vec3& q0, const Vec3& q1) {
  const Vec3 d1 = p1 - p0, d2 = q1 - q0, r = p0 - q0;
  const double a = glm::dot(d1, d1), e = glm::dot(d2, d2), f = glm::dot(d2, r);
  double s = 0.0, t = 0.0;
  if (a <= 0.0 && e <= 0.0) return glm::distance(p0, q0);
  if (a <= 0.0) {
    t = std::clamp(f / e, 0.0, 1.0);
  } else {
    const double c = glm::dot(d1, r);
    if (e <= 0.0) {
      s = std::clamp(-c / a, 0.0, 1.0);
    } else {
      const double b = glm::dot(d1, d2), denominator = a * e - b * b;
      s = denominator > 0.0 ? std::clamp((b * f - c * e) / denominator, 0.0, 1.0) : 0.0;
      t = (b * s + f) / e;
      if (t < 0.0) {
        t = 0.0;
        s = std::clamp(-c / a, 0.0, 1.0);
      } else if (t > 1.0) {
        t = 1.0;
        s = std::clamp((b - c) / a, 0.0, 1.0);
      }
    }
  }
  return glm::distance(p0 + s * d1, q0 + t * d2);
}

}  // namespace

double point_polygon_distance(const Vec3& x, std::span<const Vec3> p, const Vec3& n) {
  const double height = glm::dot(x - p[0], n);
  const Vec3 y = x - height * n;  // x projected onto the plane
  bool inside = true;
  double edge = 1e300;
  for (size_t k = 0; k < p.size(); ++k) {
    const Vec3& a = p[k];
    const Vec3& b = p[(k + 1) % p.size()];
    const Vec3 e = b - a;
    if (glm::dot(glm::cross(e, y - a), n) < 0.0) inside = false;
    const double len2 = glm::dot(e, e);
    const double t = len2 > 0.0 ? std::clamp(glm::dot(x - a, e) / len2, 0.0, 1.0) : 0.0;
    edge = std::min(edge, glm::distance(x, a + t * e));
  }
  return inside ? std::abs(height) : edge;
}

double polygon_distance(std::span<const Vec3> a, const Vec3& na, std::span<const Vec3> b,
                        const Vec3& nb) {
  double d = 1e300;
  for (const Vec3& v : a) d = std::min(d, point_polygon_distance(v, b, nb));
  for (const Vec3& v : b) d = std::min(d, point_polygon_distance(v, a, na));
  for (size_t k = 0; k < a.size(); ++k)
    for (size_t m = 0; m < b.size(); ++m)
      d = std::min(d, segment_distance(a[k], a[(k + 1) % a.size()], b[m], b[(m + 1) % b.size()]));
  return d;
}

}  // namespace radlab
