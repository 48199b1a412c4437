// RAII wrapper around Embree 3: one device and one static scene holding every mesh element as
// triangles (a quad is two, an n-gon a fan). Queries are thread-safe and map hits back to
// element ids. This is the only header that names Embree types (and only in the .cpp).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "scene/mesh.h"

namespace radlab {

struct RayHit {
  bool hit = false;
  uint32_t element = 0;
  double distance = 0.0;
};

// Up to 16 segments origin + t * direction, t in [t_near, t_far], in structure-of-arrays form:
// callers fill one in place and occluded16 hands it to Embree with one straight copy per field.
struct SegmentPacket {
  alignas(64) float ox[16], oy[16], oz[16];
  alignas(64) float dx[16], dy[16], dz[16];
  alignas(64) float t_near[16], t_far[16];
  int count = 0;  // segments in use, 1..16 (the first `count` lanes)
};

class EmbreeScene {
 public:
  explicit EmbreeScene(const Mesh& mesh);
  ~EmbreeScene();
  EmbreeScene(const EmbreeScene&) = delete;
  EmbreeScene& operator=(const EmbreeScene&) = delete;

  // True if anything blocks the open segment from `origin` along `direction` (not necessarily
  // normalised) between parameters t_near and t_far.
  bool occluded(const Vec3& origin, const Vec3& direction, double t_near, double t_far) const;

  // Up to 16 segments at once (Embree's packet path; coherent bundles run faster). Writes
  // out[k] = true if segment k < packet.count is blocked. Hits on the elements of input polygons
  // `skip_a` and `skip_b` (mesh.polygon ids; kNoPolygon for none) are ignored: a segment between
  // two elements can meet their own planar polygons only at its ends, so such hits are rounding
  // (rays grazing the polygon they start or end on), never occlusion.
  static constexpr uint32_t kNoPolygon = 0xFFFFFFFFu;
  void occluded16(const SegmentPacket& packet, bool* out, uint32_t skip_a = kNoPolygon,
                  uint32_t skip_b = kNoPolygon) const;

  // As occluded16, with the two polygons to ignore given per segment: skip_a[k] and skip_b[k]
  // for segment k (hierarchical radiosity's clusters join points of different polygons).
  void occluded16_each(const SegmentPacket& packet, bool* out, const uint32_t* skip_a,
                       const uint32_t* skip_b) const;

  // As occluded16, and hits that lie in either plane (point, unit normal) are ignored too: on a
  // triangle within ~0.8 degrees of parallel to it, at most `tolerance` from it. For the short
  // pieces of segments next to their ends (Visibility: what the ends' offsets leave out), where a
  // polygon coplanar with an end's element (its own, a neighbour, a back-to-back twin) is met
  // only by rounding, but a polygon crossing that plane (a wall the element touches) blocks.
  struct Plane {
    Vec3 point, normal;
    double tolerance = 0.0;
  };
  void occluded16_off_planes(const SegmentPacket& packet, bool* out, const Plane& a, const Plane& b,
                             uint32_t skip_a = kNoPolygon, uint32_t skip_b = kNoPolygon) const;

  // Appends to `out` every element with a triangle that may come within `radius` of `center`
  // (Embree's point query: every triangle in a leaf of its hierarchy whose box reaches the
  // sphere, so a superset of those the sphere meets); an element may appear more than once.
  void elements_near(const Vec3& center, double radius, std::vector<uint32_t>& out) const;

  // The closest element hit by a ray, if any.
  RayHit intersect(const Vec3& origin, const Vec3& direction, double t_near, double t_far) const;

  // The closest hits of `count` rays origins[k] + t directions[k], t in [t_near, t_far], through
  // Embree's stream call (rtcIntersect1M, flagged incoherent: the rays point every way): out[k]
  // as intersect() gives, without a call, a context and a ray record per ray.
  void intersect_stream(const Vec3* origins, const Vec3* directions, size_t count, double t_near,
                        double t_far, RayHit* out) const;

  size_t triangle_count() const { return triangle_element_.size(); }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  void occluded16_with(const SegmentPacket& packet, bool* out, void* context) const;
  std::vector<uint32_t> triangle_element_;
  std::vector<uint32_t> triangle_polygon_;
};

}  // namespace radlab
