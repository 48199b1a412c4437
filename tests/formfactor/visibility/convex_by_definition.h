// The definition of a convex enclosure, tested pair by pair: every vertex on or in front of every
// polygon's plane (within `tolerance` of the scene's diagonal). Quadratic in the polygons: the
// oracle of is_convex_enclosure's test (convex_enclosure_test.cpp) and what its benchmark
// (bench/bench_convex_enclosure.cpp) times the one-scan-per-normal version against.
#pragma once

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include "scene/geometry.h"
#include "scene/scene.h"

namespace radlab {

inline bool convex_by_definition(const Scene& scene, double tolerance = 1e-9) {
  Vec3 lo(1e300), hi(-1e300);
  for (const Polygon& p : scene.polygons)
    for (const Vec3& v : p.vertices) lo = glm::min(lo, v), hi = glm::max(hi, v);
  const double eps = tolerance * glm::length(hi - lo);
  for (const Polygon& plane : scene.polygons) {
    const Vec3 n = geometry::unit_normal(plane.vertices);
    for (const Polygon& other : scene.polygons)
      for (const Vec3& v : other.vertices)
        if (glm::dot(v - plane.vertices[0], n) < -eps) return false;
  }
  return true;
}

}  // namespace radlab
