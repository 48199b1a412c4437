// The quadtrees of hierarchical radiosity (Hanrahan, Salzman & Aupperle 1991, §3): charts (the
// roots), node keys, node geometry, and the projection of a hierarchical solution onto the run's
// element mesh.
//
// Charts: every input polygon with 3 or 4 corners is one root; a convex n-gon (n > 4) is rooted as
// the n-2 triangles of the same fan the mesher uses (scene/mesh.cpp), so every mesh
// element lies in exactly one chart. A chart has a parameter domain: the unit square (bilinear map
// of a quad) or the reference triangle (a,b >= 0, a+b <= 1; affine map of a triangle). A quad node
// splits into its four parameter quadrants, a triangle into its three corner triangles and the
// middle one — the same subdivisions as the mesher's K x K grids, so where K is a power of two the
// quadtree and the mesh nest.
//
// Nodes are named by keys (chart, depth, path of child digits), not by allocation order: the
// refinement runs in parallel and the tree is then built from the sorted keys, so node ids, link
// order and every sum are the same whatever the thread count.
//
// Projection: an element's value is the area average of the leaves over it, computed exactly by
// clipping the element's parameter polygon against each overlapping leaf's and integrating the
// map's Jacobian (constant for a triangle, linear for a planar bilinear quad, so its value at the
// clipped polygon's centroid times the parameter area is exact).
#pragma once

#include <cstdint>
#include <glm/vec2.hpp>
#include <vector>

#include "scene/mesh.h"
#include "scene/scene.h"

namespace radlab::hier {

using Vec2 = glm::dvec2;

struct Chart {
  uint32_t polygon = 0;  // the input polygon
  int corners = 4;       // 3 (triangle) or 4 (quad)
  Vec3 x[4];             // world corners (x[3] unused for triangles)
  Vec3 normal{0.0};
  double area = 0.0;

  Vec3 map(const Vec2& uv) const;  // parameter -> world
  // |dX/du x dX/dv| at uv: world area per unit parameter area.
  double jacobian(const Vec2& uv) const;
};

std::vector<Chart> make_charts(const Scene& scene);

// Depth up to kMaxDepth; digit of level l (1-based) in bits 2(l-1)..2l-1 of path.
inline constexpr int kMaxDepth = 24;

// A cluster (hierarchical_clusters.h) is named by its index in `chart` and this depth.
inline constexpr uint32_t kClusterDepth = 0xFFFFFFFFu;

struct NodeKey {
  uint32_t chart = 0;
  uint32_t depth = 0;
  uint64_t path = 0;

  static NodeKey cluster(uint32_t index) { return {index, kClusterDepth, 0}; }
  bool is_cluster() const { return depth == kClusterDepth; }

  NodeKey child(int digit) const {
    return {chart, depth + 1, path | (uint64_t(digit) << (2 * depth))};
  }
  NodeKey parent() const {
    return {chart, depth - 1, path & ((uint64_t(1) << (2 * (depth - 1))) - 1)};
  }
  int digit(uint32_t level) const { return int((path >> (2 * (level - 1))) & 3u); }
  bool operator==(const NodeKey& o) const {
    return chart == o.chart && depth == o.depth && path == o.path;
  }
  uint64_t hash() const;
};

// Depth-first order within a chart (a node before its descendants, children in digit order),
// charts in index order.
bool dfs_less(const NodeKey& a, const NodeKey& b);

struct NodeKeyHash {
  size_t operator()(const NodeKey& k) const { return size_t(k.hash()); }
};

// A node's geometry: its parameter polygon (3 or 4 corners, counter-clockwise) and world corners.
struct NodeGeometry {
  int corners = 4;
  Vec2 uv[4];
  Vec3 x[4];
  Vec3 centre{0.0};
  double area = 0.0;

  NodeGeometry child(const Chart& chart, int digit) const;
  // World point at local coordinates (s,t) in [0,1]^2 for a quad node; for a triangle node, the
  // point x0 + s (x1-x0) + t (x2-x0) (callers keep s+t <= 1).
  Vec3 point(double s, double t) const;
};

NodeGeometry root_geometry(const Chart& chart);
NodeGeometry node_geometry(const std::vector<Chart>& charts, const NodeKey& key);

// An element's place in the charts: its chart and parameter polygon, or, for an unsplit n-gon
// element (mesh K = 1), every fan chart of its polygon (whole = true).
struct ElementChart {
  uint32_t chart = 0;
  bool whole = false;
  int corners = 0;
  Vec2 uv[4];
};

// Parameter polygons of every mesh element, in the mesher's order; checks that they map onto the
// mesh's corners (throws std::logic_error if the mesher and this file ever disagree).
std::vector<ElementChart> element_charts(const Scene& scene, const Mesh& mesh,
                                         const std::vector<Chart>& charts);

// Area of the convex polygon `a` clipped to the convex polygon `b` (both counter-clockwise in
// parameter space), in world units under `chart`'s map.
double overlap_area(const Chart& chart, const Vec2* a, int na, const Vec2* b, int nb);

}  // namespace radlab::hier
