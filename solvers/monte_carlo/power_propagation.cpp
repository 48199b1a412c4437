// Monte Carlo power propagation (power_propagation.h).
#include "solvers/monte_carlo/power_propagation.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <limits>

namespace radlab::monte_carlo {

namespace {

// Rays per block: the stream fills one block's numbers, TBB traces them, the deposits are summed
// in order. 16384 rays keep the buffers at ~0.7 MB whatever the step's ray count.
constexpr uint64_t kBlockRays = 16384;

}  // namespace

PowerPropagation::PowerPropagation(const Mesh& mesh, const Radiosity& reflectance)
    : mesh_(mesh), reflectance_(reflectance), embree_(std::make_unique<EmbreeScene>(mesh)) {
  Vec3 low(std::numeric_limits<double>::max()), high(-std::numeric_limits<double>::max());
  for (const Vec3& v : mesh.vertices) {
    low = glm::min(low, v);
    high = glm::max(high, v);
  }
  // Rays start on the element's plane: t_near skips the rounding of Embree's float hit test
  // there (as the raycast form factors do), a millionth of the scene's size.
  t_near_ = mesh.vertices.empty() ? 0.0 : 1e-6 * glm::length(high - low);
}

uint32_t PowerPropagation::trace(size_t source, const double* u) const {
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

uint64_t PowerPropagation::propagate(const Radiosity& x, uint64_t rays, UniformStream& stream,
                                     uint64_t* block, Radiosity& y) const {
  const size_t n = mesh_.size();
  const int channels = x.channels();
  y = Radiosity(channels, n);
  // The discrete distribution over sources: cumulative |P_i| summed over channels.
  std::vector<double> cumulative(n);
  double total = 0.0;
  for (size_t i = 0; i < n; ++i) {
    double w = 0.0;
    for (int c = 0; c < channels; ++c) w += std::abs(x.at(c, i));
    total += w * mesh_.area[i];
    cumulative[i] = total;
  }
  if (!(total > 0.0) || rays == 0) return 0;
  // Per ray and channel: P_ic / (N p_i) = A_i x_ic * total / (N A_i w_i) = x_ic total / (N w_i).
  const double per_ray = total / double(rays);

  std::vector<double> u;
  std::vector<uint32_t> source, hit;
  for (uint64_t first = 0; first < rays; first += kBlockRays) {
    const size_t count = size_t(std::min(kBlockRays, rays - first));
    u.resize(count * kDimensions);
    source.resize(count);
    hit.resize(count);
    stream.fill((*block)++, u);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, count, 256), [&](const auto& range) {
      for (size_t r = range.begin(); r != range.end(); ++r) {
        const double* ur = &u[r * kDimensions];
        // The first element whose cumulative weight exceeds u0 * total: elements with no power
        // have empty intervals and are never chosen.
        const double target = ur[0] * total;
        size_t i = size_t(std::upper_bound(cumulative.begin(), cumulative.end(), target) -
                          cumulative.begin());
        i = std::min(i, n - 1);
        while (i > 0 && cumulative[i] == cumulative[i - 1]) --i;  // rounding at the very top
        source[r] = uint32_t(i);
        hit[r] = trace(i, ur);
      }
    });
    for (size_t r = 0; r < count; ++r) {
      if (hit[r] == kMiss) continue;
      const size_t i = source[r], j = hit[r];
      double w = 0.0;
      for (int c = 0; c < channels; ++c) w += std::abs(x.at(c, i));
      const double scale = per_ray / (w * mesh_.area[j]);
      for (int c = 0; c < channels; ++c) y.at(c, j) += reflectance_.at(c, j) * x.at(c, i) * scale;
    }
  }
  return rays;
}

uint64_t PowerPropagation::landing_fraction(uint64_t rays_per_element, UniformStream& stream,
                                            uint64_t* block, std::vector<double>& out) const {
  const size_t n = mesh_.size();
  out.assign(n, 0.0);
  std::vector<double> u(rays_per_element * kDimensions);
  std::vector<uint8_t> landed(rays_per_element);
  for (size_t i = 0; i < n; ++i) {
    stream.fill((*block)++, u);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, rays_per_element, 256), [&](const auto& range) {
      for (size_t r = range.begin(); r != range.end(); ++r)
        landed[r] = trace(i, &u[r * kDimensions]) != kMiss ? 1 : 0;
    });
    size_t count = 0;
    for (uint8_t l : landed) count += l;
    out[i] = double(count) / double(rays_per_element);
  }
  return rays_per_element * n;
}

}  // namespace radlab::monte_carlo
