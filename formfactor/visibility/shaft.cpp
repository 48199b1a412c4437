#include "formfactor/visibility/shaft.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>
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

namespace {

std::atomic<uint64_t> next_serial{1};

// The smallest value of dot(n, x) over a box.
// Written out per component: glm indexes a vector at run time through a switch.
[[gnu::always_inline]] inline double box_min(const Vec3& n, const Box& b) {
  return n.x * (n.x > 0 ? b.lo.x : b.hi.x) + n.y * (n.y > 0 ? b.lo.y : b.hi.y) +
         n.z * (n.z > 0 ? b.lo.z : b.hi.z);
}
[[gnu::always_inline]] inline double box_max(const Vec3& n, const Box& b) {
  return -box_min(-n, b);
}

// Whether `box` lies outside the union box `shaft` (touching up to eps counts as outside).
[[gnu::always_inline]] inline bool outside_union(const Box& box, const Box& shaft, double eps) {
  return box.lo.x >= shaft.hi.x - eps || box.hi.x <= shaft.lo.x + eps ||
         box.lo.y >= shaft.hi.y - eps || box.hi.y <= shaft.lo.y + eps ||
         box.lo.z >= shaft.hi.z - eps || box.hi.z <= shaft.lo.z + eps;
}

// A connecting plane: a normal n (not normalised) and offset; a point x is outside when its
// distance along the unit normal, (dot(n, x) - offset) / |n|, is >= -eps, that is when
// s = dot(n, x) - offset >= 0 or s^2 <= eps^2 |n|^2 (no square root).
struct Plane {
  Vec3 normal;
  double offset = 0.0;
  double tolerance2 = 0.0;  // eps^2 |n|^2
  [[gnu::always_inline]] bool outside(double s) const { return s >= 0.0 || s * s <= tolerance2; }
  [[gnu::always_inline]] bool box_outside(const Box& b) const {
    return outside(box_min(normal, b) - offset);
  }
  [[gnu::always_inline]] bool point_outside(const Vec3& x) const {
    return outside(glm::dot(normal, x) - offset);
  }
};

// One quadrant (sk, sl) of axes (k, l), with compile-time indices (glm indexes a vector at run
// time through a switch).
template <int k, int l, int sk, int sl>
[[gnu::always_inline]] inline void connect(const Box& A, const Box& B, double eps2, Plane* planes,
                                           int& count) {
  const double ak = sk > 0 ? A.hi[k] : A.lo[k], al = sl > 0 ? A.hi[l] : A.lo[l];
  const double bk = sk > 0 ? B.hi[k] : B.lo[k], bl = sl > 0 ? B.hi[l] : B.lo[l];
  const double dk = ak - bk, dl = al - bl;
  // Each box extreme along a different axis of this quadrant: the 2D hull has an edge from A's
  // corner (ak, al) to B's corner (bk, bl), with outward normal (sk|dl|, sl|dk|).
  const bool crossed = (sk * dk > 0 && sl * dl < 0) || (sk * dk < 0 && sl * dl > 0);
  if (!crossed) return;
  Plane& p = planes[count++];
  p.normal = Vec3(0.0);
  p.normal[k] = sk * std::abs(dl);
  p.normal[l] = sl * std::abs(dk);
  p.offset = p.normal[k] * ak + p.normal[l] * al;
  p.tolerance2 = eps2 * (p.normal[k] * p.normal[k] + p.normal[l] * p.normal[l]);
}

template <int k, int l>
[[gnu::always_inline]] inline void connect_axes(const Box& A, const Box& B, double eps2,
                                                Plane* planes, int& count) {
  connect<k, l, -1, -1>(A, B, eps2, planes, count);
  connect<k, l, -1, 1>(A, B, eps2, planes, count);
  connect<k, l, 1, -1>(A, B, eps2, planes, count);
  connect<k, l, 1, 1>(A, B, eps2, planes, count);
}

// The connecting planes of the hull of boxes A and B (shaft.h). Returns their number (<= 12).
int connecting_planes(const Box& A, const Box& B, double eps, Plane* planes) {
  int count = 0;
  connect_axes<0, 1>(A, B, eps * eps, planes, count);
  connect_axes<0, 2>(A, B, eps * eps, planes, count);
  connect_axes<1, 2>(A, B, eps * eps, planes, count);
  return count;
}

[[gnu::always_inline]] inline bool box_outside_planes(const Box& box, const Plane* planes,
                                                      int count) {
  for (int p = 0; p < count; ++p)
    if (planes[p].box_outside(box)) return true;
  return false;
}

// Whether all `count` points at v lie outside one of the planes.
[[gnu::always_inline]] inline bool points_outside_planes(const Vec3* v, uint32_t count,
                                                         const Plane* planes, int plane_count) {
  for (int p = 0; p < plane_count; ++p) {
    uint32_t k = 0;
    while (k < count && planes[p].point_outside(v[k])) ++k;
    if (k == count) return true;
  }
  return false;
}

// Whether all `count` points at v satisfy dot(n, x) <= limit.
[[gnu::always_inline]] inline bool points_below(const Vec3* v, uint32_t count, const Vec3& n,
                                                double limit) {
  for (uint32_t k = 0; k < count; ++k)
    if (glm::dot(n, v[k]) > limit) return false;
  return true;
}

// Whether all `count` points at v satisfy dot(n, x) >= limit.
[[gnu::always_inline]] inline bool points_above(const Vec3* v, uint32_t count, const Vec3& n,
                                                double limit) {
  for (uint32_t k = 0; k < count; ++k)
    if (glm::dot(n, v[k]) < limit) return false;
  return true;
}

}  // namespace

