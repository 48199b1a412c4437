// A binary bounding-volume hierarchy over axis-aligned boxes, built by Embree 3's generic BVH
// builder (rtcBuildBVH: binned SAH, RTC_BUILD_QUALITY_MEDIUM, two children per node, one box per
// leaf) rather than by hand. Used by hierarchical radiosity's clusters
// (solvers/hierarchical/hierarchical_clusters.h); Embree's types stay in the .cpp.
//
// The tree is returned as plain indices in preorder (a node before its descendants, the first
// child's subtree before the second's), so callers can walk it parents-first by index. Embree's
// parallel build is deterministic in the tree it makes; should a leaf hold more than one box
// (Embree's fallback when it cannot split), it is split here by box index into a balanced binary
// tree, so every leaf is one box whatever happens.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "scene/scene.h"

namespace radlab {

struct BvhBox {
  Vec3 lo, hi;
};

struct BinaryBvh {
  // child >= 0: a node index; child < 0: the box ~child (i.e. -child - 1).
  struct Node {
    int32_t child[2] = {0, 0};
    int32_t parent = -1;
  };
  std::vector<Node> nodes;  // preorder; empty when there are fewer than two boxes
};

// Throws NumericalError if Embree fails.
BinaryBvh build_binary_bvh(std::span<const BvhBox> boxes);

}  // namespace radlab
