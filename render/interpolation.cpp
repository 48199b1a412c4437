// Vertex values and in-element interpolation for smooth shading (see interpolation.h).
#include "render/interpolation.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>
#include <tuple>

namespace radlab {
namespace {

double cross2(const glm::dvec2& a, const glm::dvec2& b) {
  return a.x * b.y - a.y * b.x;
}

void triangle_weights(std::span<const Vec3> c, const Vec3& n, const Vec3& p, std::span<double> w) {
  const double area = glm::dot(glm::cross(c[1] - c[0], c[2] - c[0]), n);
  if (area == 0.0) {  // degenerate: no coordinates exist; the mean is the least surprising value
    std::fill(w.begin(), w.end(), 1.0 / 3.0);
    return;
  }
  w[0] = glm::dot(glm::cross(c[1] - p, c[2] - p), n) / area;
  w[1] = glm::dot(glm::cross(c[2] - p, c[0] - p), n) / area;
  w[2] = 1.0 - w[0] - w[1];
}

// Inverts P(s,t) = (1-s)(1-t) c0 + s(1-t) c1 + s t c2 + (1-s) t c3 in closed form. With
// e = c1-c0, f = c3-c0, g = c0-c1+c2-c3, h = p-c0 we have h = s (e + t g) + t f; the 2D cross
// product with e + t g removes s and leaves (f x g) t^2 + (f x e - h x g) t - h x e = 0. The root
// in (or nearest to) [0,1] is t; s then follows by projection on e + t g.
void quad_weights(std::span<const Vec3> c, const Vec3& n, const Vec3& p, std::span<double> w) {
  const Vec3 axis = std::abs(n.x) < 0.9 ? Vec3(1, 0, 0) : Vec3(0, 1, 0);
  const Vec3 u = glm::normalize(glm::cross(n, axis));
  const Vec3 v = glm::cross(n, u);
  auto to2 = [&](const Vec3& q) {
    return glm::dvec2(glm::dot(q - c[0], u), glm::dot(q - c[0], v));
  };
  const glm::dvec2 e = to2(c[1]), f = to2(c[3]), g = to2(c[2]) - e - f, h = to2(p);
  const double a = cross2(f, g), b = cross2(f, e) - cross2(h, g), k = -cross2(h, e);
  // Numerically stable roots: q = -(b + sign(b) sqrt(disc)) / 2, roots k/q and q/a. When a is
  // tiny (a parallelogram or trapezoid) q/a runs off to infinity and k/q is the linear root.
  const double root = std::sqrt(std::max(b * b - 4.0 * a * k, 0.0));
  const double q = -0.5 * (b + std::copysign(root, b));
  double t = 0.5;
  double best = std::numeric_limits<double>::infinity();
  auto consider = [&](double candidate) {
    const double outside = std::max({-candidate, candidate - 1.0, 0.0});
    if (outside < best) {
      best = outside;
      t = candidate;
    }
  };
  if (q != 0.0) consider(k / q);
  if (a != 0.0) consider(q / a);
  const glm::dvec2 across = e + t * g;
  const double length2 = glm::dot(across, across);
  double s = length2 > 0.0 ? glm::dot(h - t * f, across) / length2 : 0.5;
  s = std::clamp(s, 0.0, 1.0);
  t = std::clamp(t, 0.0, 1.0);
  w[0] = (1 - s) * (1 - t);
  w[1] = s * (1 - t);
  w[2] = s * t;
  w[3] = (1 - s) * t;
}

// Mean-value coordinates: w_i proportional to (tan(a_{i-1}/2) + tan(a_i/2)) / r_i, where a_i is
// the signed angle at p between corners i and i+1 and r_i = |c_i - p|. tan(a/2) is computed as
// sin a / (1 + cos a) from cross and dot products, without trigonometry. At a corner, or on an
// edge (a = pi, where the formula is 0/0), the limit is used: the corner, or linear along the edge.
void mean_value_weights(std::span<const Vec3> c, const Vec3& n, const Vec3& p,
                        std::span<double> w) {
  const size_t m = c.size();
  double scale = 0.0;
  for (const Vec3& corner : c) scale = std::max(scale, glm::length(corner - p));
  for (size_t i = 0; i < m; ++i)
    if (glm::length(c[i] - p) <= 1e-12 * scale) {
      std::fill(w.begin(), w.end(), 0.0);
      w[i] = 1.0;
      return;
    }
  for (size_t i = 0; i < m; ++i) {  // w[i] = tan(a_i / 2), edge from corner i to i+1
    const size_t j = (i + 1) % m;
    const Vec3 di = c[i] - p, dj = c[j] - p;
    const double ri = glm::length(di), rj = glm::length(dj);
    const double sine = glm::dot(glm::cross(di, dj), n), cosine = glm::dot(di, dj);
    if (cosine < 0.0 && std::abs(sine) <= 1e-12 * ri * rj) {  // p on the edge
      std::fill(w.begin(), w.end(), 0.0);
      w[i] = rj / (ri + rj);
      w[j] = ri / (ri + rj);
      return;
    }
    w[i] = sine / (ri * rj + cosine);
  }
  double before = w[m - 1], total = 0.0;
  for (size_t i = 0; i < m; ++i) {
    const double here = w[i];
    w[i] = (before + here) / glm::length(c[i] - p);
    total += w[i];
    before = here;
  }
  for (double& weight : w) weight /= total;
}

}  // namespace

void interpolation_weights(std::span<const Vec3> corners, const Vec3& normal, const Vec3& p,
                           std::span<double> weights) {
  if (weights.size() != corners.size() || corners.size() < 3)
    throw std::invalid_argument("interpolation_weights: " + std::to_string(corners.size()) +
                                " corners and " + std::to_string(weights.size()) + " weights");
  if (corners.size() == 3) return triangle_weights(corners, normal, p, weights);
  if (corners.size() == 4) return quad_weights(corners, normal, p, weights);
  mean_value_weights(corners, normal, p, weights);
}

std::vector<glm::dvec3> smooth_vertex_values(const Mesh& mesh,
                                             std::span<const glm::dvec3> element_values) {
  if (element_values.size() != mesh.size())
    throw std::invalid_argument("smooth_vertex_values: " + std::to_string(element_values.size()) +
                                " values for " + std::to_string(mesh.size()) + " elements");
  const size_t nv = mesh.vertices.size();
  constexpr uint32_t kUnused = std::numeric_limits<uint32_t>::max();
  std::vector<uint32_t> owner(nv, kUnused);  // the polygon whose elements use the vertex
  for (size_t e = 0; e < mesh.size(); ++e)
    for (uint32_t v : mesh.element_vertices(e)) owner[v] = mesh.polygon[e];

  // Merge vertices of one polygon at exactly the same position. Exact equality suffices: the
  // mesher computes a point shared by two sub-grids with the same arithmetic on both sides.
  std::vector<uint32_t> order(nv);
  std::iota(order.begin(), order.end(), 0u);
  auto key = [&](uint32_t v) {
    const Vec3& x = mesh.vertices[v];
    return std::make_tuple(owner[v], x.x, x.y, x.z);
  };
  std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) { return key(a) < key(b); });
  std::vector<uint32_t> representative(nv);
  for (size_t k = 0; k < nv; ++k)
    representative[order[k]] =
        k > 0 && key(order[k]) == key(order[k - 1]) ? representative[order[k - 1]] : order[k];

  std::vector<glm::dvec3> sum(nv, glm::dvec3(0.0));
  std::vector<double> weight(nv, 0.0);
  for (size_t e = 0; e < mesh.size(); ++e)
    for (uint32_t v : mesh.element_vertices(e)) {
      sum[representative[v]] += mesh.area[e] * element_values[e];
      weight[representative[v]] += mesh.area[e];
    }
  std::vector<glm::dvec3> value(nv, glm::dvec3(0.0));
  for (size_t v = 0; v < nv; ++v) {
    const uint32_t r = representative[v];
    if (owner[v] != kUnused && weight[r] > 0.0) value[v] = sum[r] / weight[r];
  }
  return value;
}

