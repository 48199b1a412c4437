#include "solvers/hierarchical/hierarchical_rows.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <span>

#include "formfactor/integrate/point_polygon.h"
#include "solvers/hierarchical/hierarchical_visibility.h"

namespace radlab::hier {

namespace {

struct LeafRow {
  double link_sum = 0.0, row = 0.0;
  uint64_t evaluations = 0, nonfinite = 0;
  // The emitted light: as the links gather it (P), and as the leaf receives it (D, before the
  // non-point-like part is scaled by alpha); the point-like links' two values summed.
  double gathered_emission[3] = {0.0, 0.0, 0.0};
  double point_emission[3] = {0.0, 0.0, 0.0}, other_emission[3] = {0.0, 0.0, 0.0};
  double point_source_side = 0.0, point_leaf_side = 0.0;
  // With oriented clusters: the links at clusters on the leaf's path, as (CSR entry, the leaf's
  // own factor), in path order.
  std::vector<std::pair<uint32_t, double>> own_links;
};

// Sum over a node's 2 x 2 rule (its children's centres, area weighted) of the point-to-polygon
// factor from each point to `target`; the area-weighted sum, not the mean. Non-finite values
// (a point in the target's plane) count as 0.
double rule_to_polygon(const Chart& from_chart, const NodeGeometry& from, const Vec3& to_normal,
                       const NodeGeometry& target, std::vector<Vec3>& scratch,
                       uint64_t& nonfinite) {
  double px[4], py[4], pz[4], a[4];
  for (int d = 0; d < 4; ++d) {
    const NodeGeometry c = from.child(from_chart, d);
    px[d] = c.centre.x;
    py[d] = c.centre.y;
    pz[d] = c.centre.z;
    a[d] = c.area;
  }
  const PointBatch points{px, py, pz, 4};
  double value[4];
  point_to_polygon_form_factors(points, from_chart.normal,
                                std::span<const Vec3>(target.x, size_t(target.corners)), to_normal,
                                value, scratch);
  double sum = 0.0;
  for (int d = 0; d < 4; ++d) {
    if (std::isfinite(value[d]))
      sum += a[d] * value[d];
    else
      ++nonfinite;
  }
  return sum;
}

// The unit vector along d; zero for d = 0 (slot_share and slot_directional then fall back to
// the cluster's area average).
Vec3 unit(const Vec3& d) {
  const double length = std::sqrt(glm::dot(d, d));
  return length > 0.0 ? d / length : Vec3(0.0);
}

// S_L and T_L of leaf i (geometry of every node in `geom`).
LeafRow leaf_row(const Hierarchy& h, const std::vector<Chart>& charts,
                 const std::vector<NodeGeometry>& geom, size_t i, std::vector<Vec3>& scratch) {
  LeafRow r;
  // A leaf of no area (a fan triangle of collinear corners) has no rule; it is never linked, but
  // with clusters its path holds their links (it keeps row_scale 1).
  if (!(geom[i].area > 0.0)) return r;
  const Chart& chart = charts[h.key[i].chart];
  // The 2 x 2 rule over the leaf: its children's centres, weighted by their areas.
  double px[4], py[4], pz[4], w[4];
  for (int d = 0; d < 4; ++d) {
    const NodeGeometry c = geom[i].child(chart, d);
    px[d] = c.centre.x;
    py[d] = c.centre.y;
    pz[d] = c.centre.z;
    w[d] = c.area / geom[i].area;
  }
  const PointBatch points{px, py, pz, 4};
  double value[4];
  const size_t n = h.size();
  for (int64_t a = int64_t(i); a >= 0; a = h.parent[size_t(a)]) {
    // With oriented clusters (Hierarchy::slots) the leaf gathers the links at the clusters on
    // its path itself, by its own rule (Hierarchy::leaf_link_*): their leaf-side values are both
    // what it gathers and its row's part.
    const bool own = h.slots && size_t(a) < h.clusters;
    for (uint64_t k = h.first[size_t(a)]; k < h.first[size_t(a) + 1]; ++k) {
      const size_t s = h.source[k];
      const double v = double(h.free_rays[k]) / kVisibilityRays;
      double leaf_side = h.factor[k];  // the leaf's own links: their factor is this rule already
      if (size_t(a) != i && s < h.clusters) {
        // A cluster source: its kernel (isotropic or oriented) at the leaf's four points
        // (hierarchical_clusters.h).
        double sum = 0.0;
        for (int d = 0; d < 4; ++d)
          sum += w[d] * (h.cluster_tree->oriented()
                             ? h.cluster_tree->point_factor(uint32_t(s), {px[d], py[d], pz[d]},
                                                            chart.normal)
                             : isotropic_point_factor({px[d], py[d], pz[d]}, chart.normal,
                                                      h.cluster_centre[s], h.area[s]));
        leaf_side = v * sum;
        ++r.evaluations;
      } else if (size_t(a) != i) {
        const NodeGeometry& g = geom[s];
        point_to_polygon_form_factors(points, chart.normal,
                                      std::span<const Vec3>(g.x, size_t(g.corners)),
                                      charts[h.key[s].chart].normal, value, scratch);
        double sum = 0.0;
        for (int d = 0; d < 4; ++d) {
          // A point on the source's own plane inside it (coincident back-to-back input) has no
          // defined value; it sees none of the source.
          if (std::isfinite(value[d]))
            sum += w[d] * value[d];
          else
            ++r.nonfinite;
        }
        leaf_side = v * sum;
        ++r.evaluations;
      }
      const double factor = own ? leaf_side : h.factor[k];
      r.link_sum += factor;
      if (own) r.own_links.emplace_back(uint32_t(k), leaf_side);
      r.row += leaf_side;
      // The source's emission as the gather reads it: a cluster with slots toward the link's
      // receiver.
      double emission[3] = {0.0, 0.0, 0.0};
      if (h.slots && s < h.clusters)
        slot_directional(h, h.slot_emission, uint32_t(s),
                         unit(h.node_centre[size_t(a)] - h.node_centre[s]), emission);
      else
        for (int c = 0; c < h.channels; ++c) emission[c] = h.emission[size_t(c) * n + s];
      bool emits = false;
      for (int c = 0; c < h.channels; ++c) {
        r.gathered_emission[c] += factor * emission[c];
        emits = emits || emission[c] > 0.0;
      }
      if (!emits) continue;
      if (s >= h.clusters && geom[s].area < geom[i].area) {
        // A point-like source (smaller than the leaf): its light is received by the source-side
        // rule, exact over the leaf's polygon, so the leaves it reaches receive its power
        // whatever their size (the lamp's points see a partition of the room: sum 1).
        const double source_side = v *
                                   rule_to_polygon(charts[h.key[s].chart], geom[s], chart.normal,
                                                   geom[i], scratch, r.nonfinite) /
                                   geom[i].area;
        ++r.evaluations;
        r.point_source_side += source_side;
        r.point_leaf_side += leaf_side;
        for (int c = 0; c < h.channels; ++c) r.point_emission[c] += source_side * emission[c];
      } else {
        for (int c = 0; c < h.channels; ++c) r.other_emission[c] += leaf_side * emission[c];
      }
    }
  }
  return r;
}

// What every leaf gathers through its path's links when leaf j sends the value v_j (interior
// nodes send the area average of their leaves', as pull makes B): Σ over links k on L's path of
// factor_k × (pulled v at source_k). Parents precede their children in index order.
std::vector<double> path_gather(const Hierarchy& h, const std::vector<double>& leaf_value) {
  const size_t n = h.size();
  std::vector<double> v(n, 0.0), g(n, 0.0);
  for (size_t i = n; i-- > 0;) {
    if (h.is_leaf(i)) {
      v[i] = leaf_value[i];
      continue;
    }
    double sum = 0.0, area = 0.0;
    for (int32_t k : h.child[i]) {
      if (k < 0) continue;
      area += h.area[size_t(k)];
      sum += h.area[size_t(k)] * v[size_t(k)];
    }
    v[i] = area > 0.0 ? sum / area : 0.0;
  }
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 256),
                    [&](const tbb::blocked_range<size_t>& r) {
                      for (size_t i = r.begin(); i < r.end(); ++i) {
                        double sum = 0.0;
                        for (uint64_t k = h.first[i]; k < h.first[i + 1]; ++k)
                          sum += h.factor[k] * v[h.source[k]];
                        g[i] = sum;
                      }
                    });
  for (size_t i = 0; i < n; ++i)
    if (h.parent[i] >= 0) g[i] += g[size_t(h.parent[i])];
  return g;
}

