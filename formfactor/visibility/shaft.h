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
//
// Distances to a connecting plane are compared without normalising its normal n: x is outside
// when s = n.x - offset >= 0 or s^2 <= eps^2 |n|^2, the same test as (n/|n|).x >= offset/|n| - eps
// up to rounding.
//
// Two tiers (the element-level test above is the second).
//
// 1. Polygon pairs. The same test, made for the pair of input polygons {P, Q} that i and j belong
//    to, yields the candidates of {P, Q}: the polygons other than P and Q it cannot rule out. It
//    uses P's and Q's boxes, each grown to hold the boxes of its elements, and P's and Q's planes.
//    Sound for every element pair (i in P, j in Q): an element's box lies inside its polygon's
//    box, so the element pair's shaft (the hull of its two boxes) lies inside the polygon pair's
//    hull; and when all of Q's corners are in front of P's plane, so is all of j, and every
//    segment from i to j lies in P's front half-space. A polygon P that is not flat (off its plane
//    by up to d <= the validator's tolerance) has its points in the slab |n.x - o| <= d, so the
//    segments lie in n.x >= o - max(d, eps) and P's plane rules out only polygons behind that
//    (within the usual 2 eps of touching).
// 2. Element pairs. No candidate: {i, j} is clear with no further test. Otherwise only the
//    candidates get the element-level test; the connecting planes and i's and j's plane flags are
//    built only once a candidate's box reaches into the pair's union box.
// Hence every pair the element-level test alone proves clear (element_level_blocker) is still
// proven clear, a few more are (a polygon ruled out for the whole polygon pair that the
// element-level test happens not to rule out), and each decision still rests on sound exclusions.
//
// A polygon pair whose elements are few (fewer than kMinElements on either side: listing would
// cost more than it saves) or whose candidates are many (more than kMaxCandidates) is not listed:
// its element pairs traverse a bounding-volume hierarchy of all polygons (median splits), O(log P)
// box tests plus one test per polygon whose box reaches into the shaft. The candidates are
// computed lazily, on the first element pair that needs them, and kept in a per-thread
// direct-mapped cache keyed by (culler, P, Q) with one slot per polygon (4096 to 65536 slots): no
// locks, bounded memory for scenes with thousands of polygons, and a row's polygon pairs (P fixed,
// Q running) never evict each other. The cache changes only the cost: the candidates of {P, Q}
// are a function of the pair.
//
// The decision depends only on the unordered pair {i, j} (both tiers work on (min, max) and on
// (min, max) of the polygons; whether a polygon pair is listed depends only on that pair):
// V_ij = V_ji is kept.
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

  // Every polygon that may block a segment between i and j (the same tests as first_blocker, not
  // stopping at the first), in an order that depends only on {i, j}. Empty when none can.
  void blockers(size_t i, size_t j, std::vector<uint32_t>& out) const;

  size_t polygon_count() const { return polygons_.size(); }

  // The element-level test alone (no polygon-pair tier): the first polygon other than i's and
  // j's that it cannot rule out, or -1. first_blocker(i, j) is -1 whenever this is (for tests).
  int64_t element_level_blocker(size_t i, size_t j) const;

  // The candidates of the polygon pair {p, q}: the polygons other than p and q that the
  // polygon-level shaft test cannot rule out (for tests and statistics).
  std::vector<uint32_t> polygon_pair_candidates(uint32_t p, uint32_t q) const;

  // Above this many candidates an element pair traverses the hierarchy instead of the list.
  static constexpr uint32_t kMaxCandidates = 64;
  // A polygon pair's candidates are listed only when both polygons have this many elements.
  static constexpr uint32_t kMinElements = 8;

 private:
  struct PolygonData {
    Box box;    // of its corners: as a blocker
    Box cover;  // of its corners and its elements' corners: as an end of a polygon-level shaft
    Vec3 normal;
    double offset = 0.0;  // plane: dot(normal, x) = offset
    double defect = 0.0;  // largest |dot(normal, corner) - offset|
    uint32_t first_vertex = 0, vertex_count = 0;
  };
  struct Node {
    Box box;
    uint32_t first = 0;  // leaf: first polygon in order_; inner: index of the left child
    uint32_t count = 0;  // leaf: number of polygons (> 0); inner: 0 (right child = left + 1)
  };
  struct ElementPlane {
    Vec3 normal;
    double offset = 0.0;
  };
  struct PairEntry;
  void build(uint32_t node, uint32_t first, uint32_t count, int depth);
  void compute_candidates(uint32_t p, uint32_t q, size_t limit, std::vector<uint32_t>& out) const;
  // Depth-first walk of the polygon hierarchy: skips nodes for which `node_outside(box)` holds,
  // calls `visit(id)` for every polygon in the leaves reached, and stops as soon as it returns
  // true (the walk then returns true).
  template <class NodeOutside, class Visit>
  bool walk(NodeOutside&& node_outside, Visit&& visit) const;
  const PairEntry& pair_entry(uint32_t p, uint32_t q) const;
  // `all`, if given, receives every polygon not ruled out (the walk does not stop at the first).
  int64_t element_blocker(size_t a, size_t b, const uint32_t* ids, size_t count,
                          std::vector<uint32_t>* all = nullptr) const;

  double epsilon_;
  uint64_t serial_ = 0;  // tells this culler's entries in the per-thread cache from others'
  std::vector<PolygonData> polygons_;
  std::vector<Vec3> vertices_;               // all polygons' corners, concatenated
  std::vector<uint32_t> order_;              // polygon ids, leaves' ranges point into it
  std::vector<Node> nodes_;                  // nodes_[0] is the root
  std::vector<Box> element_box_;             // per mesh element
  std::vector<ElementPlane> element_plane_;  // per mesh element: its normal and centroid's offset
  std::vector<uint32_t> element_polygon_;    // per mesh element
  std::vector<uint32_t> element_count_;      // per polygon: its number of elements
  std::vector<uint32_t> element_first_;      // size()+1 offsets into element_corner_
  std::vector<Vec3> element_corner_;         // all elements' corners, concatenated
};

}  // namespace radlab
