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
         cumulative_area.size() * sizeof(double) + chart_parent.size() * sizeof(int32_t) +
         normal_first.size() * sizeof(uint32_t) + normal.size() * sizeof(Vec3) +
         (normal_area.size() + rest_area.size() + slot_area.size()) * sizeof(double) +
         (slot_first.size() + chart_slot_first.size() + chart_slot.size()) * sizeof(uint32_t) +
         emitting.size();
}

double ClusterTree::projected_area(uint32_t c, const Vec3& w) const {
  if (!oriented()) return 0.25 * clusters[c].area;
  double p = 0.25 * rest_area[c];
  for (uint32_t k = normal_first[c]; k < normal_first[c + 1]; ++k)
    p += normal_area[k] * std::max(0.0, glm::dot(normal[k], w));
  return p;
}

double ClusterTree::slot_projected_area(uint32_t c, uint32_t slot, const Vec3& w) const {
  const uint32_t k = normal_first[c] + (slot - slot_first[c]);
  if (k >= normal_first[c + 1]) return 0.25 * rest_area[c];  // the remainder
  return normal_area[k] * std::max(0.0, glm::dot(normal[k], w));
}

double ClusterTree::projected_area_bound(uint32_t c, const Vec3& w, double spread) const {
  double p = rest_area[c];
  for (uint32_t k = normal_first[c]; k < normal_first[c + 1]; ++k) {
    // The angle between the normal and w, less the spread: the smallest angle the normal makes
    // with a direction of the cone.
    const double angle = std::acos(std::clamp(glm::dot(normal[k], w), -1.0, 1.0)) - spread;
    if (angle < 0.5 * std::numbers::pi) p += normal_area[k] * std::cos(std::max(angle, 0.0));
  }
  return p;
}

