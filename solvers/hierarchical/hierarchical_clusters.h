// Clusters for hierarchical radiosity (Smits, Arvo & Greenberg 1994; Sillion 1995): a binary
// tree of groups of charts above the charts' quadtrees, so refinement starts from one link (the
// root cluster with itself) instead of every pair of polygons.
//
// The tree is a bounding-volume hierarchy over the charts' boxes built by Embree's rtcBuildBVH
// (formfactor/visibility/embree_bvh.h: binned SAH, two children per cluster, one chart per leaf),
// numbered in preorder. A cluster holds its charts' total area A, their area-weighted centroid
// (its centre), the box of their corners and the radius of the sphere about the centre holding
// the box; its charts are a contiguous range of `order` (the tree's leaf order), with their
// cumulative areas for sampling points on them.
//
// Isotropic clusters (Sillion 1995, §3; Smits et al. 1994, §4): a cluster emits and receives as
// a point at its centre of projected area A/4 in every direction (the mean over the sphere of a
// one-sided surface's max(cos, 0) is 1/4), so
//   surface x (normal n) from cluster S:   F = A_S max(cos θ_x, 0) / (4 π r²)
//   cluster R from surface y:              F = A_y max(cos θ_y, 0) / (4 π r²)
//   cluster R from cluster S:              F = A_S / (16 π r²)
// with r the distance to the centre: reciprocal (A_R F_RS = A_S F_SR) by construction.
//
// Oriented clusters (`clustering=oriented`; Sillion 1995, §4; Smits et al. 1994): a cluster's
// projected area in direction w is that of its polygons, P(w) = sum_i A_i max(n_i . w, 0), in
// place of A/4. Each cluster keeps a list of (distinct normal, summed area) merged from its
// children (normals within 1e-9 of a cosine of each other are one), exact while it holds at most
// kOrientedNormals normals; beyond that the kOrientedNormals of largest area stay exact and the
// rest becomes an isotropic remainder of area A_rest counted as A_rest/4 (the isotropic model on
// that part only). The point kernels become
//   surface x (normal n) from cluster S:   F = P_S(w_Sx) max(cos θ_x, 0) / (π r²)
//   cluster R from cluster S:              F = P_R(w_RS) P_S(w_SR) / (π r² A_R)
// (w_ab the unit direction from a to b), still reciprocal, and A/4 gives the isotropic ones back.
#pragma once

#include <cstdint>
#include <vector>

#include "solvers/hierarchical/hierarchical_tree.h"

namespace radlab::hier {

struct Cluster {
  int32_t parent = -1;
  // >= 0: a cluster; < 0: the chart ~child (its quadtree's root).
  int32_t child[2] = {0, 0};
  Vec3 lo{0.0}, hi{0.0}, centre{0.0};
  double radius = 0.0, area = 0.0;
  uint32_t first = 0, count = 0;  // charts order[first, first + count)
};

// Normals a cluster keeps exactly (oriented clusters); architectural scenes rarely exceed it.
inline constexpr size_t kOrientedNormals = 16;

struct ClusterTree {
  std::vector<Cluster> clusters;        // preorder: clusters[0] is the root
  std::vector<uint32_t> order;          // charts in leaf order
  std::vector<double> cumulative_area;  // order.size() + 1 prefix sums of their areas
  std::vector<int32_t> chart_parent;    // per chart: the cluster holding it (-1: none)
  // Oriented clusters only (all empty when isotropic): cluster c's distinct normals and their
  // summed areas are normal[normal_first[c] .. normal_first[c+1]), its isotropic remainder's
  // area rest_area[c].
  std::vector<uint32_t> normal_first;
  std::vector<Vec3> normal;
  std::vector<double> normal_area, rest_area;
  // Oriented clusters' slots: cluster c's kept normals then its remainder are the slots
  // [slot_first[c], slot_first[c+1]) (slot_first[c] = normal_first[c] + c), slot_area their
  // charts' areas. Every chart's slot in each cluster above it, nearest first:
  // chart_slot[chart_slot_first[chart] .. chart_slot_first[chart+1]) (a chart cut into a
  // remainder stays in the remainders above). Per-orientation push and pull use them
  // (hierarchical_hierarchy.h).
  std::vector<uint32_t> slot_first, chart_slot_first, chart_slot;
  std::vector<double> slot_area;
  // Per cluster: whether a chart below it emits (mark_emitters; empty: not marked).
  std::vector<uint8_t> emitting;

  size_t size() const { return clusters.size(); }
  bool oriented() const { return !normal_first.empty(); }
  size_t memory_bytes() const;

  // Cluster c's projected area in the unit direction w: P(w) above when oriented, A/4 when
  // isotropic.
  double projected_area(uint32_t c, const Vec3& w) const;
  // Slot `slot` of cluster c's part of projected_area(c, w): A_k max(n_k . w, 0) for a kept
  // normal, A_rest / 4 for the remainder. Oriented only.
  double slot_projected_area(uint32_t c, uint32_t slot, const Vec3& w) const;
  // An upper bound of the polygons' exact projected area over every direction within angle
  // `spread` (radians) of the unit direction w: sum_k A_k cos(max(θ_k - spread, 0)) over the kept
  // normals (0 past 90°) plus the whole remainder's area (its normals are not kept). Oriented
  // only.
  double projected_area_bound(uint32_t c, const Vec3& w, double spread) const;
  // The kernel from a point x of normal n to cluster c (the surface-from-cluster line above;
  // isotropic_point_factor when isotropic). Zero at r = 0.
  double point_factor(uint32_t c, const Vec3& x, const Vec3& n) const;

  // A point of cluster c's charts for visibility: stratum k of `strata` picks a chart by area
  // (u0 jitters within the stratum), (u1, u2) a point in it. Sets `polygon` to its polygon.
  Vec3 sample(const std::vector<Chart>& charts, uint32_t c, int k, int strata, double u0, double u1,
              double u2, uint32_t& polygon) const;
};

// The cluster tree over every chart (empty for fewer than two charts); `oriented` adds the
// normal lists of oriented clusters.
ClusterTree build_clusters(const std::vector<Chart>& charts, bool oriented = false);

// Marks every cluster holding an emitting chart (chart_emits: per chart), children first.
void mark_emitters(ClusterTree& tree, const std::vector<uint8_t>& chart_emits);

// The isotropic kernel from a point to a cluster of area `source_area` at `centre`, seen from a
// surface of normal `n` at x: A max(cos, 0) / (4 π r²). Zero at r = 0.
double isotropic_point_factor(const Vec3& x, const Vec3& n, const Vec3& centre, double source_area);

}  // namespace radlab::hier
