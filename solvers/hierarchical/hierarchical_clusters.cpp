#include "solvers/hierarchical/hierarchical_clusters.h"

#include <algorithm>
#include <cmath>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <numbers>

#include "formfactor/visibility/embree_bvh.h"

namespace radlab::hier {

size_t ClusterTree::memory_bytes() const {
  return clusters.size() * sizeof(Cluster) + order.size() * sizeof(uint32_t) +
         cumulative_area.size() * sizeof(double) + chart_parent.size() * sizeof(int32_t);
}

Vec3 ClusterTree::sample(const std::vector<Chart>& charts, uint32_t c, int k, int strata, double u0,
                         double u1, double u2, uint32_t& polygon) const {
  const Cluster& cl = clusters[c];
  const double a0 = cumulative_area[cl.first], a1 = cumulative_area[cl.first + cl.count];
  const double target = a0 + (a1 - a0) * (double(k) + u0) / double(strata);
  // The chart whose area interval holds `target` (the last one for rounding at the top).
  const auto begin = cumulative_area.begin() + long(cl.first) + 1;
  const auto end = cumulative_area.begin() + long(cl.first + cl.count);
  const size_t at = size_t(std::upper_bound(begin, end, target) - begin);
  const Chart& chart = charts[order[cl.first + std::min<size_t>(at, cl.count - 1)]];
  polygon = chart.polygon;
  if (chart.corners == 3) {
    if (u1 + u2 > 1.0) {
      u1 = 1.0 - u1;
      u2 = 1.0 - u2;
    }
  }
  return chart.map({u1, u2});
}

namespace {

// Each chart's axis-aligned box, the BVH builder's input.
std::vector<BvhBox> chart_boxes(const std::vector<Chart>& charts) {
  std::vector<BvhBox> boxes(charts.size());
  for (size_t c = 0; c < charts.size(); ++c) {
    BvhBox& b = boxes[c];
    b.lo = b.hi = charts[c].x[0];
    for (int k = 1; k < charts[c].corners; ++k) {
      b.lo = glm::min(b.lo, charts[c].x[k]);
      b.hi = glm::max(b.hi, charts[c].x[k]);
    }
  }
  return boxes;
}

// Leaf order and ranges: a preorder walk visits the charts left to right, so each cluster holds
// the charts order[first, first + count), and chart_parent names each chart's cluster.
void order_charts(ClusterTree& t, size_t charts) {
  const size_t n = t.clusters.size();
  t.order.reserve(charts);
  // Ranges need the subtree sizes: children after parents in preorder, so sum in reverse.
  std::vector<uint32_t> count(n, 0);
  for (size_t i = n; i-- > 0;)
    for (int k = 0; k < 2; ++k) {
      const int32_t ch = t.clusters[i].child[k];
      count[i] += ch >= 0 ? count[size_t(ch)] : 1u;
    }
  // First chart of each cluster: the root starts at 0, a first child at its parent's first, a
  // second child after the first child's charts.
  std::vector<uint32_t> first(n, 0);
  for (size_t i = 0; i < n; ++i) {
    uint32_t at = first[i];
    for (int k = 0; k < 2; ++k) {
      const int32_t ch = t.clusters[i].child[k];
      if (ch >= 0) {
        first[size_t(ch)] = at;
        at += count[size_t(ch)];
      } else {
        at += 1;
      }
    }
  }
  t.order.assign(charts, 0);
  for (size_t i = 0; i < n; ++i) {
    t.clusters[i].first = first[i];
    t.clusters[i].count = count[i];
    uint32_t at = first[i];
    for (int k = 0; k < 2; ++k) {
      const int32_t ch = t.clusters[i].child[k];
      if (ch >= 0) {
        at += count[size_t(ch)];
      } else {
        t.order[at++] = uint32_t(~ch);
        t.chart_parent[size_t(~ch)] = int32_t(i);
      }
    }
  }
}

// Area, centroid, box and bounding-sphere radius of every cluster, children before parents.
void measure_clusters(ClusterTree& t, const std::vector<Chart>& charts,
                      const std::vector<BvhBox>& boxes) {
  for (size_t i = t.clusters.size(); i-- > 0;) {
    Cluster& cl = t.clusters[i];
    double area = 0.0;
    Vec3 moment(0.0), lo(1e300), hi(-1e300);
    for (int k = 0; k < 2; ++k) {
      const int32_t ch = cl.child[k];
      if (ch >= 0) {
        const Cluster& c = t.clusters[size_t(ch)];
        area += c.area;
        moment += c.area * c.centre;
        lo = glm::min(lo, c.lo);
        hi = glm::max(hi, c.hi);
      } else {
        const Chart& chart = charts[size_t(~ch)];
        area += chart.area;
        moment += chart.area * root_geometry(chart).centre;
        lo = glm::min(lo, boxes[size_t(~ch)].lo);
        hi = glm::max(hi, boxes[size_t(~ch)].hi);
      }
    }
    cl.area = area;
    cl.lo = lo;
    cl.hi = hi;
    // A cluster of zero area (degenerate charts only) is centred on its box.
    cl.centre = area > 0.0 ? moment / area : 0.5 * (lo + hi);
    cl.centre = glm::clamp(cl.centre, lo, hi);
    double r2 = 0.0;
    for (int corner = 0; corner < 8; ++corner) {
      const Vec3 x(corner & 1 ? hi.x : lo.x, corner & 2 ? hi.y : lo.y, corner & 4 ? hi.z : lo.z);
      r2 = std::max(r2, glm::dot(x - cl.centre, x - cl.centre));
    }
    cl.radius = std::sqrt(r2);
  }
}

}  // namespace

ClusterTree build_clusters(const std::vector<Chart>& charts) {
  ClusterTree t;
  t.chart_parent.assign(charts.size(), -1);
  const std::vector<BvhBox> boxes = chart_boxes(charts);
  const BinaryBvh bvh = build_binary_bvh(boxes);
  t.clusters.resize(bvh.nodes.size());
  for (size_t i = 0; i < bvh.nodes.size(); ++i) {
    t.clusters[i].parent = bvh.nodes[i].parent;
    for (int k = 0; k < 2; ++k) t.clusters[i].child[k] = bvh.nodes[i].child[k];
  }
  order_charts(t, charts.size());
  t.cumulative_area.assign(charts.size() + 1, 0.0);
  for (size_t k = 0; k < t.order.size(); ++k)
    t.cumulative_area[k + 1] = t.cumulative_area[k] + charts[t.order[k]].area;
  measure_clusters(t, charts, boxes);
  return t;
}

double isotropic_point_factor(const Vec3& x, const Vec3& n, const Vec3& centre,
                              double source_area) {
  const Vec3 d = centre - x;
  const double r2 = glm::dot(d, d);
  if (!(r2 > 0.0)) return 0.0;
  const double cosine = std::max(0.0, glm::dot(n, d)) / std::sqrt(r2);
  return source_area * cosine / (4.0 * std::numbers::pi * r2);
}

}  // namespace radlab::hier
