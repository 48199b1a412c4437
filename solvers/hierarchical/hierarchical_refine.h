// Link refinement of hierarchical radiosity: Refine(p, q, feps, aeps) of Hanrahan, Salzman &
// Aupperle 1991 (§3), with their visibility coherence (§4), BF refinement and multigridding
// (§5.2).
//
// Estimate: the unoccluded form factor from the centre of one node to the other node, by
// Lambert's exact point-to-polygon formula (formfactor/integrate/point_polygon.h), both ways. The
// paper names a disk or bounding-sphere solid angle; the Lambert value costs about the same, is
// exact for the differential area at the centre (so it already contains both nodes' orientations,
// which a disk of the same area facing the point ignores), and its error against the area-to-area
// form factor is O((r/R)^2) relative, the same order the paper's analysis uses. Where one node is
// cut by the other's plane the centre may see none of the other node while the rest of it does, so
// the estimate is then the larger of the centre value and the facing disk's A/(pi R^2 + A).
//
// Link when both estimates (times B_q rho_p / B_scale under BF refinement, and times
// kPartialPenalty for partially visible or plane-cut pairs, whose visibility estimate is less
// certain: the paper's larger error at shadow boundaries) are below feps; else split the node
// seen the larger (the one with the larger estimate from the other) if its area is at least
// aeps and its depth below kMaxDepth, else link anyway.
//
// A link's transfer factor: V times the mean of the point-to-polygon form factor over the
// centres of the receiving node's four children (a 2 x 2 rule: where a node's own plane cuts the
// other, it sees part of it, which the centre alone can miss), each way. V is the unblocked
// fraction of 16 rays (hierarchical_visibility.h); totally occluded pairs are neither linked nor
// refined; a fully visible pair's descendants inherit V = 1 without rays.
//
// Clusters (hierarchical_clusters.h; `clustering=isotropic`): refinement starts from the root
// cluster linked to itself. A cluster's link to itself is always opened (its members are at
// distance 0 from one another) into its children's pairs, so the first pass refines the pair of
// the two children of every cluster (n - 1 pairs for n charts, made in preorder by
// cluster_frontier). A pair with a cluster end is estimated by the isotropic kernel's bound over
// the two bounding spheres: from receiver R, a source S of projected area P (A/4 for a cluster,
// A for a surface node, whose orientation is not used) at nearest approach d = max(0, |c_R - c_S|
// - r_R - r_S) has F <= P / (pi d^2 + P) (the coaxial disk's value: 1 when the spheres meet).
// Oracle as above (both estimates below feps, x4 when partly visible); otherwise the cluster is
// opened, clusters before polygons (of two clusters, the larger sphere). Visibility: 16 segments
// between points of the two ends (a cluster's by area over its charts, stratified, hits on the
// segment's own two polygons ignored); a surface node facing away from a cluster's whole box is
// dropped by the plane test. Transfer factors: the isotropic kernels (hierarchical_clusters.h),
// a surface end by its 2 x 2 rule, the other way by reciprocity, times V.
//
// Oriented clusters (`clustering=oriented`): the kernels take each cluster's projected area
// toward the other end (ClusterTree::projected_area), and the estimate bounds the oriented
// kernel over the two spheres: with w the line of centres and `spread` = asin((r_R + r_S) / D)
// the half-angle of every direction between them, the source's projected area is bounded by
// ClusterTree::projected_area_bound (a surface: A cos(max(θ - spread, 0))), the receiver's
// factor likewise (a cluster's bound over its area, a surface's cosine), and
// F <= received * P / (π d² + P). An upper bound of the polygons' exact projected areas over the
// cone (the remainder past the normal list counted whole), not of visibility. A pair of
// clusters whose every facing segment is blocked is dropped only when kPartialPenalty times its
// estimate is below feps (isotropic: the estimate over m + 2, Laplace's rule), else opened.
//
// Work charged: 2 element-pair form factors per refinement test (the two estimates) and 2 per
// link (its two transfer factors).
#pragma once

#include <cstdint>
#include <functional>
#include <utility>
#include <vector>

#include "solvers/hierarchical/hierarchical_clusters.h"
#include "solvers/hierarchical/hierarchical_tree.h"
#include "solvers/hierarchical/hierarchical_visibility.h"

namespace radlab::hier {

enum class LinkClass : uint8_t { kVisible = 0, kPartial = 1, kCut = 2 };

// A link between nodes p and q: p gathers fpq * B_q, q gathers fqp * B_p.
struct LinkRecord {
  NodeKey p, q;
  double fpq = 0.0, fqp = 0.0;             // transfer factors, visibility included
  float estimate_pq = 0, estimate_qp = 0;  // unoccluded estimates (the refinement oracle)
  LinkClass cls = LinkClass::kVisible;
  bool partial = false;    // some rays blocked (a cut pair can be partial too)
  uint8_t free_rays = 16;  // unblocked rays of kVisibilityRays: V = free_rays / 16
};

// Counters of the paper's Table 1.
struct RefineStats {
  uint64_t refinement_tests = 0;   // Refine calls that evaluated estimates
  uint64_t facing_away = 0;        // pairs dropped by the plane test
  uint64_t visibility_tests = 0;   // pairs that cast rays
  uint64_t inherited_visible = 0;  // pairs that took V = 1 from a fully visible ancestor pair
  uint64_t occluded = 0;           // pairs found totally occluded (neither linked nor refined)
  uint64_t degenerate = 0;         // pairs with a node of zero area (neither linked nor refined)
  uint64_t rays = 0;
  uint64_t pair_evaluations = 0;
  uint64_t links_created = 0;

