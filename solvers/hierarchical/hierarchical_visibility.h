// Visibility between two hierarchy nodes with triage (Hanrahan, Salzman & Aupperle 1991, §4).
//
// First a constant-time plane test on the two nodes alone: they face each other, one lies on or
// behind the other's plane (no transport), or one is cut by the other's plane. Then, for pairs
// whose visibility is not inherited, 16 segments between jittered points of the two nodes traced
// through Embree: each node is split into 16 cells (a 4 x 4 parameter grid on a quad, the 16
// triangles of a 4-level grid on a triangle), one jittered point per cell, and cell k of the
// first node is joined to cell perm(k) of the second, perm being the numbering of Dürer's magic
// square (the paper's "magic square" pairing: no cell is always joined to the same place). The
// jitter is a hash of the seed and the two node keys, so the answer does not depend on which
// thread asks or in which order. The segments ignore hits on the two nodes' own polygons (a
// segment between two points of planar polygons meets them only at its ends; such hits are
// rounding). Cost: 16 rays per test.
#pragma once

#include <cstdint>
#include <memory>

#include "formfactor/visibility/embree_scene.h"
#include "solvers/hierarchical/hierarchical_tree.h"

namespace radlab::hier {

enum class PlaneRelation : uint8_t { kFacing, kAway, kCut };

// How `q` lies relative to `p`'s plane and `p` to `q`'s: kAway if either lies entirely on or
// behind the other's plane, kCut if either straddles the other's plane, kFacing otherwise.
PlaneRelation plane_test(const NodeGeometry& p, const Vec3& p_normal, const NodeGeometry& q,
                         const Vec3& q_normal);

inline constexpr int kVisibilityRays = 16;

// The point of stratum `cell` (of 16) of a node at jitter (u1, u2), and the stratum of the other
// node it is joined to (Dürer's magic square), as unblocked() uses them.
Vec3 stratum_point(const NodeGeometry& g, int cell, double u1, double u2);
int magic_partner(int cell);

class NodeVisibility {
 public:
  // Builds an Embree scene of the input polygons (one element per polygon).
  explicit NodeVisibility(const Scene& scene);
  ~NodeVisibility();

  // Number of the 16 segments between p and q that nothing blocks.
  int unblocked(const NodeGeometry& p, uint32_t p_polygon, const NodeKey& p_key,
                const NodeGeometry& q, uint32_t q_polygon, const NodeKey& q_key,
                uint64_t seed) const;

  // Number of the `count` (<= 16) segments x[k] -> y[k] that nothing blocks, ignoring hits on
  // polygons x_polygon[k] and y_polygon[k] (the segment's own ends); for clusters
  // (hierarchical_refine.h).
  int unblocked_segments(const Vec3* x, const Vec3* y, const uint32_t* x_polygon,
                         const uint32_t* y_polygon, int count) const;

 private:
  Mesh mesh_;
  std::unique_ptr<EmbreeScene> embree_;
};

}  // namespace radlab::hier