// Per leaf j, Σ_L A_L row_scale_L K_Lj / A_j: the power j's light delivers per unit (before j's
// own send_scale). Links from a source node spread its light over its leaves in proportion to
// area, so c_j = Σ over j's path s of acc_s / A_s, acc_s = Σ over links from s of f × W_receiver,
// W_a = Σ over leaves L under a of A_L row_scale_L.
std::vector<double> raw_columns(const Hierarchy& h) {
  const size_t n = h.size();
  std::vector<double> weight(n, 0.0), acc(n, 0.0), column(n, 0.0);
  for (size_t i = n; i-- > 0;) {
    if (h.is_leaf(i)) weight[i] = h.area[i] * h.row_scale[i];
    if (h.parent[i] >= 0) weight[size_t(h.parent[i])] += weight[i];
  }
  for (size_t a = 0; a < n; ++a)
    for (uint64_t k = h.first[a]; k < h.first[a + 1]; ++k)
      acc[h.source[k]] += h.factor[k] * weight[a];
  for (size_t i = 0; i < n; ++i)
    column[i] = (h.area[i] > 0.0 ? acc[i] / h.area[i] : 0.0) +
                (h.parent[i] >= 0 ? column[size_t(h.parent[i])] : 0.0);
  return column;
}

// The reflected light's column sums after normalisation: c_j, the fraction of leaf j's light
// that the normalised gathers deliver, per unit of j's power (Σ_L A_L row_scale_L K_Lj / A_j,
// times j's send_scale with column balance); their range and area-weighted mean |c - 1|.
void column_sums(const Hierarchy& h, RowStats& stats) {
  const std::vector<double> column = raw_columns(h);
  double lo = 1e300, hi = -1e300, deviation = 0.0, area = 0.0;
  for (size_t i = 0; i < h.size(); ++i) {
    if (!h.is_leaf(i) || !(h.area[i] > 0.0)) continue;
    const double sent = column[i] * (h.balanced() ? h.send_scale[i] : 1.0);
    lo = std::min(lo, sent);
    hi = std::max(hi, sent);
    deviation += h.area[i] * std::abs(sent - 1.0);
    area += h.area[i];
  }
  stats.min_column = lo <= hi ? lo : 0.0;
  stats.max_column = lo <= hi ? hi : 0.0;
  stats.mean_column_deviation = area > 0.0 ? deviation / area : 0.0;
}