// One slot of the per-thread cache of polygon pairs' candidates.
struct ShaftCuller::PairEntry {
  uint64_t serial = 0;  // 0: empty
  uint32_t p = 0, q = 0;
  bool traverse = false;      // not listed: element pairs traverse the hierarchy
  std::vector<uint32_t> ids;  // the candidates (when listed)
};

ShaftCuller::ShaftCuller(const Scene& scene, const Mesh& mesh, double epsilon)
    : epsilon_(epsilon), serial_(next_serial.fetch_add(1)) {
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
    d.cover = d.box;
    d.normal = geometry::unit_normal(v);
    d.offset = glm::dot(d.normal, geometry::centroid(v));
    for (const Vec3& x : v)
      d.defect = std::max(d.defect, std::abs(glm::dot(d.normal, x) - d.offset));
  }
  const size_t n = mesh.size();
  element_box_.resize(n);
  element_plane_.resize(n);
  element_polygon_.resize(n);
  element_first_.resize(n + 1);
  element_count_.assign(polygons_.size(), 0);
  element_corner_.reserve(mesh.vertex_index.size());
  for (size_t e = 0; e < n; ++e) {
    element_first_[e] = uint32_t(element_corner_.size());
    for (uint32_t v : mesh.element_vertices(e)) {
      element_box_[e].grow(mesh.vertices[v]);
      element_corner_.push_back(mesh.vertices[v]);
    }
    element_plane_[e] = {mesh.normal[e], glm::dot(mesh.normal[e], mesh.centroid[e])};
    element_polygon_[e] = mesh.polygon[e];
    polygons_[mesh.polygon[e]].cover.grow(element_box_[e]);
    ++element_count_[mesh.polygon[e]];
  }
  element_first_[n] = uint32_t(element_corner_.size());
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

template <class NodeOutside, class Visit>
bool ShaftCuller::walk(NodeOutside&& node_outside, Visit&& visit) const {
  uint32_t stack[64];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& node = nodes_[stack[--top]];
    if (node_outside(node.box)) continue;
    if (node.count == 0) {
      stack[top++] = node.first;
      stack[top++] = node.first + 1;
      continue;
    }
    for (uint32_t k = node.first; k < node.first + node.count; ++k)
      if (visit(order_[k])) return true;
  }
  return false;
}