  void add(const RefineStats& o);
};

// A cluster pair opened with at least this many pairs of charts below it refines its two halves
// as parallel tasks (the same links in the same order; the threshold only bounds the tasks'
// overhead against their work).
inline constexpr uint64_t kParallelOpen = 4096;

// The partially visible pairs' error multiplier.
inline constexpr double kPartialPenalty = 4.0;

struct RefineCriterion {
  double feps = 0.02;
  double min_area = 0.0;  // aeps in scene units (m^2)
  uint64_t seed = 1;
  // BF refinement: the oracle is estimate * max_c rho_p,c B_q,c / bf_scale (the scene's mean
  // radiosity). Empty: F alone.
  std::function<Rgb(const NodeKey&)> radiosity;
  std::vector<Rgb> chart_reflectance;  // per chart (BF only)
  double bf_scale = 1.0;
};

class Refiner {
 public:
  // `clusters`: the cluster tree when clustering (nullptr: none).
  Refiner(const std::vector<Chart>& charts, const NodeVisibility& visibility,
          const RefineCriterion& criterion, const ClusterTree* clusters = nullptr)
      : charts_(charts), visibility_(visibility), c_(criterion), clusters_(clusters) {
    if (clusters_)
      for (const Chart& c : charts_) {
        if (polygon_normal_.size() <= c.polygon) polygon_normal_.resize(c.polygon + 1, Vec3(0.0));
        polygon_normal_[c.polygon] = c.normal;
      }
  }

  // Refine(root of chart a, root of chart b).
  void refine_roots(uint32_t a, uint32_t b, std::vector<LinkRecord>& out, RefineStats& stats) const;
  // Refine(a, b) for any two nodes (clusters or quadtree nodes; a == b a cluster with itself).
  void refine_keys(const NodeKey& a, const NodeKey& b, std::vector<LinkRecord>& out,
                   RefineStats& stats) const;
  // The pairs the root cluster's link to itself opens into: the two children of every cluster,
  // in preorder (each self pair of a cluster opens into its children's self pairs and this pair;
  // a chart's self pair carries nothing, a planar polygon not seeing itself).
  static std::vector<std::pair<NodeKey, NodeKey>> cluster_frontier(const ClusterTree& tree);
  // Multigridding: keeps `link` if it passes the (new) criterion, else replaces it by the links
  // Refine makes below it.
  void rerefine(const LinkRecord& link, std::vector<LinkRecord>& out, RefineStats& stats) const;

 private:
  struct Node {
    NodeKey key;
    NodeGeometry g;
  };
  enum class Known : uint8_t { kUnknown, kVisible };

  void refine(const Node& p, const Node& q, Known known, std::vector<LinkRecord>& out,
              RefineStats& stats) const;
  double error(const NodeKey& receiver, const NodeKey& source, double estimate) const;
  bool can_split(const Node& n) const;
  void split(const Node& p, const Node& q, bool split_q, Known known, std::vector<LinkRecord>& out,
             RefineStats& stats) const;
  double transfer(const Node& receiver, const Node& source) const;
  double max_over_children(const Node& receiver, const Node& source) const;

  // Clusters.
  Node node_of(const NodeKey& key) const;
  void refine_any(const Node& p, const Node& q, Known known, std::vector<LinkRecord>& out,
                  RefineStats& stats) const;
  void refine_clustered(const Node& p, const Node& q, Known known, std::vector<LinkRecord>& out,
                        RefineStats& stats) const;
  // Which end a failing pair opens: true for q (clusters before polygons; the larger sphere).
  bool open_q(const Node& p, const Node& q, double e_pq, double e_qp) const;
  void open(const Node& p, const Node& q, bool open_q, Known known, std::vector<LinkRecord>& out,
            RefineStats& stats) const;
  // Charts under a node: a cluster's count, 1 for a quadtree node.
  uint32_t chart_count(const Node& n) const;
  Vec3 centre(const Node& n) const;
  double radius(const Node& n) const;
  double node_area(const Node& n) const;
  double bound_estimate(const Node& receiver, const Node& source) const;
  bool behind(const Node& surface, const Node& cluster) const;
  // Unblocked segments of those (`facing`) of 16 that leave both ends' front sides.
  int cluster_visibility(const Node& p, const Node& q, int& facing) const;
  double surface_from_cluster(const Node& surface, const Node& cluster) const;

  const std::vector<Chart>& charts_;
  const NodeVisibility& visibility_;
  RefineCriterion c_;
  const ClusterTree* clusters_ = nullptr;
  std::vector<Vec3> polygon_normal_;  // per input polygon (clusters' segments)
};

}  // namespace radlab::hier
