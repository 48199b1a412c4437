#include "scene/tessellate.h"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <numbers>

#include "scene/geometry.h"

namespace radlab::tessellate {
namespace {

// Orthonormal u, v with u x v = w (w unit).
void make_axes(const Vec3& w, Vec3& u, Vec3& v) {
  int k = 0;
  for (int i = 1; i < 3; ++i)
    if (std::abs(w[i]) < std::abs(w[k])) k = i;
  Vec3 a(0.0);
  a[k] = 1.0;
  u = glm::normalize(glm::cross(a, w));
  v = glm::cross(w, u);
}

// Point at angle step k of `segments` around the circle of radius r about `centre` in the plane
// (u, v); k wraps, so k = segments is k = 0 exactly.
Vec3 around(const Vec3& centre, const Vec3& u, const Vec3& v, double r, int k, int segments) {
  const double theta = 2.0 * std::numbers::pi * double(k % segments) / double(segments);
  return centre + r * (std::cos(theta) * u + std::sin(theta) * v);
}

void add(Polygons& out, std::vector<Vec3> polygon, bool reversed) {
  if (reversed) std::reverse(polygon.begin(), polygon.end());
  out.push_back(std::move(polygon));
}

}  // namespace

// Quads [P1(k), P1(k+1), P2(k+1), P2(k)] face away from the axis.
Polygons cone(const Vec3& p1, double r1, const Vec3& p2, double r2, int segments) {
  const bool inward = r1 < 0 || r2 < 0;
  const Vec3 w = glm::normalize(p2 - p1);
  Vec3 u, v;
  make_axes(w, u, v);
  const double a1 = std::abs(r1), a2 = std::abs(r2);
  Polygons out;
  for (int k = 0; k < segments; ++k) {
    std::vector<Vec3> q;
    if (a1 > 0) {
      q.push_back(around(p1, u, v, a1, k, segments));
      q.push_back(around(p1, u, v, a1, k + 1, segments));
    } else {
      q.push_back(p1);
    }
    if (a2 > 0) {
      q.push_back(around(p2, u, v, a2, k + 1, segments));
      q.push_back(around(p2, u, v, a2, k, segments));
    } else {
      q.push_back(p2);
    }
    add(out, std::move(q), inward);
  }
  return out;
}

Polygons sphere(const Vec3& centre, double radius, int segments) {
  const bool inward = radius < 0;
  const double r = std::abs(radius);
  const Vec3 u(1, 0, 0), v(0, 1, 0), w(0, 0, 1);
  const int bands = segments / 2;
  auto ring_at = [&](int j, int k) {
    const double phi = std::numbers::pi * double(j) / double(bands);
    return around(centre + r * std::cos(phi) * w, u, v, r * std::sin(phi), k, segments);
  };
  Polygons out;
  for (int j = 0; j < bands; ++j) {  // band between latitude j (upper) and j + 1 (lower)
    for (int k = 0; k < segments; ++k) {
      std::vector<Vec3> q;
      if (j + 1 == bands) {
        q.push_back(centre - r * w);
      } else {
        q.push_back(ring_at(j + 1, k));
        q.push_back(ring_at(j + 1, k + 1));
      }
      if (j == 0) {
        q.push_back(centre + r * w);
      } else {
        q.push_back(ring_at(j, k + 1));
        q.push_back(ring_at(j, k));
      }
      add(out, std::move(q), inward);
    }
  }
  return out;
}

Polygons ring(const Vec3& centre, const Vec3& normal, double rmin, double rmax, int segments) {
  Vec3 u, v;
  make_axes(normal, u, v);
  Polygons out;
  for (int k = 0; k < segments; ++k) {
    std::vector<Vec3> q;
    if (rmin > 0) {
      q.push_back(around(centre, u, v, rmin, k, segments));
    } else {
      q.push_back(centre);
    }
    q.push_back(around(centre, u, v, rmax, k, segments));
    q.push_back(around(centre, u, v, rmax, k + 1, segments));
    if (rmin > 0) q.push_back(around(centre, u, v, rmin, k + 1, segments));
    add(out, std::move(q), false);
  }
  return out;
}

Polygons torus(const Vec3& centre, const Vec3& normal, double rmin, double rmax, int segments) {
  const bool inward = rmax < 0;
  const double big = 0.5 * std::abs(rmin + rmax), tube = 0.5 * std::abs(rmax - rmin);
  Vec3 u, v;
  make_axes(normal, u, v);
  auto point = [&](int k, int j) {
    const double theta = 2.0 * std::numbers::pi * double(k % segments) / double(segments);
    const double psi = 2.0 * std::numbers::pi * double(j % segments) / double(segments);
    const Vec3 d = std::cos(theta) * u + std::sin(theta) * v;
    return centre + (big + tube * std::cos(psi)) * d + tube * std::sin(psi) * normal;
  };
  Polygons out;
  for (int k = 0; k < segments; ++k)
    for (int j = 0; j < segments; ++j)
      add(out, {point(k, j), point(k + 1, j), point(k + 1, j + 1), point(k, j + 1)}, inward);
  return out;
}

Polygons prism(const std::vector<Vec3>& base, double length) {
  const Vec3 d = -length * geometry::unit_normal(base);
  Polygons out;
  out.push_back(base);
  std::vector<Vec3> top(base.rbegin(), base.rend());
  for (Vec3& p : top) p += d;
  out.push_back(std::move(top));
  for (size_t i = 0; i < base.size(); ++i) {
    const Vec3& a = base[i];
    const Vec3& b = base[(i + 1) % base.size()];
    out.push_back({a, a + d, b + d, b});
  }
  return out;
}

}  // namespace radlab::tessellate
