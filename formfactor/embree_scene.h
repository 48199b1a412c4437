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
  // out[k] = true if ray k is blocked. `count` <= 16. Hits on the elements of input polygons
  // `skip_a` and `skip_b` (mesh.polygon ids; kNoPolygon for none) are ignored: a segment between
  // two elements can meet their own planar polygons only at its ends, so such hits are rounding
  // (rays grazing the polygon they start or end on), never occlusion.
  static constexpr uint32_t kNoPolygon = 0xFFFFFFFFu;
  void occluded16(const float* ox, const float* oy, const float* oz, const float* dx,
                  const float* dy, const float* dz, const float* t_near, const float* t_far,
                  int count, bool* out, uint32_t skip_a = kNoPolygon,
                  uint32_t skip_b = kNoPolygon) const;

  // The closest element hit by a ray, if any.
  RayHit intersect(const Vec3& origin, const Vec3& direction, double t_near, double t_far) const;

  size_t triangle_count() const { return triangle_element_.size(); }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::vector<uint32_t> triangle_element_;
  std::vector<uint32_t> triangle_polygon_;
};

}  // namespace radlab
