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

struct ClusterTree {
  std::vector<Cluster> clusters;        // preorder: clusters[0] is the root
  std::vector<uint32_t> order;          // charts in leaf order
  std::vector<double> cumulative_area;  // order.size() + 1 prefix sums of their areas
  std::vector<int32_t> chart_parent;    // per chart: the cluster holding it (-1: none)

  size_t size() const { return clusters.size(); }
  size_t memory_bytes() const;

  // A point of cluster c's charts for visibility: stratum k of `strata` picks a chart by area
  // (u0 jitters within the stratum), (u1, u2) a point in it. Sets `polygon` to its polygon.
  Vec3 sample(const std::vector<Chart>& charts, uint32_t c, int k, int strata, double u0, double u1,
              double u2, uint32_t& polygon) const;
};

// The cluster tree over every chart (empty for fewer than two charts).
ClusterTree build_clusters(const std::vector<Chart>& charts);

// The isotropic kernel from a point to a cluster of area `source_area` at `centre`, seen from a
// surface of normal `n` at x: A max(cos, 0) / (4 π r²). Zero at r = 0.
double isotropic_point_factor(const Vec3& x, const Vec3& n, const Vec3& centre, double source_area);

}  // namespace radlab::hier
