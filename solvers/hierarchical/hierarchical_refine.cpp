#include "solvers/hierarchical/hierarchical_refine.h"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <span>

#include "formfactor/integrate/point_polygon.h"

namespace radlab::hier {

void RefineStats::add(const RefineStats& o) {
  refinement_tests += o.refinement_tests;
  facing_away += o.facing_away;
  visibility_tests += o.visibility_tests;
  inherited_visible += o.inherited_visible;
  occluded += o.occluded;
  degenerate += o.degenerate;
  rays += o.rays;
  pair_evaluations += o.pair_evaluations;
  links_created += o.links_created;
}

namespace {

double lambert(const Vec3& x, const Vec3& n, const NodeGeometry& target, const Vec3& normal) {
  thread_local std::vector<Vec3> scratch;
  return point_to_polygon_form_factor(x, n, std::span<const Vec3>(target.x, size_t(target.corners)),
                                      normal, scratch);
}

int child_count(const NodeGeometry&) {
  return 4;
}

bool usable(const NodeGeometry& g) {
  return g.area > 0.0 && std::isfinite(g.area) && std::isfinite(g.centre.x) &&
         std::isfinite(g.centre.y) && std::isfinite(g.centre.z);
}

}  // namespace

double Refiner::error(const NodeKey& receiver, const NodeKey& source, double estimate) const {
  if (!c_.radiosity) return estimate;
  const Rgb b = c_.radiosity(source);
  const Rgb& rho = c_.chart_reflectance[receiver.chart];
  const double m = std::max({rho.x * b.x, rho.y * b.y, rho.z * b.z});
  return estimate * m / c_.bf_scale;
}

bool Refiner::can_split(const Node& n) const {
  return int(n.key.depth) < kMaxDepth && n.g.area >= c_.min_area;
}

double Refiner::max_over_children(const Node& receiver, const Node& source) const {
  const Chart& chart = charts_[receiver.key.chart];
  const Vec3& m = charts_[source.key.chart].normal;
  double best = 0.0;
  for (int d = 0; d < child_count(receiver.g); ++d)
    best = std::max(best, lambert(receiver.g.child(chart, d).centre, chart.normal, source.g, m));
  return best;
}

double Refiner::transfer(const Node& receiver, const Node& source) const {
  const Chart& chart = charts_[receiver.key.chart];
  const Vec3& n = chart.normal;
  const Vec3& m = charts_[source.key.chart].normal;
  double sum = 0.0;
  for (int d = 0; d < child_count(receiver.g); ++d) {
    const NodeGeometry c = receiver.g.child(chart, d);
    sum += c.area * lambert(c.centre, n, source.g, m);
  }
  return sum / receiver.g.area;
}

void Refiner::split(const Node& p, const Node& q, bool split_q, Known known,
                    std::vector<LinkRecord>& out, RefineStats& stats) const {
  const Node& s = split_q ? q : p;
  const Chart& chart = charts_[s.key.chart];
  for (int d = 0; d < child_count(s.g); ++d) {
    const Node child{s.key.child(d), s.g.child(chart, d)};
    if (split_q)
      refine(p, child, known, out, stats);
    else
      refine(child, q, known, out, stats);
  }
}

void Refiner::refine(const Node& p, const Node& q, Known known, std::vector<LinkRecord>& out,
                     RefineStats& stats) const {
  ++stats.refinement_tests;
  if (!usable(p.g) || !usable(q.g)) {
    // A node of no area (a fan triangle of collinear corners) exchanges no light; its centroid
    // and normal are undefined, so no estimate is made.
    ++stats.degenerate;
    return;
  }
  const Chart& cp = charts_[p.key.chart];
  const Chart& cq = charts_[q.key.chart];
  const PlaneRelation relation = plane_test(p.g, cp.normal, q.g, cq.normal);
  if (relation == PlaneRelation::kAway) {
    ++stats.facing_away;
    return;
  }
  double est_pq = lambert(p.g.centre, cp.normal, q.g, cq.normal);
  double est_qp = lambert(q.g.centre, cq.normal, p.g, cp.normal);
  stats.pair_evaluations += 2;
  const bool cut = relation == PlaneRelation::kCut;
  if (cut) {
    // The centre may lie on the far side of the other's plane while the rest of the node sees
    // it: take the largest of the centre's and the four children's centres' values.
    est_pq = std::max(est_pq, max_over_children(p, q));
    est_qp = std::max(est_qp, max_over_children(q, p));
    stats.pair_evaluations += 2;
  }
  int free = kVisibilityRays;
  if (known == Known::kVisible) {
    ++stats.inherited_visible;
  } else {
    free = visibility_.unblocked(p.g, cp.polygon, p.key, q.g, cq.polygon, q.key, c_.seed);
    ++stats.visibility_tests;
    stats.rays += kVisibilityRays;
  }
  if (free == 0) {
    ++stats.occluded;
    return;
  }
  const bool partial = free < kVisibilityRays;
  const double penalty = partial ? kPartialPenalty : 1.0;
  const double e_pq = penalty * error(p.key, q.key, est_pq);
  const double e_qp = penalty * error(q.key, p.key, est_qp);
  if (std::max(e_pq, e_qp) >= c_.feps) {
    const bool split_q = e_pq >= e_qp;
    if (can_split(split_q ? q : p)) {
      split(p, q, split_q, partial ? Known::kUnknown : Known::kVisible, out, stats);
      return;
    }
  }
  const double v = double(free) / kVisibilityRays;
  LinkRecord link;
  link.p = p.key;
  link.q = q.key;
  link.fpq = v * transfer(p, q);
  link.fqp = v * transfer(q, p);
  link.estimate_pq = float(est_pq);
  link.estimate_qp = float(est_qp);
  link.cls = cut ? LinkClass::kCut : partial ? LinkClass::kPartial : LinkClass::kVisible;
  link.partial = partial;
  link.free_rays = uint8_t(free);
  stats.pair_evaluations += 2;
  ++stats.links_created;
  out.push_back(link);
}

void Refiner::refine_roots(uint32_t a, uint32_t b, std::vector<LinkRecord>& out,
                           RefineStats& stats) const {
  const Node p{{a, 0, 0}, root_geometry(charts_[a])};
  const Node q{{b, 0, 0}, root_geometry(charts_[b])};
  refine(p, q, Known::kUnknown, out, stats);
}

void Refiner::rerefine(const LinkRecord& link, std::vector<LinkRecord>& out,
                       RefineStats& stats) const {
  const double penalty = (link.partial || link.cls == LinkClass::kCut) ? kPartialPenalty : 1.0;
  const double e_pq = penalty * error(link.p, link.q, link.estimate_pq);
  const double e_qp = penalty * error(link.q, link.p, link.estimate_qp);
  if (std::max(e_pq, e_qp) < c_.feps) {
    out.push_back(link);
    return;
  }
  const Node p{link.p, node_geometry(charts_, link.p)};
  const Node q{link.q, node_geometry(charts_, link.q)};
  const bool split_q = e_pq >= e_qp;
  if (!can_split(split_q ? q : p)) {
    out.push_back(link);
    return;
  }
  split(p, q, split_q, link.partial ? Known::kUnknown : Known::kVisible, out, stats);
}

}  // namespace radlab::hier
