#include "solvers/hierarchical/hierarchical_tree.h"

#include <cmath>
#include <glm/geometric.hpp>
#include <stdexcept>
#include <string>

#include "core/random.h"
#include "scene/geometry.h"

namespace radlab::hier {

Vec3 Chart::map(const Vec2& uv) const {
  const double s = uv.x, t = uv.y;
  if (corners == 3) return x[0] + s * (x[1] - x[0]) + t * (x[2] - x[0]);
  return (1 - s) * (1 - t) * x[0] + s * (1 - t) * x[1] + s * t * x[2] + (1 - s) * t * x[3];
}

double Chart::jacobian(const Vec2& uv) const {
  if (corners == 3) return 2.0 * area;
  const double s = uv.x, t = uv.y;
  const Vec3 du = (1 - t) * (x[1] - x[0]) + t * (x[2] - x[3]);
  const Vec3 dv = (1 - s) * (x[3] - x[0]) + s * (x[2] - x[1]);
  return std::abs(glm::dot(glm::cross(du, dv), normal));
}

std::vector<Chart> make_charts(const Scene& scene) {
  std::vector<Chart> charts;
  for (size_t p = 0; p < scene.polygons.size(); ++p) {
    const std::vector<Vec3>& v = scene.polygons[p].vertices;
    const Vec3 normal = geometry::unit_normal(v);
    auto add = [&](std::initializer_list<Vec3> corners) {
      Chart c;
      c.polygon = uint32_t(p);
      c.corners = int(corners.size());
      int k = 0;
      for (const Vec3& x : corners) c.x[k++] = x;
      c.normal = normal;
      c.area = geometry::area(std::span<const Vec3>(c.x, size_t(c.corners)));
      charts.push_back(c);
    };
    if (v.size() == 4)
      add({v[0], v[1], v[2], v[3]});
    else if (v.size() == 3)
      add({v[0], v[1], v[2]});
    else
      for (size_t i = 1; i + 1 < v.size(); ++i) add({v[0], v[i], v[i + 1]});
  }
  return charts;
}

uint64_t NodeKey::hash() const {
  return hash_combine(hash_combine(mix64(chart), depth), path);
}

bool dfs_less(const NodeKey& a, const NodeKey& b) {
  if (a.chart != b.chart) return a.chart < b.chart;
  const uint32_t common = std::min(a.depth, b.depth);
  for (uint32_t l = 1; l <= common; ++l) {
    const int da = a.digit(l), db = b.digit(l);
    if (da != db) return da < db;
  }
  return a.depth < b.depth;
}

namespace {

void finish(NodeGeometry& g, const Chart& chart) {
  for (int k = 0; k < g.corners; ++k) g.x[k] = chart.map(g.uv[k]);
  const std::span<const Vec3> x(g.x, size_t(g.corners));
  g.area = geometry::area(x);
  g.centre = geometry::centroid(x);
}

}  // namespace

NodeGeometry root_geometry(const Chart& chart) {
  NodeGeometry g;
  g.corners = chart.corners;
  if (chart.corners == 3) {
    g.uv[0] = {0, 0};
    g.uv[1] = {1, 0};
    g.uv[2] = {0, 1};
  } else {
    g.uv[0] = {0, 0};
    g.uv[1] = {1, 0};
    g.uv[2] = {1, 1};
    g.uv[3] = {0, 1};
  }
  finish(g, chart);
  return g;
}

NodeGeometry NodeGeometry::child(const Chart& chart, int digit) const {
  NodeGeometry c;
  c.corners = corners;
  if (corners == 4) {
    const double u0 = uv[0].x, v0 = uv[0].y, u1 = uv[2].x, v1 = uv[2].y;
    const double um = 0.5 * (u0 + u1), vm = 0.5 * (v0 + v1);
    double a0 = u0, a1 = um, b0 = v0, b1 = vm;  // digit 0: lower left
    if (digit == 1 || digit == 2) a0 = um, a1 = u1;
    if (digit == 2 || digit == 3) b0 = vm, b1 = v1;
    c.uv[0] = {a0, b0};
    c.uv[1] = {a1, b0};
    c.uv[2] = {a1, b1};
    c.uv[3] = {a0, b1};
  } else {
    const Vec2 m01 = 0.5 * (uv[0] + uv[1]), m12 = 0.5 * (uv[1] + uv[2]),
               m20 = 0.5 * (uv[2] + uv[0]);
    const Vec2 tri[4][3] = {
        {uv[0], m01, m20}, {m01, uv[1], m12}, {m20, m12, uv[2]}, {m01, m12, m20}};
    for (int k = 0; k < 3; ++k) c.uv[k] = tri[digit][k];
  }
  finish(c, chart);
  return c;
}

Vec3 NodeGeometry::point(double s, double t) const {
  if (corners == 3) return x[0] + s * (x[1] - x[0]) + t * (x[2] - x[0]);
  return (1 - s) * (1 - t) * x[0] + s * (1 - t) * x[1] + s * t * x[2] + (1 - s) * t * x[3];
}

NodeGeometry node_geometry(const std::vector<Chart>& charts, const NodeKey& key) {
  const Chart& chart = charts[key.chart];
  NodeGeometry g = root_geometry(chart);
  for (uint32_t l = 1; l <= key.depth; ++l) g = g.child(chart, key.digit(l));
  return g;
}

std::vector<ElementChart> element_charts(const Scene& scene, const Mesh& mesh,
                                         const std::vector<Chart>& charts) {
  std::vector<ElementChart> out(mesh.size());
  uint32_t first_chart = 0;
  for (size_t p = 0; p < scene.polygons.size(); ++p) {
    const size_t nv = scene.polygons[p].vertices.size();
    const size_t begin = mesh.first_element_of_polygon[p],
                 end = mesh.first_element_of_polygon[p + 1];
    const size_t m = end - begin;
    const uint32_t fan = nv <= 4 ? 1u : uint32_t(nv - 2);
    if (nv > 4 && m == 1) {
      out[begin].chart = first_chart;
      out[begin].whole = true;
    } else {
      const size_t per_chart = m / fan;
      const int k = int(std::lround(std::sqrt(double(per_chart))));
      if (size_t(k) * size_t(k) * fan != m)
        throw std::logic_error("hierarchical: polygon " + std::to_string(p) + " has " +
                               std::to_string(m) + " elements, not a K x K grid per chart");
      size_t e = begin;
      for (uint32_t f = 0; f < fan; ++f) {
        const double h = 1.0 / k;
        if (nv == 4) {
          for (int b = 0; b < k; ++b)
            for (int a = 0; a < k; ++a, ++e) {
              ElementChart& c = out[e];
              c.chart = first_chart + f;
              c.corners = 4;
              c.uv[0] = {a * h, b * h};
              c.uv[1] = {(a + 1) * h, b * h};
              c.uv[2] = {(a + 1) * h, (b + 1) * h};
              c.uv[3] = {a * h, (b + 1) * h};
            }
        } else {
          // The mesher's triangle_grid order: per row b, the upward triangle then the downward.
          for (int b = 0; b < k; ++b)
            for (int a = 0; a + b < k; ++a) {
              ElementChart& c = out[e++];
              c.chart = first_chart + f;
              c.corners = 3;
              c.uv[0] = {a * h, b * h};
              c.uv[1] = {(a + 1) * h, b * h};
              c.uv[2] = {a * h, (b + 1) * h};
              if (a + b + 1 < k) {
                ElementChart& d = out[e++];
                d.chart = first_chart + f;
                d.corners = 3;
                d.uv[0] = {(a + 1) * h, b * h};
                d.uv[1] = {(a + 1) * h, (b + 1) * h};
                d.uv[2] = {a * h, (b + 1) * h};
              }
            }
        }
      }
      // The mesher and this file must agree on every corner.
      for (size_t i = begin; i < end; ++i) {
        const ElementChart& c = out[i];
        const auto corners = mesh.element_vertices(i);
        const Chart& chart = charts[c.chart];
        const double scale = 1.0 + std::sqrt(chart.area);
        if (corners.size() != size_t(c.corners))
          throw std::logic_error("hierarchical: element " + std::to_string(i) +
                                 " corner count differs from its chart's");
        for (int j = 0; j < c.corners; ++j)
          if (glm::distance(chart.map(c.uv[j]), mesh.vertices[corners[size_t(j)]]) > 1e-9 * scale)
            throw std::logic_error("hierarchical: element " + std::to_string(i) +
                                   " does not lie where its chart puts it");
      }
    }
    first_chart += fan;
  }
  if (first_chart != charts.size())
    throw std::logic_error("hierarchical: charts and scene polygons disagree");
  return out;
}

namespace {

double cross2(const Vec2& a, const Vec2& b) {
  return a.x * b.y - a.y * b.x;
}

}  // namespace

double overlap_area(const Chart& chart, const Vec2* a, int na, const Vec2* b, int nb) {
  // Sutherland–Hodgman: keep the part of `a` left of every edge of `b`.
  Vec2 buffer[2][16];
  int n = na;
  for (int k = 0; k < na; ++k) buffer[0][k] = a[k];
  int cur = 0;
  for (int e = 0; e < nb && n > 0; ++e) {
    const Vec2 p = b[e], d = b[(e + 1) % nb] - b[e];
    const Vec2* in = buffer[cur];
    Vec2* out = buffer[1 - cur];
    int m = 0;
    for (int k = 0; k < n; ++k) {
      const Vec2 s = in[k], t = in[(k + 1) % n];
      const double fs = cross2(d, s - p), ft = cross2(d, t - p);
      if (fs >= 0) out[m++] = s;
      if ((fs >= 0) != (ft >= 0)) out[m++] = s + (fs / (fs - ft)) * (t - s);
    }
    n = m;
    cur = 1 - cur;
  }
  if (n < 3) return 0.0;
  const Vec2* poly = buffer[cur];
  double twice = 0.0;
  Vec2 centroid{0.0};
  for (int k = 0; k < n; ++k) {
    const double w = cross2(poly[k], poly[(k + 1) % n]);
    twice += w;
    centroid += w * (poly[k] + poly[(k + 1) % n]);
  }
  if (!(twice > 0)) return 0.0;
  centroid /= 3.0 * twice;
  return 0.5 * twice * chart.jacobian(centroid);
}

}  // namespace radlab::hier