glm::dvec3 interpolate_on_element(const Mesh& mesh, std::span<const glm::dvec3> vertex_values,
                                  size_t element, const Vec3& p) {
  const auto ids = mesh.element_vertices(element);
  const Vec3& n = mesh.normal[element];
  const Vec3 in_plane = p - glm::dot(p - mesh.centroid[element], n) * n;
  // Elements have 3 or 4 corners except unsplit n-gons; keep the common case off the heap.
  constexpr size_t kInline = 8;
  std::array<Vec3, kInline> inline_corners;
  std::array<double, kInline> inline_weights;
  std::vector<Vec3> heap_corners;
  std::vector<double> heap_weights;
  std::span<Vec3> corners(inline_corners.data(), std::min(ids.size(), kInline));
  std::span<double> weights(inline_weights.data(), corners.size());
  if (ids.size() > kInline) {
    heap_corners.resize(ids.size());
    heap_weights.resize(ids.size());
    corners = heap_corners;
    weights = heap_weights;
  }
  for (size_t k = 0; k < ids.size(); ++k) corners[k] = mesh.vertices[ids[k]];
  interpolation_weights(corners, n, in_plane, weights);
  glm::dvec3 value(0.0);
  for (size_t k = 0; k < ids.size(); ++k) value += weights[k] * vertex_values[ids[k]];
  return value;
}

}  // namespace radlab
