#include "formfactor/raycast.h"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>

#include "core/error.h"
#include "formfactor/occlusion.h"
#include "formfactor/polygon_integral.h"
#include "formfactor/sampling.h"

namespace radlab {

RaycastOptions RaycastOptions::from(ParamBag& bag) {
  RaycastOptions o;
  o.tolerance = bag.get_double("tolerance", o.tolerance);
  o.rays = int(bag.get_int("rays", o.rays));
  o.seed = uint64_t(bag.get_int("seed", 0));
  o.max_order = int(bag.get_int("max_order", o.max_order));
  o.validate();
  return o;
}

void RaycastOptions::validate() const {
  if (!(tolerance > 0.0 && tolerance < 1.0))
    throw UsageError("raycast: tolerance must lie in (0,1), got " + std::to_string(tolerance));
  if (rays < 1 || rays > 4096)
    throw UsageError("raycast: rays must lie in [1,4096], got " + std::to_string(rays));
  if (max_order < 1 || max_order > 32)
    throw UsageError("raycast: max_order must lie in [1,32], got " + std::to_string(max_order));
}

std::string RaycastOptions::canonical() const {
  char buffer[160];
  std::snprintf(buffer, sizeof buffer, "max_order=%d,rays=%d,seed=%llu,tolerance=%.6g", max_order,
                rays, static_cast<unsigned long long>(seed), tolerance);
  return buffer;
}

RaycastFormFactors::RaycastFormFactors(const Scene& scene, const Mesh& mesh,
                                       RaycastOptions options)
    : mesh_(mesh),
      options_((options.validate(), options)),
      order_rule_(options.tolerance, options.max_order) {
  convex_enclosure_ = is_convex_enclosure(scene);
  double extent = 0.0;
  radius_.resize(mesh.size());
  for (size_t e = 0; e < mesh.size(); ++e) {
    double r = 0.0;
    for (uint32_t v : mesh.element_vertices(e))
      r = std::max(r, glm::distance(mesh.vertices[v], mesh.centroid[e]));
    radius_[e] = r;
  }
  for (const Vec3& v : mesh.vertices) extent = std::max(extent, glm::length(v - mesh.vertices[0]));
  plane_epsilon_ = 1e-9 * extent;
  if (!convex_enclosure_) embree_ = std::make_unique<EmbreeScene>(mesh);
}

std::vector<std::string> RaycastFormFactors::left_out() const {
  std::vector<std::string> notes = {"pairs facing away or coplanar: no quadrature, no rays"};
  if (convex_enclosure_)
    notes.push_back("visibility rays: none (the scene is a convex enclosure, nothing can occlude)");
  return notes;
}

double RaycastFormFactors::unoccluded(size_t i, size_t j, RowCost& cost) const {
  thread_local std::vector<Vec3> from, to;
  mesh_.corners(i, from);
  mesh_.corners(j, to);
  const PolygonRef a{from, mesh_.normal[i]};
  const PolygonRef b{to, mesh_.normal[j]};
  const double gap =
      glm::distance(mesh_.centroid[i], mesh_.centroid[j]) - radius_[i] - radius_[j];
  const int order = order_rule_.order(gap, 2.0 * radius_[i]);
  if (order > 0) {
    cost.kernel_evaluations += uint64_t(order * order * (from.size() == 4 ? 1 : int(from.size()) - 2));
    return polygon_form_factor_fixed(a, b, order);
  }
  long long evaluations = 0;
  double f = polygon_form_factor_adaptive(a, b, options_.tolerance, 1e-14, 10, &evaluations);
  cost.kernel_evaluations += uint64_t(evaluations);
  return f;
}

double RaycastFormFactors::visibility(size_t i, size_t j, RowCost& cost) const {
  // Symmetric in i and j: the same points, the same rays, whichever row asks.
  const size_t lo = std::min(i, j), hi = std::max(i, j);
  Pcg32 rng(hash_combine(hash_combine(options_.seed, lo), hi));
  thread_local std::vector<Vec3> corners, p, q;
  mesh_.corners(lo, corners);
  stratified_points(corners, options_.rays, rng, p);
  mesh_.corners(hi, corners);
  stratified_points(corners, options_.rays, rng, q);
  // Pair the strata of one element with a random permutation of the other's: an affine map
  // k -> (a k + b) mod R with odd a when R is a power of two (cheap), Fisher–Yates otherwise.
  const int R = options_.rays;
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
  for (int start = 0; start < options_.rays; start += 16) {
    const int count = std::min(16, options_.rays - start);
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
    embree_->occluded16(ox, oy, oz, dx, dy, dz, tn, tf, count, blocked);
    for (int k = 0; k < count; ++k) visible += blocked[k] ? 0 : 1;
  }
  cost.rays += uint64_t(options_.rays);
  return double(visible) / options_.rays;
}

double RaycastFormFactors::pair(size_t i, size_t j, RowCost& cost) const {
  if (i == j) return 0.0;
  // Facing away or coplanar: j wholly behind (or in) i's plane, or i wholly behind j's.
  const Vec3& ni = mesh_.normal[i];
  const Vec3& nj = mesh_.normal[j];
  const Vec3& ci = mesh_.centroid[i];
  const Vec3& cj = mesh_.centroid[j];
  bool j_in_front = false, i_in_front = false;
  for (uint32_t v : mesh_.element_vertices(j))
    if (glm::dot(mesh_.vertices[v] - ci, ni) > plane_epsilon_) j_in_front = true;
  for (uint32_t v : mesh_.element_vertices(i))
    if (glm::dot(mesh_.vertices[v] - cj, nj) > plane_epsilon_) i_in_front = true;
  if (!j_in_front || !i_in_front) {
    ++cost.pairs_culled;
    return 0.0;
  }
  const double f = unoccluded(i, j, cost);
  if (f <= 0.0) return 0.0;
  if (convex_enclosure_) {
    ++cost.pairs_unoccluded;
    return f;
  }
  ++cost.pairs_traced;
  return f * visibility(i, j, cost);
}

void RaycastFormFactors::row(size_t i, std::span<double> out, RowCost& cost) const {
  for (size_t j = 0; j < out.size(); ++j) out[j] = pair(i, j, cost);
}

}  // namespace radlab