// Column balance (rows=balanced): the row targets r_L = min(T_L, 1) as before, and column
// targets the same numbers, because by reciprocity the power a leaf's light delivers is its own
// row sum (Σ_L A_L F_Lj = A_j Σ_L F_jL). Alternating scalings (Sinkhorn–Knopp) of the leaves'
// gathers (row_scale) and of the reflected light they send (send_scale) meet both; the totals
// agree (Σ A r on both sides), so the alternation converges where every leaf gathers from and
// sends to some other. Stops at 1e-9 relative or 200 rounds.
void balance_columns(Hierarchy& h, const std::vector<double>& target,
                     const std::vector<char>& active, RowStats& stats) {
  const size_t n = h.size();
  h.send_scale.assign(n, 1.0);
  std::vector<double>& t = h.send_scale;
  for (int round = 0; round < 200; ++round) {
    const std::vector<double> g = path_gather(h, t);
    for (size_t i = 0; i < n; ++i)
      if (active[i] && g[i] > 0.0) h.row_scale[i] = target[i] / g[i];
    const std::vector<double> c = raw_columns(h);
    double worst = 0.0;
    for (size_t j = 0; j < n; ++j) {
      if (!active[j] || !(c[j] > 0.0) || !(target[j] > 0.0)) continue;
      worst = std::max(worst, std::abs(t[j] * c[j] / target[j] - 1.0));
      t[j] = target[j] / c[j];
    }
    stats.balance_rounds = round + 1;
    stats.balance_residual = worst;
    if (worst < 1e-9) break;
  }
  // The last rows against the last t: rows exact, columns within balance_residual.
  const std::vector<double> g = path_gather(h, t);
  for (size_t i = 0; i < n; ++i)
    if (active[i] && g[i] > 0.0) h.row_scale[i] = target[i] / g[i];
  h.S.assign(h.B.size(), 0.0);
  refresh_sent(h, 0, n);
}

}  // namespace

