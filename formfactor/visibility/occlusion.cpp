#include "formfactor/visibility/occlusion.h"

#include <bit>
#include <cstdint>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <limits>
#include <unordered_map>

#include "scene/geometry.h"

namespace radlab {
namespace {

// A unit normal's exact bits, as a hash key: polygons on parallel planes (an architectural scene
// has a handful of directions for hundreds of thousands of polygons) share one scan.
struct NormalKey {
  uint64_t x, y, z;
  bool operator==(const NormalKey&) const = default;
};
struct NormalKeyHash {
  size_t operator()(const NormalKey& k) const {
    return size_t(k.x * 0x9E3779B97F4A7C15ULL ^ (k.y + 0x632BE59BD9B4E019ULL) * 31 ^ k.z);
  }
};

}  // namespace

bool is_convex_enclosure(const Scene& scene, double tolerance) {
  Vec3 lo(1e300), hi(-1e300);
  for (const Polygon& p : scene.polygons)
    for (const Vec3& v : p.vertices) {
      lo = glm::min(lo, v);
      hi = glm::max(hi, v);
    }
  const double eps = tolerance * glm::length(hi - lo);
  // Every vertex v must satisfy n.v >= n.origin - eps for every polygon (n, origin). The least n.v
  // over all vertices depends on n alone, so it is found by one scan per distinct normal and
  // compared with each polygon's own threshold: O(vertices x directions + polygons), where
  // testing every vertex against every plane was O(vertices x polygons) for a convex scene (and
  // for every polygon before the first that fails), e.g. 576 ground-floor patches each scanning
  // the whole of builtin:floors:k=108's 800k vertices. A scan stops at the first vertex behind its
  // polygon's plane, as before; only a completed scan (the exact minimum) is remembered.
  std::unordered_map<NormalKey, double, NormalKeyHash> least;
  for (const Polygon& plane : scene.polygons) {
    const Vec3 n = geometry::unit_normal(plane.vertices);
    const double threshold = glm::dot(plane.vertices[0], n) - eps;
    const NormalKey key{std::bit_cast<uint64_t>(n.x), std::bit_cast<uint64_t>(n.y),
                        std::bit_cast<uint64_t>(n.z)};
    if (const auto it = least.find(key); it != least.end()) {
      if (it->second < threshold) return false;
      continue;
    }
    double minimum = std::numeric_limits<double>::infinity();
    for (const Polygon& other : scene.polygons)
      for (const Vec3& v : other.vertices) {
        const double d = glm::dot(v, n);
        if (d < threshold) return false;
        minimum = std::min(minimum, d);
      }
    least.emplace(key, minimum);
  }
  return true;
}

}  // namespace radlab