double ClusterTree::point_factor(uint32_t c, const Vec3& x, const Vec3& n) const {
  const Cluster& cl = clusters[c];
  if (!oriented()) return isotropic_point_factor(x, n, cl.centre, cl.area);
  const Vec3 d = cl.centre - x;
  const double r2 = glm::dot(d, d);
  if (!(r2 > 0.0)) return 0.0;
  const double r = std::sqrt(r2);
  const double cosine = std::max(0.0, glm::dot(n, d)) / r;
  if (cosine == 0.0) return 0.0;
  return projected_area(c, -d / r) * cosine / (std::numbers::pi * r2);
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

// Oriented clusters' normal lists, children before parents: a chart contributes its normal and
// area, a cluster its children's lists merged (left child first, then right, in list order, so
// the result does not depend on threads or hashing); past kOrientedNormals, the normals of
// largest area are kept (ties by list order) and the rest join the isotropic remainder. Where
// each child entry (and each chart) went is recorded, so every chart's slot in every cluster above
// it is known exactly (a chart's area is counted in that slot and no other).
void orient_clusters(ClusterTree& t, const std::vector<Chart>& charts) {
  const size_t n = t.clusters.size();
  std::vector<std::vector<std::pair<Vec3, double>>> lists(n);
  std::vector<double> rest(n, 0.0);
  // Per cluster, per entry of its list: the entry of its parent's list it went to (-1: the
  // parent's remainder, or no parent). Per chart: its entry in its cluster's list.
  std::vector<std::vector<int32_t>> up(n);
  std::vector<int32_t> chart_entry(charts.size(), -1);
  for (size_t i = n; i-- > 0;) {
    std::vector<std::pair<Vec3, double>>& list = lists[i];
    auto add = [&](const Vec3& normal, double area) -> int32_t {
      if (!(area > 0.0)) return -1;  // a degenerate chart has no normal and sends nothing
      for (size_t e = 0; e < list.size(); ++e)
        if (glm::dot(list[e].first, normal) > 1.0 - 1e-9) {
          list[e].second += area;
          return int32_t(e);
        }
      list.emplace_back(normal, area);
      return int32_t(list.size() - 1);
    };
    for (int k = 0; k < 2; ++k) {
      const int32_t ch = t.clusters[i].child[k];
      if (ch >= 0) {
        const auto& child = lists[size_t(ch)];
        up[size_t(ch)].assign(child.size(), -1);
        for (size_t e = 0; e < child.size(); ++e)
          up[size_t(ch)][e] = add(child[e].first, child[e].second);
        rest[i] += rest[size_t(ch)];
      } else {
        chart_entry[size_t(~ch)] = add(charts[size_t(~ch)].normal, charts[size_t(~ch)].area);
      }
    }
    if (list.size() > kOrientedNormals) {
      std::vector<int32_t> rank(list.size());
      for (size_t e = 0; e < list.size(); ++e) rank[e] = int32_t(e);
      std::stable_sort(rank.begin(), rank.end(), [&](int32_t a, int32_t b) {
        return list[size_t(a)].second > list[size_t(b)].second;
      });
      std::vector<int32_t> renumber(list.size(), -1);
      std::vector<std::pair<Vec3, double>> kept;
      for (size_t r = 0; r < list.size(); ++r) {
        const size_t e = size_t(rank[r]);
        if (r < kOrientedNormals) {
          renumber[e] = int32_t(kept.size());
          kept.push_back(list[e]);
        } else {
          rest[i] += list[e].second;
        }
      }
      list.swap(kept);
      for (int k = 0; k < 2; ++k) {
        const int32_t ch = t.clusters[i].child[k];
        if (ch >= 0) {
          for (int32_t& e : up[size_t(ch)])
            if (e >= 0) e = renumber[size_t(e)];
        } else if (chart_entry[size_t(~ch)] >= 0) {
          chart_entry[size_t(~ch)] = renumber[size_t(chart_entry[size_t(~ch)])];
        }
      }
    }
  }
  t.normal_first.assign(n + 1, 0);
  t.slot_first.assign(n + 1, 0);
  for (size_t i = 0; i < n; ++i) {
    t.normal_first[i + 1] = t.normal_first[i] + uint32_t(lists[i].size());
    t.slot_first[i + 1] = t.normal_first[i + 1] + uint32_t(i + 1);
    for (const auto& [m, a] : lists[i]) {
      t.normal.push_back(m);
      t.normal_area.push_back(a);
      t.slot_area.push_back(a);
    }
    t.slot_area.push_back(rest[i]);
  }
  t.rest_area = std::move(rest);
  // Every chart's slot in each cluster above it, nearest first: its entry while it has one, the
  // remainder once cut from a list (a remainder stays one all the way up).
  t.chart_slot_first.assign(charts.size() + 1, 0);
  t.chart_slot.clear();
  for (size_t c = 0; c < charts.size(); ++c) {
    int32_t entry = chart_entry[c];
    for (int32_t k = t.chart_parent[c]; k >= 0; k = t.clusters[size_t(k)].parent) {
      const uint32_t kept = t.normal_first[size_t(k) + 1] - t.normal_first[size_t(k)];
      t.chart_slot.push_back(t.slot_first[size_t(k)] + (entry >= 0 ? uint32_t(entry) : kept));
      entry = entry >= 0 && t.clusters[size_t(k)].parent >= 0 ? up[size_t(k)][size_t(entry)] : -1;
    }
    t.chart_slot_first[c + 1] = uint32_t(t.chart_slot.size());
  }
}

}  // namespace

ClusterTree build_clusters(const std::vector<Chart>& charts, bool oriented) {
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
  if (oriented && !t.clusters.empty()) orient_clusters(t, charts);
  return t;
}

void mark_emitters(ClusterTree& tree, const std::vector<uint8_t>& chart_emits) {
  tree.emitting.assign(tree.size(), 0);
  for (size_t i = tree.size(); i-- > 0;)
    for (int k = 0; k < 2; ++k) {
      const int32_t ch = tree.clusters[i].child[k];
      tree.emitting[i] |= ch >= 0 ? tree.emitting[size_t(ch)] : chart_emits[size_t(~ch)];
    }
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
