#include "formfactor/sampling.h"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>

namespace radlab {
namespace {

// Area-uniform map of the unit square onto a triangle.
Vec3 on_triangle(const Vec3& a, const Vec3& b, const Vec3& c, double s, double t) {
  const double r = std::sqrt(s);
  return (1.0 - r) * a + r * (1.0 - t) * b + r * t * c;
}

Vec3 on_polygon(std::span<const Vec3> c, double s, double t) {
  if (c.size() == 4)  // bilinear: not area-uniform on a non-parallelogram, which only changes
                      // the stratification, not the estimate of V
    return (1 - s) * (1 - t) * c[0] + s * (1 - t) * c[1] + s * t * c[2] + (1 - s) * t * c[3];
  if (c.size() == 3) return on_triangle(c[0], c[1], c[2], s, t);
  // A fan: pick the triangle by area with s, then rescale s within it.
  double total = 0.0;
  for (size_t f = 1; f + 1 < c.size(); ++f)
    total += glm::length(glm::cross(c[f] - c[0], c[f + 1] - c[0]));
  double acc = 0.0;
  for (size_t f = 1; f + 1 < c.size(); ++f) {
    const double a = glm::length(glm::cross(c[f] - c[0], c[f + 1] - c[0])) / total;
    if (s <= acc + a || f + 2 == c.size())
      return on_triangle(c[0], c[f], c[f + 1], std::clamp((s - acc) / a, 0.0, 1.0), t);
    acc += a;
  }
  return c[0];
}

}  // namespace

void stratified_points(std::span<const Vec3> c, int count, Pcg32& rng, std::vector<Vec3>& out,
                       double inset) {
  out.resize(size_t(count));
  const int m = int(std::ceil(std::sqrt(double(count))));
  const double scale = (1.0 - 2.0 * inset) / m;
  if (m * m == count && c.size() == 4) {
    // The common case, kept tight: every cell of a quad once, in order (no selection needed).
    const Vec3 e1 = c[1] - c[0], e3 = c[3] - c[0], twist = c[2] - c[1] - c[3] + c[0];
    for (int k = 0; k < count; ++k) {
      const double s = inset + scale * (k % m + rng.next_double());
      const double t = inset + scale * (k / m + rng.next_double());
      out[size_t(k)] = c[0] + s * e1 + t * e3 + (s * t) * twist;
    }
    return;
  }
  if (m * m == count) {
    // Every cell once, in order: no selection needed.
    for (int k = 0; k < count; ++k) {
      const double s = inset + scale * (k % m + rng.next_double());
      const double t = inset + scale * (k / m + rng.next_double());
      out[size_t(k)] = on_polygon(c, s, t);
    }
    return;
  }
  // Choose `count` distinct cells of the m x m grid.
  thread_local std::vector<int> cells;
  cells.resize(size_t(m * m));
  for (int k = 0; k < m * m; ++k) cells[size_t(k)] = k;
  for (int k = 0; k < count; ++k) {
    const int pick = k + int(rng.next_below(uint32_t(m * m - k)));
    std::swap(cells[size_t(k)], cells[size_t(pick)]);
    const int cell = cells[size_t(k)];
    const double s = inset + scale * (cell % m + rng.next_double());
    const double t = inset + scale * (cell / m + rng.next_double());
    out[size_t(k)] = on_polygon(c, s, t);
  }
}

}  // namespace radlab
