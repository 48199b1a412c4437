#include "solvers/hierarchical/hierarchical_refine.h"

#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <numbers>
#include <span>

#include "core/random.h"
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
  // A cluster reflects what its charts do: bounded by 1.
  const Rgb rho = receiver.is_cluster() ? Rgb(1.0) : c_.chart_reflectance[receiver.chart];
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
  if (link.p.is_cluster() || link.q.is_cluster()) {
    const Node p = node_of(link.p), q = node_of(link.q);
    open(p, q, open_q(p, q, e_pq, e_qp), Known::kUnknown, out, stats);
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

// ---- Clusters ----

std::vector<std::pair<NodeKey, NodeKey>> Refiner::cluster_frontier(const ClusterTree& tree) {
  std::vector<std::pair<NodeKey, NodeKey>> pairs;
  pairs.reserve(tree.size());
  auto key = [](int32_t child) {
    return child >= 0 ? NodeKey::cluster(uint32_t(child)) : NodeKey{uint32_t(~child), 0, 0};
  };
  for (const Cluster& c : tree.clusters) pairs.emplace_back(key(c.child[0]), key(c.child[1]));
  return pairs;
}

Refiner::Node Refiner::node_of(const NodeKey& key) const {
  if (key.is_cluster()) return {key, NodeGeometry{}};
  return {key, node_geometry(charts_, key)};
}

void Refiner::refine_keys(const NodeKey& a, const NodeKey& b, std::vector<LinkRecord>& out,
                          RefineStats& stats) const {
  refine_any(node_of(a), node_of(b), Known::kUnknown, out, stats);
}

void Refiner::refine_any(const Node& p, const Node& q, Known known, std::vector<LinkRecord>& out,
                         RefineStats& stats) const {
  if (p.key.is_cluster() || q.key.is_cluster())
    refine_clustered(p, q, known, out, stats);
  else if (p.key.chart > q.key.chart)
    // Chart roots in refine_roots' order (a < b), so that the pair's rays, hence its links, are
    // the unclustered run's.
    refine(q, p, known, out, stats);
  else
    refine(p, q, known, out, stats);
}

Vec3 Refiner::centre(const Node& n) const {
  return n.key.is_cluster() ? clusters_->clusters[n.key.chart].centre : n.g.centre;
}

double Refiner::radius(const Node& n) const {
  if (n.key.is_cluster()) return clusters_->clusters[n.key.chart].radius;
  double r2 = 0.0;
  for (int k = 0; k < n.g.corners; ++k)
    r2 = std::max(r2, glm::dot(n.g.x[k] - n.g.centre, n.g.x[k] - n.g.centre));
  return std::sqrt(r2);
}

double Refiner::node_area(const Node& n) const {
  return n.key.is_cluster() ? clusters_->clusters[n.key.chart].area : n.g.area;
}

double Refiner::bound_estimate(const Node& receiver, const Node& source) const {
  const double separation = glm::length(centre(receiver) - centre(source));
  const double d = std::max(0.0, separation - radius(receiver) - radius(source));
  if (!clusters_->oriented()) {
    const double projected = source.key.is_cluster() ? 0.25 * node_area(source) : node_area(source);
    return projected / (std::numbers::pi * d * d + projected);
  }
  // Oriented: every direction from a point of the source's sphere to one of the receiver's lies
  // within `spread` of the line of centres w, so the source's projected area toward the receiver
  // and the receiver's cosine (or its projected area per unit area) are bounded over that cone.
  const double reach = radius(receiver) + radius(source);
  const bool apart = separation > reach;
  const double spread = apart ? std::asin(reach / separation) : std::numbers::pi;
  const Vec3 w = apart ? (centre(receiver) - centre(source)) / separation : Vec3(0.0, 0.0, 1.0);
  auto facing = [&](const Node& n, const Vec3& towards) {
    if (n.key.is_cluster())
      return clusters_->projected_area_bound(n.key.chart, towards, spread) / node_area(n);
    const double angle =
        std::acos(std::clamp(glm::dot(charts_[n.key.chart].normal, towards), -1.0, 1.0)) - spread;
    return angle < 0.5 * std::numbers::pi ? std::cos(std::max(angle, 0.0)) : 0.0;
  };
  const double projected = node_area(source) * facing(source, w);
  const double received = std::min(1.0, facing(receiver, -w));
  return projected > 0.0 ? received * projected / (std::numbers::pi * d * d + projected) : 0.0;
}

bool Refiner::behind(const Node& surface, const Node& cluster) const {
  // Every corner of the cluster's box on or behind the surface's plane: none of its charts can
  // exchange light with it.
  const Cluster& c = clusters_->clusters[cluster.key.chart];
  const Vec3& n = charts_[surface.key.chart].normal;
  const double tol = 1e-9 * std::sqrt(std::max(surface.g.area, c.area));
  for (int corner = 0; corner < 8; ++corner) {
    const Vec3 x(corner & 1 ? c.hi.x : c.lo.x, corner & 2 ? c.hi.y : c.lo.y,
                 corner & 4 ? c.hi.z : c.lo.z);
    if (glm::dot(x - surface.g.x[0], n) > tol) return false;
  }
  return true;
}

int Refiner::cluster_visibility(const Node& p, const Node& q, int& facing) const {
  Pcg32 rng(hash_combine(hash_combine(c_.seed, p.key.hash()), q.key.hash()));
  Vec3 x[kVisibilityRays], y[kVisibilityRays];
  uint32_t px[kVisibilityRays], py[kVisibilityRays];
  facing = 0;
  for (int k = 0; k < kVisibilityRays; ++k) {
    const double a0 = rng.next_double(), a1 = rng.next_double(), a2 = rng.next_double();
    const double b0 = rng.next_double(), b1 = rng.next_double(), b2 = rng.next_double();
    auto point = [&](const Node& n, int cell, double u0, double u1, double u2, uint32_t& poly) {
      if (n.key.is_cluster())
        return clusters_->sample(charts_, n.key.chart, cell, kVisibilityRays, u0, u1, u2, poly);
      poly = charts_[n.key.chart].polygon;
      return stratum_point(n.g, cell, u1, u2);
    };
    uint32_t pa = 0, pb = 0;
    const Vec3 a = point(p, k, a0, a1, a2, pa);
    const Vec3 b = point(q, magic_partner(k), b0, b1, b2, pb);
    // Only segments leaving both ends' front sides carry light: one that starts behind its own
    // polygon (a point on a desk's far side, facing away) runs through what lies behind it and
    // would count as blocked, though no light was ever to pass there.
    if (!(glm::dot(polygon_normal_[pa], b - a) > 0.0 && glm::dot(polygon_normal_[pb], a - b) > 0.0))
      continue;
    x[facing] = a;
    y[facing] = b;
    px[facing] = pa;
    py[facing] = pb;
    ++facing;
  }
  return visibility_.unblocked_segments(x, y, px, py, facing);
}

double Refiner::surface_from_cluster(const Node& surface, const Node& cluster) const {
  // The isotropic kernel by the surface node's 2 x 2 rule (its children's centres, area
  // weighted).
  const Chart& chart = charts_[surface.key.chart];
  double sum = 0.0;
  for (int d = 0; d < child_count(surface.g); ++d) {
    const NodeGeometry g = surface.g.child(chart, d);
    sum += g.area * clusters_->point_factor(cluster.key.chart, g.centre, chart.normal);
  }
  return sum / surface.g.area;
}

bool Refiner::open_q(const Node& p, const Node& q, double e_pq, double e_qp) const {
  const bool pc = p.key.is_cluster(), qc = q.key.is_cluster();
  if (pc != qc) return qc;
  if (pc && qc) {
    const double rp = radius(p), rq = radius(q);
    if (rp != rq) return rq > rp;
  }
  return e_pq >= e_qp;
}

uint32_t Refiner::chart_count(const Node& n) const {
  return n.key.is_cluster() ? clusters_->clusters[n.key.chart].count : 1u;
}

void Refiner::open(const Node& p, const Node& q, bool open_q_side, Known known,
                   std::vector<LinkRecord>& out, RefineStats& stats) const {
  // open_q() names the cluster end whenever there is one, so `s` is a cluster.
  const Node& s = open_q_side ? q : p;
  const Cluster& c = clusters_->clusters[s.key.chart];
  Node child[2];
  for (int k = 0; k < 2; ++k)
    child[k] = node_of(c.child[k] >= 0 ? NodeKey::cluster(uint32_t(c.child[k]))
                                       : NodeKey{uint32_t(~c.child[k]), 0, 0});
  auto refine_child = [&](int k, std::vector<LinkRecord>& into, RefineStats& st) {
    if (open_q_side)
      refine_any(p, child[k], known, into, st);
    else
      refine_any(child[k], q, known, into, st);
  };
  if (uint64_t(chart_count(p)) * chart_count(q) < kParallelOpen) {
    refine_child(0, out, stats);
    refine_child(1, out, stats);
    return;
  }
  // A large pair: its two halves as two tasks (the root cluster's pair of children alone was a
  // third of hosp.mgf's refinement, on one thread). The second half's links go to their own list,
  // appended after the first's: the same links in the same order as one thread makes them.
  std::vector<LinkRecord> second;
  RefineStats second_stats;
  tbb::parallel_invoke([&] { refine_child(0, out, stats); },
                       [&] { refine_child(1, second, second_stats); });
  out.insert(out.end(), second.begin(), second.end());
  stats.add(second_stats);
}

void Refiner::refine_clustered(const Node& p, const Node& q, Known known,
                               std::vector<LinkRecord>& out, RefineStats& stats) const {
  if (p.key == q.key) {
    // A cluster with itself: its children's self pairs and their pair (a chart's self pair
    // carries nothing).
    const Cluster& c = clusters_->clusters[p.key.chart];
    Node child[2];
    for (int k = 0; k < 2; ++k)
      child[k] = node_of(c.child[k] >= 0 ? NodeKey::cluster(uint32_t(c.child[k]))
                                         : NodeKey{uint32_t(~c.child[k]), 0, 0});
    if (child[0].key.is_cluster()) refine_clustered(child[0], child[0], known, out, stats);
    refine_any(child[0], child[1], Known::kUnknown, out, stats);
    if (child[1].key.is_cluster()) refine_clustered(child[1], child[1], known, out, stats);
    return;
  }
  ++stats.refinement_tests;
  const bool pc = p.key.is_cluster(), qc = q.key.is_cluster();
  if ((!pc && !usable(p.g)) || (!qc && !usable(q.g)) || !(node_area(p) > 0.0) ||
      !(node_area(q) > 0.0)) {
    ++stats.degenerate;
    return;
  }
  if ((!pc && behind(p, q)) || (!qc && behind(q, p))) {
    ++stats.facing_away;
    return;
  }
  const double est_pq = bound_estimate(p, q), est_qp = bound_estimate(q, p);
  stats.pair_evaluations += 2;
  // V: the unblocked fraction of the segments that leave both ends' front sides; fewer than 8
  // of 16 facing make the pair partly visible (the estimate x4).
  int facing = 0;
  const int free = cluster_visibility(p, q, facing);
  ++stats.visibility_tests;
  stats.rays += uint64_t(facing);
  const bool partial = free < facing || facing < kVisibilityRays / 2 || free == 0;
  const double penalty = partial ? kPartialPenalty : 1.0;
  const double e_pq = penalty * error(p.key, q.key, est_pq);
  const double e_qp = penalty * error(q.key, p.key, est_qp);
  // Every facing segment blocked: V is small but not shown to be 0 (two clusters on storeys
  // above one another, blocked by the slab on every sample, see each other through the atrium;
  // dropping every such pair doubled the building's rms error). With m facing segments all
  // blocked, 1 / (m + 2) (Laplace's rule of succession) stands for V: the pair is dropped when
  // the estimate times that is below feps, else opened. Oriented clusters treat such a pair as
  // a partly visible one instead (dropped only when kPartialPenalty times the estimate is below
  // feps, else opened down to pairs whose own rays decide): 16 segments between two clusters
  // sample few of their members' pairs, and the light of the pairs dropped by Laplace's rule
  // was hosp.mgf's largest clustered loss (docs/solvers.md, "Clustering measured").
  const double e_max = std::max(error(p.key, q.key, est_pq), error(q.key, p.key, est_qp));
  const double blocked_bound =
      clusters_->oriented() ? kPartialPenalty * e_max : e_max / double(facing + 2);
  if (free == 0 && blocked_bound < c_.feps) {
    ++(facing > 0 ? stats.occluded : stats.facing_away);
    return;
  }
  // A cluster holding a lamp is opened until the lamp is a surface of its own (oriented): as a
  // cluster's light its emission would be spread over the cluster's faces and sent from its
  // centre, moving the direct light, which refinement on F alone does not see.
  const bool p_emits = pc && !clusters_->emitting.empty() && clusters_->emitting[p.key.chart];
  const bool q_emits = qc && !clusters_->emitting.empty() && clusters_->emitting[q.key.chart];
  if (p_emits || q_emits) {
    open(p, q, q_emits && (!p_emits || radius(q) >= radius(p)), Known::kUnknown, out, stats);
    return;
  }
  if (std::max(e_pq, e_qp) >= c_.feps) {
    // The children's pairs are other pairs of surfaces, not parts of this one: 16 free segments
    // between two clusters say nothing of every pair of their members, so nothing is inherited.
    open(p, q, open_q(p, q, e_pq, e_qp), Known::kUnknown, out, stats);
    return;
  }
  // V in sixteenths, as a quadtree link stores it (hierarchical_rows.h reads it back).
  const int sixteenths = facing > 0 ? int(std::lround(double(kVisibilityRays) * free / facing)) : 0;
  const double v = double(sixteenths) / kVisibilityRays;
  const double ap = node_area(p), aq = node_area(q);
  LinkRecord link;
  link.p = p.key;
  link.q = q.key;
  if (pc && qc && clusters_->oriented()) {
    // Each end's projected area towards the other: A_p F_pq = A_q F_qp = V P_p P_q / (π r²).
    const Vec3 d = centre(q) - centre(p);
    const double r2 = glm::dot(d, d);
    const Vec3 u = d / std::sqrt(r2);
    const double exchange = v * clusters_->projected_area(p.key.chart, u) *
                            clusters_->projected_area(q.key.chart, -u) / (std::numbers::pi * r2);
    link.fpq = exchange / ap;
    link.fqp = exchange / aq;
  } else if (pc && qc) {
    const Vec3 d = centre(p) - centre(q);
    const double r2 = glm::dot(d, d);
    link.fpq = v * aq / (16.0 * std::numbers::pi * r2);
    link.fqp = v * ap / (16.0 * std::numbers::pi * r2);
  } else if (qc) {
    link.fpq = v * surface_from_cluster(p, q);
    link.fqp = link.fpq * ap / aq;
  } else {
    link.fqp = v * surface_from_cluster(q, p);
    link.fpq = link.fqp * aq / ap;
  }
  link.estimate_pq = float(est_pq);
  link.estimate_qp = float(est_qp);
  link.cls = partial ? LinkClass::kPartial : LinkClass::kVisible;
  link.partial = partial;
  link.free_rays = uint8_t(sixteenths);
  stats.pair_evaluations += 2;
  ++stats.links_created;
  out.push_back(link);
}

}  // namespace radlab::hier
