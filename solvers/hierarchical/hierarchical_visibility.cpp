#include "solvers/hierarchical/hierarchical_visibility.h"

#include <glm/geometric.hpp>

#include "core/random.h"
#include "scene/geometry.h"

namespace radlab::hier {

PlaneRelation plane_test(const NodeGeometry& p, const Vec3& p_normal, const NodeGeometry& q,
                         const Vec3& q_normal) {
  // A tolerance relative to the nodes' size: corners within it of a plane count as on it (two
  // walls meeting at an edge share corners that rounding puts a hair either side).
  const double scale = std::sqrt(std::max(p.area, q.area));
  const double tol = 1e-9 * scale;
  auto side = [&](const NodeGeometry& a, const Vec3& origin, const Vec3& normal, bool& front,
                  bool& back) {
    front = back = false;
    for (int k = 0; k < a.corners; ++k) {
      const double d = glm::dot(a.x[k] - origin, normal);
      front |= d > tol;
      back |= d < -tol;
    }
  };
  bool q_front, q_back, p_front, p_back;
  side(q, p.x[0], p_normal, q_front, q_back);
  side(p, q.x[0], q_normal, p_front, p_back);
  if (!q_front || !p_front) return PlaneRelation::kAway;
  if (q_back || p_back) return PlaneRelation::kCut;
  return PlaneRelation::kFacing;
}

namespace {

// Dürer's magic square (Melencolia I), row by row, minus one: cell k of the first node is joined
// to cell kMagic[k] of the second.
constexpr int kMagic[16] = {15, 2, 1, 12, 4, 9, 10, 7, 8, 5, 6, 11, 3, 14, 13, 0};

// The 16 cells of a triangle node: up and down triangles of the 4-level grid, in local (s,t).
struct TriCell {
  double a[2], b[2], c[2];
};
struct TriCells {
  TriCell cell[16];
  TriCells() {
    int k = 0;
    for (int row = 0; row < 4; ++row)
      for (int col = 0; col + row < 4; ++col) {
        const double s = col / 4.0, t = row / 4.0, h = 0.25;
        cell[k++] = {{s, t}, {s + h, t}, {s, t + h}};
        if (col + row + 1 < 4) cell[k++] = {{s + h, t}, {s + h, t + h}, {s, t + h}};
      }
  }
};
const TriCells kTriCells;

// Row k of the packet: the segment from x to y, trimmed at both ends (t in [1e-5, 1 - 1e-5]) so
// that the two end polygons do not block it.
void set_segment(SegmentPacket& packet, int k, const Vec3& x, const Vec3& y) {
  const Vec3 d = y - x;
  packet.ox[k] = float(x.x);
  packet.oy[k] = float(x.y);
  packet.oz[k] = float(x.z);
  packet.dx[k] = float(d.x);
  packet.dy[k] = float(d.y);
  packet.dz[k] = float(d.z);
  packet.t_near[k] = 1e-5f;
  packet.t_far[k] = 1.0f - 1e-5f;
}

}  // namespace

Vec3 stratum_point(const NodeGeometry& g, int cell, double u1, double u2) {
  if (g.corners == 4) return g.point((cell % 4 + u1) * 0.25, (cell / 4 + u2) * 0.25);
  if (u1 + u2 > 1.0) {
    u1 = 1.0 - u1;
    u2 = 1.0 - u2;
  }
  const TriCell& c = kTriCells.cell[cell];
  const double s = c.a[0] + u1 * (c.b[0] - c.a[0]) + u2 * (c.c[0] - c.a[0]);
  const double t = c.a[1] + u1 * (c.b[1] - c.a[1]) + u2 * (c.c[1] - c.a[1]);
  return g.point(s, t);
}

int magic_partner(int cell) {
  return kMagic[cell];
}

NodeVisibility::NodeVisibility(const Scene& scene) : mesh_(build_mesh(scene, {1, 0.0})) {
  embree_ = std::make_unique<EmbreeScene>(mesh_);
}

NodeVisibility::~NodeVisibility() = default;

int NodeVisibility::unblocked(const NodeGeometry& p, uint32_t p_polygon, const NodeKey& p_key,
                              const NodeGeometry& q, uint32_t q_polygon, const NodeKey& q_key,
                              uint64_t seed) const {
  Pcg32 rng(hash_combine(hash_combine(seed, p_key.hash()), q_key.hash()));
  SegmentPacket packet;
  packet.count = kVisibilityRays;
  for (int k = 0; k < kVisibilityRays; ++k) {
    const double a1 = rng.next_double(), a2 = rng.next_double();
    const double b1 = rng.next_double(), b2 = rng.next_double();
    set_segment(packet, k, stratum_point(p, k, a1, a2), stratum_point(q, kMagic[k], b1, b2));
  }
  bool blocked[16];
  embree_->occluded16(packet, blocked, p_polygon, q_polygon);
  int free = 0;
  for (int k = 0; k < kVisibilityRays; ++k) free += blocked[k] ? 0 : 1;
  return free;
}

int NodeVisibility::unblocked_segments(const Vec3* x, const Vec3* y, const uint32_t* x_polygon,
                                       const uint32_t* y_polygon, int count) const {
  if (count <= 0) return 0;
  SegmentPacket packet;
  packet.count = count;
  for (int k = 0; k < count; ++k) {
    set_segment(packet, k, x[k], y[k]);
  }
  bool blocked[16];
  embree_->occluded16_each(packet, blocked, x_polygon, y_polygon);
  int free = 0;
  for (int k = 0; k < count; ++k) free += blocked[k] ? 0 : 1;
  return free;
}

}  // namespace radlab::hier
