// Cosine rays between elements, and the power distribution over elements (element_rays.h).
#include "solvers/monte_carlo/element_rays.h"

#include <algorithm>
#include <cmath>
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
  sources_.resize(mesh.size());
  targets_.resize(mesh.size());
  for (size_t e = 0; e < mesh.size(); ++e) {
    targets_[e] = {mesh.normal[e], mesh.polygon[e]};
    Source& s = sources_[e];
    const std::span<const uint32_t> v = mesh.element_vertices(e);
    s.normal = mesh.normal[e];
    const Frame frame = frame_about(s.normal);
    s.tangent = frame.t;
    s.bitangent = frame.b;
    s.polygon = mesh.polygon[e];
    s.fan = v.size() == 3 || v.size() == 4;
    if (!s.fan) continue;
    s.a = mesh.vertices[v[0]];
    s.b = mesh.vertices[v[1]];
    s.c = mesh.vertices[v[2]];
    s.d = v.size() == 4 ? mesh.vertices[v[3]] : s.c;
    const double first = glm::length(glm::cross(s.b - s.a, s.c - s.a));
    const double second = v.size() == 4 ? glm::length(glm::cross(s.c - s.a, s.d - s.a)) : 0.0;
    s.first_share = first + second > 0.0 ? first / (first + second) : 1.0;
    s.first_scale = s.first_share > 0.0 ? 1.0 / s.first_share : 0.0;
    s.second_scale = s.first_share < 1.0 ? 1.0 / (1.0 - s.first_share) : 0.0;
  }
}

namespace {

// The fan's triangle by area and u1 rescaled to [0,1) within it (as point_on_element), as
// m (1: the first triangle, 0: the second) and r, the square root that keeps the point uniform.
// Without a branch (which triangle is a coin toss on a quad): m x + (1 - m) y is x or y exactly.
// A triangle's share is 1, so m is 1 there.
struct FanPick {
  double m, r;
};
inline FanPick fan_pick(double u1, double first_share, double first_scale, double second_scale) {
  const double m = u1 < first_share ? 1.0 : 0.0;
  const double t = m * (u1 * first_scale) + (1.0 - m) * ((u1 - first_share) * second_scale);
  return {m, std::sqrt(std::clamp(t, 0.0, 0x1.fffffffffffffp-1))};
}

}  // namespace

Vec3 ElementRays::fan_point(const Source& s, double m, double r, double u2) {
  const Vec3 b = s.b * m + s.c * (1.0 - m);
  const Vec3 c = s.c * m + s.d * (1.0 - m);
  return s.a * (1.0 - r) + b * (r * (1.0 - u2)) + c * (r * u2);
}

Vec3 ElementRays::origin(const Source& s, size_t element, double u1, double u2) const {
  if (!s.fan) return point_on_element(mesh_, element, u1, u2);
  const FanPick pick = fan_pick(u1, s.first_share, s.first_scale, s.second_scale);
  return fan_point(s, pick.m, pick.r, u2);
}

ElementRays::Ray ElementRays::ray(size_t source, const double* u) const {
  const Source& s = sources_[source];
  const Vec3 local = cosine_direction_local(u[3], u[4]);
  return {origin(s, source, u[1], u[2]),
          s.tangent * local.x + s.bitangent * local.y + s.normal * local.z, s.polygon};
}

uint32_t ElementRays::cast(const Ray& ray) const {
  double t_near = t_near_;
  // A planar polygon cannot be met again by a ray leaving its front: a hit on the source's own
  // polygon is rounding (a ray grazing it near an edge), so the ray goes on past it (a few
  // times at most).
  for (int attempt = 0; attempt < 4; ++attempt) {
    const RayHit hit = embree_->intersect(ray.origin, ray.direction, t_near, 1e30);
    if (!hit.hit) return kMiss;
    const Target& met = targets_[hit.element];
    if (met.polygon == ray.polygon) {
      t_near = hit.distance + t_near_;
      continue;
    }
    // Only a front face receives (F_ij is zero when j faces away from i): a back face absorbs.
    return glm::dot(ray.direction, met.normal) < 0.0 ? hit.element : kMiss;
  }
  return kMiss;
}

