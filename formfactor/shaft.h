// Shaft culling (after Haines & Wallace 1991, "Shaft culling for efficient ray-cast radiosity"):
// proves that nothing can block any segment between two elements, so the pair needs no
// visibility rays.
//
// The shaft of a pair (i, j) is the convex hull of the axis-aligned boxes of the two elements;
// every segment from a point of i to a point of j lies in it. It is bounded here by the faces of
// the union box and by up to 12 axis-parallel "connecting" planes: for each pair of axes, the 2D
// hull of the two boxes' projections has, besides the union rectangle, an edge joining the two
// boxes' corners in every quadrant where each box is extreme along a different axis. The
// intersection of these half-spaces contains the true hull (it is the intersection of the hull's
// three axis projections), so the test is conservative.
//
// An input polygon can block a segment between i and j only if
//   - it is not the polygon of i or of j (a planar convex polygon meets a segment that leaves it
//     only at the segment's end point),
//   - some of it lies strictly inside the shaft (a polygon that only touches the shaft's boundary
//     meets the segments, which run through the shaft's interior, at most at their end points),
//   - it is not wholly behind (or in) i's plane when all of j is in front of i's plane (then every
//     segment lies in i's closed front half-space and meets that plane only at its start), and
//     likewise with i and j exchanged.
// Polygons sit in a bounding-volume hierarchy (median splits), so a pair costs O(log P) box tests
// for P polygons, plus one test per polygon whose box reaches into the shaft.
//
// The decision depends only on the unordered pair {i, j}: V_ij = V_ji is kept.
#pragma once

#include <cstdint>
#include <vector>

#include "scene/mesh.h"

namespace radlab {

struct Box {
  Vec3 lo{1e300};
  Vec3 hi{-1e300};
  void grow(const Vec3& p);
  void grow(const Box& b);
};

class ShaftCuller {
 public:
  // `epsilon` (metres): overlaps and plane distances up to this count as touching.
  ShaftCuller(const Scene& scene, const Mesh& mesh, double epsilon);

  // True when no polygon can block any segment between elements i and j (i != j). Thread-safe.
  bool unoccluded(size_t i, size_t j) const { return first_blocker(i, j) < 0; }
  // The first polygon found that may block a segment between i and j, or -1 when none can.
  int64_t first_blocker(size_t i, size_t j) const;

  size_t polygon_count() const { return polygons_.size(); }

 private:
  struct PolygonData {
    Box box;
    Vec3 normal;
    double offset = 0.0;  // plane: dot(normal, x) = offset
    uint32_t first_vertex = 0, vertex_count = 0;
  };
  struct Node {
    Box box;
    uint32_t first = 0;  // leaf: first polygon in order_; inner: index of the left child
    uint32_t count = 0;  // leaf: number of polygons (> 0); inner: 0 (right child = left + 1)
  };
  void build(uint32_t node, uint32_t first, uint32_t count, int depth);

  const Mesh& mesh_;
  double epsilon_;
  std::vector<PolygonData> polygons_;
  std::vector<Vec3> vertices_;    // all polygons' corners, concatenated
  std::vector<uint32_t> order_;   // polygon ids, leaves' ranges point into it
  std::vector<Node> nodes_;       // nodes_[0] is the root
  std::vector<Box> element_box_;  // per mesh element
};

}  // namespace radlab
