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

}  // namespace

void stratified_points(std::span<const Vec3> c, int count, Pcg32& rng, std::vector<Vec3>& out,
                       double inset) {
  out.clear();
  const int m = int(std::ceil(std::sqrt(double(count))));
  // Choose `count` distinct cells of the m x m grid (all of them when count is a square).
  thread_local std::vector<int> cells;
  cells.resize(size_t(m * m));
  for (int k = 0; k < m * m; ++k) cells[size_t(k)] = k;
  for (int k = 0; k < count; ++k) {
    int pick = k + int(rng.next_below(uint32_t(m * m - k)));
    std::swap(cells[size_t(k)], cells[size_t(pick)]);
  }
  // Areas of the fan triangles, for n-gons (quads use the bilinear map; it is not area-uniform
  // for a non-parallelogram, which only changes the stratification, not correctness of V).
  for (int k = 0; k < count; ++k) {
    const int cell = cells[size_t(k)];
    double s = (cell % m + rng.next_double()) / m;
    double t = (cell / m + rng.next_double()) / m;
    s = inset + (1.0 - 2.0 * inset) * s;
    t = inset + (1.0 - 2.0 * inset) * t;
    Vec3 p;
    if (c.size() == 4) {
      p = (1 - s) * (1 - t) * c[0] + s * (1 - t) * c[1] + s * t * c[2] + (1 - s) * t * c[3];
    } else if (c.size() == 3) {
      p = on_triangle(c[0], c[1], c[2], s, t);
    } else {
      // Fan: pick the triangle by area with s, then rescale s within it.
      double total = 0.0;
      for (size_t f = 1; f + 1 < c.size(); ++f)
        total += glm::length(glm::cross(c[f] - c[0], c[f + 1] - c[0]));
      double acc = 0.0;
      p = c[0];
      for (size_t f = 1; f + 1 < c.size(); ++f) {
        double a = glm::length(glm::cross(c[f] - c[0], c[f + 1] - c[0])) / total;
        if (s <= acc + a || f + 2 == c.size()) {
          double local = std::clamp((s - acc) / a, 0.0, 1.0);
          p = on_triangle(c[0], c[f], c[f + 1], local, t);
          break;
        }
        acc += a;
      }
    }
    out.push_back(p);
  }
}

}  // namespace radlab
