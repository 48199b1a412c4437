#include "formfactor/visibility.h"

#include <algorithm>
#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include "core/random.h"
#include "formfactor/occlusion.h"
#include "formfactor/polygon_integral.h"
#include "formfactor/sampling.h"

namespace radlab {

double plane_epsilon(const Mesh& mesh) {
  Vec3 lo(1e300), hi(-1e300);
  for (const Vec3& v : mesh.vertices) {
    lo = glm::min(lo, v);
    hi = glm::max(hi, v);
  }
  return mesh.vertices.empty() ? 0.0 : 1e-9 * glm::length(hi - lo);
}

Visibility::Visibility(const Scene& scene, const Mesh& mesh, int rays, uint64_t seed,
                       bool shaft_culling)
    : mesh_(mesh), rays_(rays), seed_(seed), plane_epsilon_(plane_epsilon(mesh)) {
  convex_enclosure_ = is_convex_enclosure(scene);
  if (convex_enclosure_) return;
  if (shaft_culling) shafts_ = std::make_unique<ShaftCuller>(scene, mesh, plane_epsilon_);
  embree_ = std::make_unique<EmbreeScene>(mesh);
}

Visibility::~Visibility() = default;

std::vector<std::string> Visibility::left_out() const {
  if (convex_enclosure_)
    return {"visibility rays: none (the scene is a convex enclosure, nothing can occlude)"};
  if (shafts_)
    return {
        "visibility rays for pairs whose shaft holds no possible occluder (counted in "
        "pairs_unoccluded)"};
  return {};
}

bool Visibility::needs_rays(size_t i, size_t j) const {
  if (convex_enclosure_) return false;
  return !shafts_ || !shafts_->unoccluded(i, j);
}

int64_t Visibility::possible_blocker(size_t i, size_t j) const {
  if (convex_enclosure_) return -1;
  return shafts_ ? shafts_->first_blocker(i, j) : 0;
}

double Visibility::fraction(size_t i, size_t j, RowCost& cost) const {
  if (!needs_rays(i, j)) {
    ++cost.pairs_unoccluded;
    return 1.0;
  }
  ++cost.pairs_traced;
  return trace(i, j, cost);
}

double Visibility::trace(size_t i, size_t j, RowCost& cost) const {
  // Symmetric in i and j: the same points, the same rays, whichever row asks.
  const size_t lo = std::min(i, j), hi = std::max(i, j);
  Pcg32 rng(hash_combine(hash_combine(seed_, lo), hi));
  // Sample the region the unoccluded integral covers: the part of each element in front of the
  // other's plane (raycast.cpp and exact.cpp clip i to j's front, and the point-to-polygon formula
  // clips j to i's). Rays from a part clipped away would be blocked by the very polygon that
  // crosses the element and penalise the pair twice.
  thread_local std::vector<Vec3> corners_lo, corners_hi, p, q;
  mesh_.corners(lo, corners_lo);
  mesh_.corners(hi, corners_hi);
  const bool lo_kept =
      clip_to_front(corners_lo, mesh_.centroid[hi], mesh_.normal[hi], plane_epsilon_) > 0.0;
  const bool hi_kept =
      clip_to_front(corners_hi, mesh_.centroid[lo], mesh_.normal[lo], plane_epsilon_) > 0.0;
  if (!lo_kept || !hi_kept) return 1.0;  // no unoccluded exchange to scale (F^u = 0)
  stratified_points(corners_lo, rays_, rng, p);
  stratified_points(corners_hi, rays_, rng, q);
  // Pair the strata of one element with a random permutation of the other's: an affine map
  // k -> (a k + b) mod R with odd a when R is a power of two (cheap), Fisher–Yates otherwise.
  const int R = rays_;
  if ((R & (R - 1)) == 0) {
    const uint32_t a = rng.next_u32() | 1u, b = rng.next_u32();
    thread_local std::vector<Vec3> shuffled;
    shuffled.resize(size_t(R));
    for (int k = 0; k < R; ++k) shuffled[(a * uint32_t(k) + b) & uint32_t(R - 1)] = q[size_t(k)];
    q.swap(shuffled);
  } else {
    for (int k = R - 1; k > 0; --k) std::swap(q[size_t(k)], q[rng.next_below(uint32_t(k + 1))]);
  }

  int visible = 0;
  alignas(64) float ox[16], oy[16], oz[16], dx[16], dy[16], dz[16], tn[16], tf[16];
  bool blocked[16];
  for (int start = 0; start < R; start += 16) {
    const int count = std::min(16, R - start);
    for (int k = 0; k < count; ++k) {
      const Vec3& from = p[size_t(start + k)];
      const Vec3 d = q[size_t(start + k)] - from;
      ox[k] = float(from.x), oy[k] = float(from.y), oz[k] = float(from.z);
      dx[k] = float(d.x), dy[k] = float(d.y), dz[k] = float(d.z);
      // Parameters along the segment: skip its two ends, where it touches i and j.
      const double eps = std::max(1e-4, 1e-6 / std::max(glm::length(d), 1e-12));
      tn[k] = float(eps);
      tf[k] = float(1.0 - eps);
    }
    embree_->occluded16(ox, oy, oz, dx, dy, dz, tn, tf, count, blocked, mesh_.polygon[lo],
                        mesh_.polygon[hi]);
    for (int k = 0; k < count; ++k) visible += blocked[k] ? 0 : 1;
  }
  cost.rays += uint64_t(R);
  return double(visible) / R;
}

}  // namespace radlab