// The polygon-level test (shaft.h): the polygons other than p and q (p <= q) that may reach
// into the shaft of p's and q's cover boxes, in the hierarchy's traversal order.
void ShaftCuller::compute_candidates(uint32_t p, uint32_t q, size_t limit,
                                     std::vector<uint32_t>& out) const {
  out.clear();
  if (nodes_.empty()) return;
  const PolygonData& P = polygons_[p];
  const PolygonData& Q = polygons_[q];
  Box shaft = P.cover;
  shaft.grow(Q.cover);
  const double eps = epsilon_;
  std::array<Plane, 12> planes;
  const int plane_count = connecting_planes(P.cover, Q.cover, eps, planes.data());
  // P's plane: every point of P lies within P.defect of it, so when all of Q is in front (up to
  // eps) every segment lies in dot(nP, x) >= oP - max(defect, eps); a polygon within 2 eps of
  // that half-space's boundary or behind it only touches the segments.
  const Vec3* pv = vertices_.data() + P.first_vertex;
  const Vec3* qv = vertices_.data() + Q.first_vertex;
  const bool use_p = points_above(qv, Q.vertex_count, P.normal, P.offset - eps);
  const bool use_q = points_above(pv, P.vertex_count, Q.normal, Q.offset - eps);
  const double limit_p = P.offset - std::max(P.defect, eps) + 2 * eps;
  const double limit_q = Q.offset - std::max(Q.defect, eps) + 2 * eps;

  auto box_outside = [&](const Box& box) {
    if (outside_union(box, shaft, eps)) return true;
    if (box_outside_planes(box, planes.data(), plane_count)) return true;
    if (use_p && box_max(P.normal, box) <= limit_p) return true;
    if (use_q && box_max(Q.normal, box) <= limit_q) return true;
    return false;
  };
  auto polygon_outside = [&](uint32_t id) {
    const PolygonData& d = polygons_[id];
    if (box_outside(d.box)) return true;
    const Vec3* v = vertices_.data() + d.first_vertex;
    if (points_outside_planes(v, d.vertex_count, planes.data(), plane_count)) return true;
    if (use_p && points_below(v, d.vertex_count, P.normal, limit_p)) return true;
    if (use_q && points_below(v, d.vertex_count, Q.normal, limit_q)) return true;
    return false;
  };

  walk(box_outside, [&](uint32_t id) {
    if (id == p || id == q || polygon_outside(id)) return false;
    out.push_back(id);
    return out.size() > limit;  // enough to know the list will not be used
  });
}

std::vector<uint32_t> ShaftCuller::polygon_pair_candidates(uint32_t p, uint32_t q) const {
  std::vector<uint32_t> out;
  compute_candidates(std::min(p, q), std::max(p, q), SIZE_MAX, out);
  return out;
}

const ShaftCuller::PairEntry& ShaftCuller::pair_entry(uint32_t p, uint32_t q) const {
  // Direct-mapped: a row's pairs (p fixed, q running) fall in distinct slots while the slots
  // (a power of two, 4096 to 65536) are at least as many as the polygons.
  thread_local std::vector<PairEntry> cache;
  const size_t slots = std::clamp<size_t>(std::bit_ceil(polygons_.size()), 4096, 65536);
  if (cache.size() < slots) cache.assign(slots, PairEntry{});
  PairEntry& entry = cache[(size_t(p) * polygons_.size() + q) & (cache.size() - 1)];
  if (entry.serial != serial_ || entry.p != p || entry.q != q) {
    entry.serial = 0;  // empty until filled
    // A row of p's elements uses the entry for q's elements, a row of q's for p's: with few
    // elements on either side, listing the candidates can cost more than it saves (rows asked for
    // in any order, as a shooting solver does); such pairs traverse the hierarchy, as do pairs
    // with many candidates.
    entry.traverse = std::min(element_count_[p], element_count_[q]) < kMinElements;
    if (!entry.traverse) {
      compute_candidates(p, q, kMaxCandidates, entry.ids);
      entry.traverse = entry.ids.size() > kMaxCandidates;
    }
    entry.serial = serial_;
    entry.p = p;
    entry.q = q;
  }
  return entry;
}

int64_t ShaftCuller::first_blocker(size_t i, size_t j) const {
  if (nodes_.empty()) return -1;
  // Work on the ordered pair so the decision cannot depend on which row asks.
  const size_t a = std::min(i, j), b = std::max(i, j);
  const uint32_t pa = element_polygon_[a], pb = element_polygon_[b];
  const PairEntry& entry = pair_entry(std::min(pa, pb), std::max(pa, pb));
  if (entry.traverse) return element_blocker(a, b, nullptr, 0);
  if (entry.ids.empty()) return -1;
  return element_blocker(a, b, entry.ids.data(), entry.ids.size());
}

