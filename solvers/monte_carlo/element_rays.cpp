// Cosine rays between elements, and the power distribution over elements (element_rays.h).
#include "solvers/monte_carlo/element_rays.h"

#include <algorithm>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <limits>

#include "solvers/monte_carlo/ray_sampler.h"

namespace radlab::monte_carlo {

ElementRays::ElementRays(const Mesh& mesh)
    : mesh_(mesh), embree_(std::make_unique<EmbreeScene>(mesh)) {
  Vec3 low(std::numeric_limits<double>::max()), high(-std::numeric_limits<double>::max());
  for (const Vec3& v : mesh.vertices) {
    low = glm::min(low, v);
    high = glm::max(high, v);
  }
  // Rays start on the element's plane: t_near skips the rounding of Embree's float hit test
  // there (as the raycast form factors do), a millionth of the scene's size.
  t_near_ = mesh.vertices.empty() ? 0.0 : 1e-6 * glm::length(high - low);
}

uint32_t ElementRays::trace(size_t source, const double* u) const {
  const Vec3 origin = point_on_element(mesh_, source, u[1], u[2]);
  const Vec3 direction = cosine_direction(mesh_.normal[source], u[3], u[4]);
  const uint32_t own_polygon = mesh_.polygon[source];
  double t_near = t_near_;
  // A planar polygon cannot be met again by a ray leaving its front: a hit on the source's own
  // polygon is rounding (a ray grazing it near an edge), so the ray goes on past it (a few
  // times at most).
  for (int attempt = 0; attempt < 4; ++attempt) {
    const RayHit hit = embree_->intersect(origin, direction, t_near, 1e30);
    if (!hit.hit) return kMiss;
    if (mesh_.polygon[hit.element] == own_polygon) {
      t_near = hit.distance + t_near_;
      continue;
    }
    // Only a front face receives (F_ij is zero when j faces away from i): a back face absorbs.
    return glm::dot(direction, mesh_.normal[hit.element]) < 0.0 ? hit.element : kMiss;
  }
  return kMiss;
}

ElementDistribution::ElementDistribution(std::span<const double> weights)
    : cumulative_(weights.size()) {
  double total = 0.0;
  for (size_t i = 0; i < weights.size(); ++i) {
    total += weights[i];
    cumulative_[i] = total;
  }
}

size_t ElementDistribution::pick(double u) const {
  const double target = u * total();
  // The first element whose cumulative weight exceeds u * total.
  size_t i = size_t(std::upper_bound(cumulative_.begin(), cumulative_.end(), target) -
                    cumulative_.begin());
  i = std::min(i, cumulative_.size() - 1);
  while (i > 0 && cumulative_[i] == cumulative_[i - 1]) --i;  // rounding at the very top
  return i;
}

}  // namespace radlab::monte_carlo