void ElementRays::cast(Batch& batch, uint32_t* out) const {
  // In three loops. The sources' triangle shares first (the gathers). Then every ray's
  // direction about +z and triangle choice at once: no memory access but arrays, no branch, so
  // the loop runs two rays to an instruction (SSE2; CMakeLists.txt lets this file if-convert and
  // vectorise: no errno from sqrt, no trapping compares, no contraction): the division, the
  // sin/cos polynomials and both square roots were most of a ray's making (perf annotate). Then
  // each ray's origin and direction from its source's points and frame.
  constexpr size_t n = Batch::kCapacity;
  double share[n], first_scale[n], second_scale[n];
  for (size_t k = 0; k < batch.size; ++k) {
    const Source& s = sources_[batch.source[k]];
    share[k] = s.first_share;
    first_scale[k] = s.first_scale;
    second_scale[k] = s.second_scale;
  }
  double x[n], y[n], z[n], m[n], r[n];
  for (size_t k = 0; k < batch.size; ++k) {
    const Vec3 local = cosine_direction_local(batch.u3[k], batch.u4[k]);
    x[k] = local.x;
    y[k] = local.y;
    z[k] = local.z;
    const FanPick pick = fan_pick(batch.u1[k], share[k], first_scale[k], second_scale[k]);
    m[k] = pick.m;
    r[k] = pick.r;
  }
  for (size_t k = 0; k < batch.size; ++k) {
    const Source& s = sources_[batch.source[k]];
    batch.origin[k] = s.fan ? fan_point(s, m[k], r[k], batch.u2[k])
                            : point_on_element(mesh_, batch.source[k], batch.u1[k], batch.u2[k]);
    batch.direction[k] = s.tangent * x[k] + s.bitangent * y[k] + s.normal * z[k];
    batch.polygon[k] = s.polygon;
  }
  RayHit hits[Batch::kCapacity];
  embree_->intersect_stream(batch.origin, batch.direction, batch.size, t_near_, 1e30, hits);
  for (size_t k = 0; k < batch.size; ++k) {
    if (!hits[k].hit) {
      out[k] = kMiss;
      continue;
    }
    const Target& met = targets_[hits[k].element];
    if (met.polygon == batch.polygon[k])  // rare: the single-ray path goes on past the own polygon
      out[k] = cast(Ray{batch.origin[k], batch.direction[k], batch.polygon[k]});
    else  // a back face absorbs
      out[k] = glm::dot(batch.direction[k], met.normal) < 0.0 ? hits[k].element : kMiss;
  }
}

ElementDistribution::ElementDistribution(std::span<const double> weights)
    : cumulative_(weights.size()) {
  double total = 0.0;
  for (size_t i = 0; i < weights.size(); ++i) {
    total += weights[i];
    cumulative_[i] = total;
  }
  const size_t n = weights.size();
  guide_.resize(n);
  size_t i = 0;
  for (size_t k = 0; k < n; ++k) {
    const double target = double(k) / double(n) * total;
    while (i + 1 < n && !(cumulative_[i] > target)) ++i;
    guide_[k] = uint32_t(i);
  }
}

size_t ElementDistribution::pick(double u) const {
  const size_t n = cumulative_.size();
  const double target = u * total();
  // The first element whose cumulative weight exceeds u * total: from the guide's start, back
  // while the one before also exceeds it (rounding of k/n), then on while this one does not.
  size_t i = guide_[std::min(size_t(u * double(n)), n - 1)];
  while (i > 0 && cumulative_[i - 1] > target) --i;
  while (i + 1 < n && !(cumulative_[i] > target)) ++i;
  while (i > 0 && cumulative_[i] == cumulative_[i - 1]) --i;  // rounding at the very top
  return i;
}

}  // namespace radlab::monte_carlo