RowStats normalise_rows(Hierarchy& h, const std::vector<Chart>& charts, bool balance) {
  const size_t n = h.size(), nc = h.chart_first.size() - 1;
  h.row_scale.assign(n, 1.0);
  h.row_offset.assign(size_t(h.channels) * n, 0.0);
  // Node geometry, parents before children (depth-first order within each chart).
  std::vector<NodeGeometry> geom(n);
  tbb::parallel_for(
      tbb::blocked_range<size_t>(0, nc, 16), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t c = r.begin(); c < r.end(); ++c)
          for (size_t i = h.chart_first[c]; i < h.chart_first[c + 1]; ++i)
            geom[i] = h.key[i].depth == 0 ? root_geometry(charts[c])
                                          : geom[size_t(h.parent[i])].child(
                                                charts[c], h.key[i].digit(h.key[i].depth));
      });
  std::vector<LeafRow> rows(n);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 64), [&](const tbb::blocked_range<size_t>& r) {
    std::vector<Vec3> scratch;
    for (size_t i = r.begin(); i < r.end(); ++i)
      if (h.is_leaf(i)) rows[i] = leaf_row(h, charts, geom, i, scratch);
  });
  if (h.slots) {
    // The leaves' own gathers of their clusters' links (Hierarchy::leaf_link_*), in node order.
    h.leaf_link_first.assign(n + 1, 0);
    for (size_t i = 0; i < n; ++i)
      h.leaf_link_first[i + 1] = h.leaf_link_first[i] + rows[i].own_links.size();
    h.leaf_link_entry.resize(h.leaf_link_first[n]);
    h.leaf_link_factor.resize(h.leaf_link_first[n]);
    h.link_value.assign(size_t(h.channels) * h.first[h.clusters], 0.0);
    for (size_t i = 0; i < n; ++i) {
      uint64_t at = h.leaf_link_first[i];
      for (const auto& [entry, factor] : rows[i].own_links) {
        h.leaf_link_entry[at] = entry;
        h.leaf_link_factor[at++] = factor;
      }
      std::vector<std::pair<uint32_t, double>>().swap(rows[i].own_links);
    }
  }
  RowStats stats;
  stats.min_link_sum = 1e300;
  std::vector<double> target(n, 0.0);
  std::vector<char> active(n, 0);
  for (size_t i = 0; i < n; ++i) {
    if (!h.is_leaf(i)) continue;
    const LeafRow& r = rows[i];
    stats.evaluations += r.evaluations;
    stats.nonfinite += r.nonfinite;
    if (!(r.link_sum > 0.0 && std::isfinite(r.link_sum))) continue;
    const double row = std::min(r.row, 1.0);
    h.row_scale[i] = row / r.link_sum;
    target[i] = row;
    active[i] = 1;
    stats.max_link_sum = std::max(stats.max_link_sum, r.link_sum);
    stats.min_link_sum = std::min(stats.min_link_sum, r.link_sum);
    stats.max_row = std::max(stats.max_row, row);
    stats.leaves_above_one += r.link_sum > 1.0 ? 1 : 0;
    stats.max_change = std::max(stats.max_change, std::abs(h.row_scale[i] - 1.0));
  }
  if (stats.min_link_sum > stats.max_link_sum) stats.min_link_sum = 0.0;
  if (balance) balance_columns(h, target, active, stats);
  // The emitted light's row, once the row scales are final: the point-like links' source-side
  // values, the rest's leaf-side values scaled so the whole row is `row` again (a furnace's
  // uniform E still gives E row); it replaces what the scaled gather holds of the emitted light.
  for (size_t i = 0; i < n; ++i) {
    if (!active[i]) continue;
    const LeafRow& r = rows[i];
    const double rest = r.row - r.point_leaf_side;
    const double alpha = rest > 0.0 ? std::max(0.0, target[i] - r.point_source_side) / rest : 1.0;
    for (int c = 0; c < h.channels; ++c)
      h.row_offset[size_t(c) * n + i] = r.point_emission[c] + alpha * r.other_emission[c] -
                                        h.row_scale[i] * r.gathered_emission[c];
  }
  column_sums(h, stats);
  return stats;
}

}  // namespace radlab::hier
