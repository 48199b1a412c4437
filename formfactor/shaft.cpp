#include "formfactor/shaft.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include "scene/geometry.h"

namespace radlab {

void Box::grow(const Vec3& p) {
  lo = glm::min(lo, p);
  hi = glm::max(hi, p);
}

void Box::grow(const Box& b) {
  lo = glm::min(lo, b.lo);
  hi = glm::max(hi, b.hi);
}

ShaftCuller::ShaftCuller(const Scene& scene, const Mesh& mesh, double epsilon)
    : mesh_(mesh), epsilon_(epsilon) {
  polygons_.resize(scene.polygons.size());
  for (size_t p = 0; p < scene.polygons.size(); ++p) {
    const auto& v = scene.polygons[p].vertices;
    PolygonData& d = polygons_[p];
    d.first_vertex = uint32_t(vertices_.size());
    d.vertex_count = uint32_t(v.size());
    for (const Vec3& x : v) {
      d.box.grow(x);
      vertices_.push_back(x);
    }
    d.normal = geometry::unit_normal(v);
    d.offset = glm::dot(d.normal, geometry::centroid(v));
  }
  element_box_.resize(mesh.size());
  for (size_t e = 0; e < mesh.size(); ++e)
    for (uint32_t v : mesh.element_vertices(e)) element_box_[e].grow(mesh.vertices[v]);
  order_.resize(polygons_.size());
  for (uint32_t p = 0; p < order_.size(); ++p) order_[p] = p;
  if (!order_.empty()) {
    nodes_.reserve(2 * order_.size());
    nodes_.emplace_back();
    build(0, 0, uint32_t(order_.size()), 0);
  }
}

// Fills node `node` (already allocated) with the subtree over order_[first, first + count).
// An inner node's two children are allocated together, so the right one is left + 1.
void ShaftCuller::build(uint32_t node, uint32_t first, uint32_t count, int depth) {
  Box box, centres;
  for (uint32_t k = first; k < first + count; ++k) {
    const Box& b = polygons_[order_[k]].box;
    box.grow(b);
    centres.grow(0.5 * (b.lo + b.hi));
  }
  nodes_[node].box = box;
  if (count <= 2 || depth >= 48) {
    nodes_[node].first = first;
    nodes_[node].count = count;
    return;
  }
  const Vec3 extent = centres.hi - centres.lo;
  const int axis =
      extent.x >= extent.y && extent.x >= extent.z ? 0 : (extent.y >= extent.z ? 1 : 2);
  const uint32_t half = count / 2;
  std::nth_element(order_.begin() + first, order_.begin() + first + half,
                   order_.begin() + first + count, [&](uint32_t a, uint32_t b) {
                     const Box& ba = polygons_[a].box;
                     const Box& bb = polygons_[b].box;
                     return ba.lo[axis] + ba.hi[axis] < bb.lo[axis] + bb.hi[axis];
                   });
  const uint32_t left = uint32_t(nodes_.size());
  nodes_[node].first = left;
  nodes_[node].count = 0;
  nodes_.emplace_back();
  nodes_.emplace_back();
  build(left, first, half, depth + 1);
  build(left + 1, first + half, count - half, depth + 1);
}

namespace {

struct Plane {
  Vec3 normal;  // unit
  double offset = 0.0;
};

// The smallest value of dot(n, x) over a box.
double box_min(const Vec3& n, const Box& b) {
  double s = 0.0;
  for (int k = 0; k < 3; ++k) s += n[k] * (n[k] > 0 ? b.lo[k] : b.hi[k]);
  return s;
}
double box_max(const Vec3& n, const Box& b) {
  return -box_min(-n, b);
}

}  // namespace

int64_t ShaftCuller::first_blocker(size_t i, size_t j) const {
  if (nodes_.empty()) return -1;
  // Work on the ordered pair so the decision cannot depend on which row asks.
  const size_t a = std::min(i, j), b = std::max(i, j);
  const Box& A = element_box_[a];
  const Box& B = element_box_[b];
  Box shaft = A;
  shaft.grow(B);
  const double eps = epsilon_;

  // Connecting planes: outside means dot(normal, x) >= offset - eps.
  std::array<Plane, 12> planes;
  int plane_count = 0;
  constexpr int kAxes[3][2] = {{0, 1}, {0, 2}, {1, 2}};
  for (const auto& axes : kAxes) {
    const int k = axes[0], l = axes[1];
    for (int sk = -1; sk <= 1; sk += 2)
      for (int sl = -1; sl <= 1; sl += 2) {
        const double ak = sk > 0 ? A.hi[k] : A.lo[k], al = sl > 0 ? A.hi[l] : A.lo[l];
        const double bk = sk > 0 ? B.hi[k] : B.lo[k], bl = sl > 0 ? B.hi[l] : B.lo[l];
        const double dk = ak - bk, dl = al - bl;
        // Each box extreme along a different axis of this quadrant: the 2D hull has an edge
        // from A's corner (ak, al) to B's corner (bk, bl), with outward normal (sk|dl|, sl|dk|).
        const bool crossed = (sk * dk > 0 && sl * dl < 0) || (sk * dk < 0 && sl * dl > 0);
        if (!crossed) continue;
        Vec3 n(0.0);
        n[k] = sk * std::abs(dl);
        n[l] = sl * std::abs(dk);
        const double length = glm::length(n);
        if (!(length > 0)) continue;
        n /= length;
        planes[size_t(plane_count++)] = Plane{n, n[k] * ak + n[l] * al};
      }
  }

  // i's and j's planes, usable only when the other element lies wholly in front of them.
  auto wholly_in_front = [&](size_t e, const Vec3& n, double offset) {
    for (uint32_t v : mesh_.element_vertices(e))
      if (glm::dot(n, mesh_.vertices[v]) - offset < -eps) return false;
    return true;
  };
  const Vec3 na = mesh_.normal[a], nb = mesh_.normal[b];
  const double oa = glm::dot(na, mesh_.centroid[a]), ob = glm::dot(nb, mesh_.centroid[b]);
  const bool use_a = wholly_in_front(b, na, oa);
  const bool use_b = wholly_in_front(a, nb, ob);
  const uint32_t pa = mesh_.polygon[a], pb = mesh_.polygon[b];

  auto box_outside = [&](const Box& box) {
    for (int k = 0; k < 3; ++k)
      if (box.lo[k] >= shaft.hi[k] - eps || box.hi[k] <= shaft.lo[k] + eps) return true;
    for (int p = 0; p < plane_count; ++p)
      if (box_min(planes[size_t(p)].normal, box) >= planes[size_t(p)].offset - eps) return true;
    if (use_a && box_max(na, box) <= oa + eps) return true;
    if (use_b && box_max(nb, box) <= ob + eps) return true;
    return false;
  };
  auto polygon_outside = [&](uint32_t id) {
    const PolygonData& d = polygons_[id];
    if (box_outside(d.box)) return true;
    const Vec3* v = vertices_.data() + d.first_vertex;
    auto all = [&](auto&& predicate) {
      for (uint32_t k = 0; k < d.vertex_count; ++k)
        if (!predicate(v[k])) return false;
      return true;
    };
    for (int p = 0; p < plane_count; ++p) {
      const Plane& plane = planes[size_t(p)];
      if (all([&](const Vec3& x) { return glm::dot(plane.normal, x) >= plane.offset - eps; }))
        return true;
    }
    if (use_a && all([&](const Vec3& x) { return glm::dot(na, x) <= oa + eps; })) return true;
    if (use_b && all([&](const Vec3& x) { return glm::dot(nb, x) <= ob + eps; })) return true;
    return false;
  };

  uint32_t stack[64];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& node = nodes_[stack[--top]];
    if (box_outside(node.box)) continue;
    if (node.count == 0) {
      stack[top++] = node.first;
      stack[top++] = node.first + 1;
      continue;
    }
    for (uint32_t k = node.first; k < node.first + node.count; ++k) {
      const uint32_t id = order_[k];
      if (id == pa || id == pb) continue;
      if (!polygon_outside(id)) return int64_t(id);
    }
  }
  return -1;
}

}  // namespace radlab
