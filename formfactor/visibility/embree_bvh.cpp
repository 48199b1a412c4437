#include "formfactor/visibility/embree_bvh.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <string>

#include "core/error.h"

namespace radlab {
namespace {

// Embree's nodes during the build: allocated from its thread-local allocator, freed with the BVH.
struct BuildNode {
  bool leaf = false;
  BuildNode* child[2] = {nullptr, nullptr};
};

void* create_node(RTCThreadLocalAllocator alloc, unsigned int child_count, void*) {
  void* memory = rtcThreadLocalAlloc(alloc, sizeof(BuildNode), 16);
  auto* node = new (memory) BuildNode;
  node->leaf = false;
  (void)child_count;
  return node;
}

void set_children(void* node_ptr, void** children, unsigned int child_count, void*) {
  auto* node = static_cast<BuildNode*>(node_ptr);
  for (unsigned k = 0; k < child_count && k < 2; ++k)
    node->child[k] = static_cast<BuildNode*>(children[k]);
}

void set_bounds(void*, const RTCBounds**, unsigned int, void*) {}

struct LeafNode {
  BuildNode node;
  uint32_t count = 0;
  uint32_t box[RTC_BUILD_MAX_PRIMITIVES_PER_LEAF];
};

void* create_leaf(RTCThreadLocalAllocator alloc, const RTCBuildPrimitive* prims, size_t count,
                  void*) {
  void* memory = rtcThreadLocalAlloc(alloc, sizeof(LeafNode), 16);
  auto* leaf = new (memory) LeafNode;
  leaf->node.leaf = true;
  leaf->count = uint32_t(std::min<size_t>(count, RTC_BUILD_MAX_PRIMITIVES_PER_LEAF));
  for (uint32_t k = 0; k < leaf->count; ++k) leaf->box[k] = prims[k].primID;
  // The order Embree hands a leaf's primitives in may depend on the build's threads.
  std::sort(leaf->box, leaf->box + leaf->count);
  return &leaf->node;
}

class Flatten {
 public:
  explicit Flatten(BinaryBvh& out) : out_(out) {}

  // Returns the child code of the subtree: a node index, or ~box for a single box.
  int32_t node(const BuildNode* n, int32_t parent) {
    if (n->leaf) {
      const auto* leaf = reinterpret_cast<const LeafNode*>(n);
      return boxes(leaf->box, leaf->count, parent);
    }
    const int32_t self = add(parent);
    const int32_t a = node(n->child[0], self);
    const int32_t b = node(n->child[1], self);
    out_.nodes[size_t(self)].child[0] = a;
    out_.nodes[size_t(self)].child[1] = b;
    return self;
  }

  // A leaf of several boxes as a balanced binary tree by index.
  int32_t boxes(const uint32_t* box, uint32_t count, int32_t parent) {
    if (count == 1) return ~int32_t(box[0]);
    const int32_t self = add(parent);
    const uint32_t half = count / 2;
    const int32_t a = boxes(box, half, self);
    const int32_t b = boxes(box + half, count - half, self);
    out_.nodes[size_t(self)].child[0] = a;
    out_.nodes[size_t(self)].child[1] = b;
    return self;
  }

 private:
  int32_t add(int32_t parent) {
    out_.nodes.push_back({});
    out_.nodes.back().parent = parent;
    return int32_t(out_.nodes.size() - 1);
  }
  BinaryBvh& out_;
};

void check(RTCDevice device, const char* what) {
  const RTCError error = rtcGetDeviceError(device);
  if (error != RTC_ERROR_NONE)
    throw NumericalError(std::string("Embree failed during ") + what + " (error " +
                         std::to_string(int(error)) + ")");
}

}  // namespace

BinaryBvh build_binary_bvh(std::span<const BvhBox> boxes) {
  BinaryBvh out;
  if (boxes.size() < 2) return out;
  if (boxes.size() > 0x7fffffffu) throw NumericalError("BVH: more than 2^31 boxes");
  RTCDevice device = rtcNewDevice(nullptr);
  if (!device) throw NumericalError("Embree: cannot create a device");
  RTCBVH bvh = rtcNewBVH(device);
  std::vector<RTCBuildPrimitive> prims(boxes.size());
  for (size_t i = 0; i < boxes.size(); ++i) {
    RTCBuildPrimitive& p = prims[i];
    // Float boxes rounded outwards are not needed: the tree is only a grouping.
    p.lower_x = float(boxes[i].lo.x);
    p.lower_y = float(boxes[i].lo.y);
    p.lower_z = float(boxes[i].lo.z);
    p.upper_x = float(boxes[i].hi.x);
    p.upper_y = float(boxes[i].hi.y);
    p.upper_z = float(boxes[i].hi.z);
    p.geomID = 0;
    p.primID = unsigned(i);
  }
  RTCBuildArguments args = rtcDefaultBuildArguments();
  args.byteSize = sizeof(args);
  args.buildQuality = RTC_BUILD_QUALITY_MEDIUM;
  args.maxBranchingFactor = 2;
  args.maxDepth = 1024;
  args.sahBlockSize = 1;
  args.minLeafSize = 1;
  args.maxLeafSize = 1;
  args.traversalCost = 1.0f;
  args.intersectionCost = 1.0f;
  args.bvh = bvh;
  args.primitives = prims.data();
  args.primitiveCount = prims.size();
  args.primitiveArrayCapacity = prims.size();
  args.createNode = create_node;
  args.setNodeChildren = set_children;
  args.setNodeBounds = set_bounds;
  args.createLeaf = create_leaf;
  void* root = rtcBuildBVH(&args);
  try {
    check(device, "BVH build");
    if (!root) throw NumericalError("Embree: the BVH build returned no tree");
    Flatten flatten(out);
    out.nodes.reserve(boxes.size() - 1);
    flatten.node(static_cast<const BuildNode*>(root), -1);
  } catch (...) {
    rtcReleaseBVH(bvh);
    rtcReleaseDevice(device);
    throw;
  }
  rtcReleaseBVH(bvh);
  rtcReleaseDevice(device);
  return out;
}

}  // namespace radlab