void ShaftCuller::blockers(size_t i, size_t j, std::vector<uint32_t>& out) const {
  out.clear();
  if (nodes_.empty()) return;
  const size_t a = std::min(i, j), b = std::max(i, j);
  const uint32_t pa = element_polygon_[a], pb = element_polygon_[b];
  const PairEntry& entry = pair_entry(std::min(pa, pb), std::max(pa, pb));
  if (entry.traverse)
    element_blocker(a, b, nullptr, 0, &out);
  else if (!entry.ids.empty())
    element_blocker(a, b, entry.ids.data(), entry.ids.size(), &out);
}

int64_t ShaftCuller::element_level_blocker(size_t i, size_t j) const {
  if (nodes_.empty()) return -1;
  return element_blocker(std::min(i, j), std::max(i, j), nullptr, 0);
}

// The element-level test of the pair a < b against the polygons ids[0, count), or against all
// polygons but a's and b's through the hierarchy when ids is null.
int64_t ShaftCuller::element_blocker(size_t a, size_t b, const uint32_t* ids, size_t count,
                                     std::vector<uint32_t>* all) const {
  const uint32_t pa = element_polygon_[a], pb = element_polygon_[b];
  const Box& A = element_box_[a];
  const Box& B = element_box_[b];
  Box shaft = A;
  shaft.grow(B);
  const double eps = epsilon_;
  // Built once a polygon reaches into the union box: the connecting planes, and whether i's and
  // j's planes can be used (the other element wholly in front).
  std::array<Plane, 12> planes;
  int plane_count = 0;
  bool use_a = false, use_b = false;
  const ElementPlane& ea = element_plane_[a];
  const ElementPlane& eb = element_plane_[b];
  auto complete = [&] {
    plane_count = connecting_planes(A, B, eps, planes.data());
    use_a = points_above(element_corner_.data() + element_first_[b],
                         element_first_[b + 1] - element_first_[b], ea.normal, ea.offset - eps);
    use_b = points_above(element_corner_.data() + element_first_[a],
                         element_first_[a + 1] - element_first_[a], eb.normal, eb.offset - eps);
  };
  // The tests after the union box's.
  auto box_outside = [&](const Box& box) {
    if (box_outside_planes(box, planes.data(), plane_count)) return true;
    if (use_a && box_max(ea.normal, box) <= ea.offset + eps) return true;
    if (use_b && box_max(eb.normal, box) <= eb.offset + eps) return true;
    return false;
  };
  auto corners_outside = [&](const PolygonData& d) {
    const Vec3* v = vertices_.data() + d.first_vertex;
    if (points_outside_planes(v, d.vertex_count, planes.data(), plane_count)) return true;
    if (use_a && points_below(v, d.vertex_count, ea.normal, ea.offset + eps)) return true;
    if (use_b && points_below(v, d.vertex_count, eb.normal, eb.offset + eps)) return true;
    return false;
  };

  if (ids) {
    bool completed = false;
    for (const uint32_t* id_pointer = ids; id_pointer != ids + count; ++id_pointer) {
      const uint32_t id = *id_pointer;
      const PolygonData& d = polygons_[id];
      if (outside_union(d.box, shaft, eps)) continue;
      if (!completed) {
        complete();
        completed = true;
      }
      if (box_outside(d.box) || corners_outside(d)) continue;
      if (!all) return int64_t(id);
      all->push_back(id);
    }
    return all && !all->empty() ? int64_t(all->front()) : -1;
  }

  complete();
  int64_t blocker = -1;
  walk([&](const Box& box) { return outside_union(box, shaft, eps) || box_outside(box); },
       [&](uint32_t id) {
         if (id == pa || id == pb) return false;
         const PolygonData& d = polygons_[id];
         if (outside_union(d.box, shaft, eps) || box_outside(d.box) || corners_outside(d))
           return false;
         if (blocker < 0) blocker = int64_t(id);
         if (all) all->push_back(id);
         return !all;
       });
  return blocker;
}

}  // namespace radlab
