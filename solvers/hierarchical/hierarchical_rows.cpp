#include "solvers/hierarchical/hierarchical_rows.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <span>

#include "formfactor/integrate/point_polygon.h"
#include "solvers/hierarchical/hierarchical_visibility.h"

namespace radlab::hier {

namespace {

struct LeafRow {
  double link_sum = 0.0, row = 0.0;
  uint64_t evaluations = 0, nonfinite = 0;
};

// S_L and T_L of leaf i (geometry of every node in `geom`).
LeafRow leaf_row(const Hierarchy& h, const std::vector<Chart>& charts,
                 const std::vector<NodeGeometry>& geom, size_t i, std::vector<Vec3>& scratch) {
  LeafRow r;
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
  for (int64_t a = int64_t(i); a >= 0; a = h.parent[size_t(a)]) {
    for (uint64_t k = h.first[size_t(a)]; k < h.first[size_t(a) + 1]; ++k) {
      r.link_sum += h.factor[k];
      if (size_t(a) == i) {
        // The leaf's own links: their factor is this rule already (hierarchical_refine.cpp).
        r.row += h.factor[k];
        continue;
      }
      const size_t s = h.source[k];
      const NodeGeometry& g = geom[s];
      point_to_polygon_form_factors(points, chart.normal,
                                    std::span<const Vec3>(g.x, size_t(g.corners)),
                                    charts[h.key[s].chart].normal, value, scratch);
      const double v = double(h.free_rays[k]) / kVisibilityRays;
      double sum = 0.0;
      for (int d = 0; d < 4; ++d) {
        // A point on the source's own plane inside it (coincident back-to-back input) has no
        // defined value; it sees none of the source.
        if (std::isfinite(value[d]))
          sum += w[d] * value[d];
        else
          ++r.nonfinite;
      }
      r.row += v * sum;
      ++r.evaluations;
    }
  }
  return r;
}

}  // namespace

RowStats normalise_rows(Hierarchy& h, const std::vector<Chart>& charts) {
  const size_t n = h.size(), nc = h.chart_first.size() - 1;
  h.row_scale.assign(n, 1.0);
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
  RowStats stats;
  stats.min_link_sum = 1e300;
  for (size_t i = 0; i < n; ++i) {
    if (!h.is_leaf(i)) continue;
    const LeafRow& r = rows[i];
    stats.evaluations += r.evaluations;
    stats.nonfinite += r.nonfinite;
    if (!(r.link_sum > 0.0 && std::isfinite(r.link_sum))) continue;
    const double row = std::min(r.row, 1.0);
    h.row_scale[i] = row / r.link_sum;
    stats.max_link_sum = std::max(stats.max_link_sum, r.link_sum);
    stats.min_link_sum = std::min(stats.min_link_sum, r.link_sum);
    stats.max_row = std::max(stats.max_row, row);
    stats.leaves_above_one += r.link_sum > 1.0 ? 1 : 0;
    stats.max_change = std::max(stats.max_change, std::abs(h.row_scale[i] - 1.0));
  }
  if (stats.min_link_sum > stats.max_link_sum) stats.min_link_sum = 0.0;
  return stats;
}

}  // namespace radlab::hier
