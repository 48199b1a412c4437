#include "formfactor/visibility/embree_scene.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <limits>
#include <string>

#include "core/error.h"

namespace radlab {

struct EmbreeScene::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  ~Impl() {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
  }
};

namespace {

// An intersection context that carries the two polygons whose hits are to be ignored. Embree
// passes the context it was given to the filter unchanged, so the filter can cast back.
struct SkipContext {
  RTCIntersectContext context;  // first member: a SkipContext* is a valid RTCIntersectContext*
  const uint32_t* triangle_polygon;
  uint32_t skip_a, skip_b;
};

void skip_polygons(const RTCFilterFunctionNArguments* args) {
  const auto* skip = reinterpret_cast<const SkipContext*>(args->context);
  for (unsigned k = 0; k < args->N; ++k) {
    if (args->valid[k] == 0) continue;
    const uint32_t polygon = skip->triangle_polygon[RTCHitN_primID(args->hit, args->N, k)];
    if (polygon == skip->skip_a || polygon == skip->skip_b) args->valid[k] = 0;
  }
}

// Per-segment polygons to ignore (occluded16_each): the lane is the ray's id.
struct SkipEachContext {
  RTCIntersectContext context;  // first member, as above
  const uint32_t* triangle_polygon;
  uint32_t skip_a[16], skip_b[16];
};

void skip_polygons_each(const RTCFilterFunctionNArguments* args) {
  const auto* skip = reinterpret_cast<const SkipEachContext*>(args->context);
  for (unsigned k = 0; k < args->N; ++k) {
    if (args->valid[k] == 0) continue;
    const unsigned lane = RTCRayN_id(args->ray, args->N, k) & 15u;
    const uint32_t polygon = skip->triangle_polygon[RTCHitN_primID(args->hit, args->N, k)];
    if (polygon == skip->skip_a[lane] || polygon == skip->skip_b[lane]) args->valid[k] = 0;
  }
}

// The same, and the two planes whose own hits are ignored (occluded16_off_planes).
struct OffPlanesContext {
  SkipContext skip;  // first member, as above
  EmbreeScene::Plane planes[2];
};

bool in_plane(const EmbreeScene::Plane& plane, const Vec3& point, const Vec3& triangle_normal) {
  const double length = glm::length(triangle_normal);
  return length > 0.0 &&
         std::abs(glm::dot(triangle_normal, plane.normal)) >= (1.0 - 1e-4) * length &&
         std::abs(glm::dot(point - plane.point, plane.normal)) <= plane.tolerance;
}

void skip_polygons_and_planes(const RTCFilterFunctionNArguments* args) {
  skip_polygons(args);
  const auto* off = reinterpret_cast<const OffPlanesContext*>(args->context);
  for (unsigned k = 0; k < args->N; ++k) {
    if (args->valid[k] == 0) continue;
    // During the filter call the ray's tfar holds the candidate hit's distance.
    const double t = double(RTCRayN_tfar(args->ray, args->N, k));
    const Vec3 hit(double(RTCRayN_org_x(args->ray, args->N, k)) +
                       t * double(RTCRayN_dir_x(args->ray, args->N, k)),
                   double(RTCRayN_org_y(args->ray, args->N, k)) +
                       t * double(RTCRayN_dir_y(args->ray, args->N, k)),
                   double(RTCRayN_org_z(args->ray, args->N, k)) +
                       t * double(RTCRayN_dir_z(args->ray, args->N, k)));
    const Vec3 normal(double(RTCHitN_Ng_x(args->hit, args->N, k)),
                      double(RTCHitN_Ng_y(args->hit, args->N, k)),
                      double(RTCHitN_Ng_z(args->hit, args->N, k)));
    if (in_plane(off->planes[0], hit, normal) || in_plane(off->planes[1], hit, normal))
      args->valid[k] = 0;
  }
}

void check_device(RTCDevice device, const char* what) {
  RTCError error = rtcGetDeviceError(device);
  if (error != RTC_ERROR_NONE)
    throw NumericalError(std::string("Embree failed during ") + what + " (error " +
                         std::to_string(int(error)) + ")");
}

// One ray of a closest-hit query, in Embree's single-precision layout (single calls and streams).
inline void set_ray(RTCRayHit& rh, const Vec3& o, const Vec3& d, double t_near, double t_far,
                    unsigned id) {
  rh.ray.org_x = float(o.x);
  rh.ray.org_y = float(o.y);
  rh.ray.org_z = float(o.z);
  rh.ray.dir_x = float(d.x);
  rh.ray.dir_y = float(d.y);
  rh.ray.dir_z = float(d.z);
  rh.ray.tnear = float(t_near);
  rh.ray.tfar = float(t_far);
  rh.ray.time = 0.0f;
  rh.ray.mask = 0xFFFFFFFFu;
  rh.ray.id = id;
  rh.ray.flags = 0;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
}

}  // namespace

EmbreeScene::EmbreeScene(const Mesh& mesh) : impl_(std::make_unique<Impl>()) {
  impl_->device = rtcNewDevice(nullptr);
  if (!impl_->device) throw NumericalError("Embree: cannot create a device");
  impl_->scene = rtcNewScene(impl_->device);
  // Robust mode: rays between points on touching elements must not slip through shared edges.
  // Context filters: occluded16 can ignore the polygons a segment starts and ends on.
  rtcSetSceneFlags(impl_->scene,
                   RTCSceneFlags(RTC_SCENE_FLAG_ROBUST | RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION));
  rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_HIGH);

  std::vector<uint32_t> triangles;
  for (size_t e = 0; e < mesh.size(); ++e) {
    auto corners = mesh.element_vertices(e);
    for (size_t k = 1; k + 1 < corners.size(); ++k) {
      triangles.insert(triangles.end(), {corners[0], corners[k], corners[k + 1]});
      triangle_element_.push_back(uint32_t(e));
      triangle_polygon_.push_back(mesh.polygon[e]);
    }
  }
  RTCGeometry geometry = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0,
                                                         RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                                         mesh.vertices.size()));
  for (size_t v = 0; v < mesh.vertices.size(); ++v)
    for (int c = 0; c < 3; ++c) vb[3 * v + size_t(c)] = float(mesh.vertices[v][c]);
  auto* ib = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0,
                                                            RTC_FORMAT_UINT3, 3 * sizeof(uint32_t),
                                                            triangles.size() / 3));
  std::copy(triangles.begin(), triangles.end(), ib);
  rtcCommitGeometry(geometry);
  rtcAttachGeometry(impl_->scene, geometry);
  rtcReleaseGeometry(geometry);
  rtcCommitScene(impl_->scene);
  check_device(impl_->device, "scene build");
}

EmbreeScene::~EmbreeScene() = default;

bool EmbreeScene::occluded(const Vec3& o, const Vec3& d, double t_near, double t_far) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRay ray;
  ray.org_x = float(o.x);
  ray.org_y = float(o.y);
  ray.org_z = float(o.z);
  ray.dir_x = float(d.x);
  ray.dir_y = float(d.y);
  ray.dir_z = float(d.z);
  ray.tnear = float(t_near);
  ray.tfar = float(t_far);
  ray.time = 0.0f;
  ray.mask = 0xFFFFFFFFu;
  ray.id = 0;
  ray.flags = 0;
  rtcOccluded1(impl_->scene, &context, &ray);
  return ray.tfar < 0.0f;  // Embree sets tfar to -inf when blocked
}

void EmbreeScene::occluded16(const SegmentPacket& packet, bool* out, uint32_t skip_a,
                             uint32_t skip_b) const {
  SkipContext skip;
  rtcInitIntersectContext(&skip.context);
  skip.context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  skip.triangle_polygon = triangle_polygon_.data();
  skip.skip_a = skip_a;
  skip.skip_b = skip_b;
  if (skip_a != kNoPolygon || skip_b != kNoPolygon) skip.context.filter = skip_polygons;
  occluded16_with(packet, out, &skip.context);
}

void EmbreeScene::occluded16_each(const SegmentPacket& packet, bool* out, const uint32_t* skip_a,
                                  const uint32_t* skip_b) const {
  SkipEachContext skip;
  rtcInitIntersectContext(&skip.context);
  skip.context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  skip.triangle_polygon = triangle_polygon_.data();
  for (int k = 0; k < 16; ++k) {
    skip.skip_a[k] = k < packet.count ? skip_a[k] : kNoPolygon;
    skip.skip_b[k] = k < packet.count ? skip_b[k] : kNoPolygon;
  }
  skip.context.filter = skip_polygons_each;
  occluded16_with(packet, out, &skip.context);
}

void EmbreeScene::occluded16_off_planes(const SegmentPacket& packet, bool* out, const Plane& a,
                                        const Plane& b, uint32_t skip_a, uint32_t skip_b) const {
  OffPlanesContext off;
  rtcInitIntersectContext(&off.skip.context);
  off.skip.context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  off.skip.triangle_polygon = triangle_polygon_.data();
  off.skip.skip_a = skip_a;
  off.skip.skip_b = skip_b;
  off.skip.context.filter = skip_polygons_and_planes;
  off.planes[0] = a;
  off.planes[1] = b;
  occluded16_with(packet, out, &off.skip.context);
}

void EmbreeScene::occluded16_with(const SegmentPacket& packet, bool* out, void* context) const {
  alignas(64) RTCRay16 rays;
  alignas(64) int valid[16];
  // Whole-width copies (they vectorise); lanes past `count` are masked off by `valid` but still
  // get lane 0's finite values, so Embree never reads uninitialised floats.
  for (int k = 0; k < 16; ++k) {
    rays.org_x[k] = packet.ox[k];
    rays.org_y[k] = packet.oy[k];
    rays.org_z[k] = packet.oz[k];
    rays.dir_x[k] = packet.dx[k];
    rays.dir_y[k] = packet.dy[k];
    rays.dir_z[k] = packet.dz[k];
    rays.tnear[k] = packet.t_near[k];
    rays.tfar[k] = packet.t_far[k];
    rays.time[k] = 0.0f;
    rays.mask[k] = 0xFFFFFFFFu;
    rays.id[k] = unsigned(k);
    rays.flags[k] = 0;
    valid[k] = k < packet.count ? -1 : 0;
  }
  for (int k = packet.count; k < 16; ++k) {
    rays.org_x[k] = packet.ox[0];
    rays.org_y[k] = packet.oy[0];
    rays.org_z[k] = packet.oz[0];
    rays.dir_x[k] = packet.dx[0];
    rays.dir_y[k] = packet.dy[0];
    rays.dir_z[k] = packet.dz[0];
    rays.tnear[k] = packet.t_near[0];
    rays.tfar[k] = packet.t_far[0];
  }
  rtcOccluded16(valid, impl_->scene, static_cast<RTCIntersectContext*>(context), &rays);
  for (int k = 0; k < packet.count; ++k) out[k] = rays.tfar[k] < 0.0f;
}

void EmbreeScene::elements_near(const Vec3& center, double radius,
                                std::vector<uint32_t>& out) const {
  struct Found {
    const uint32_t* triangle_element;
    std::vector<uint32_t>* out;
  } found{triangle_element_.data(), &out};
  RTCPointQuery query;
  query.x = float(center.x);
  query.y = float(center.y);
  query.z = float(center.z);
  query.time = 0.0f;
  // Rounded up, so that the float sphere holds the double one.
  query.radius = std::nextafter(float(radius), std::numeric_limits<float>::infinity());
  RTCPointQueryContext context;
  rtcInitPointQueryContext(&context);
  const RTCPointQueryFunction collect = [](RTCPointQueryFunctionArguments* args) {
    const auto* f = static_cast<const Found*>(args->userPtr);
    f->out->push_back(f->triangle_element[args->primID]);
    return false;  // the query's radius is unchanged
  };
  rtcPointQuery(impl_->scene, &query, &context, collect, &found);
}

RayHit EmbreeScene::intersect(const Vec3& o, const Vec3& d, double t_near, double t_far) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit rh;
  set_ray(rh, o, d, t_near, t_far, 0);
  rtcIntersect1(impl_->scene, &context, &rh);
  RayHit result;
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return result;
  result.hit = true;
  result.element = triangle_element_[rh.hit.primID];
  result.distance = double(rh.ray.tfar);
  return result;
}

void EmbreeScene::intersect_stream(const Vec3* origins, const Vec3* directions, size_t count,
                                   double t_near, double t_far, RayHit* out) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  context.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
  constexpr size_t kChunk = 64;
  alignas(64) RTCRayHit rays[kChunk];
  for (size_t first = 0; first < count; first += kChunk) {
    const size_t size = std::min(kChunk, count - first);
    for (size_t k = 0; k < size; ++k) {
      set_ray(rays[k], origins[first + k], directions[first + k], t_near, t_far, unsigned(k));
    }
    rtcIntersect1M(impl_->scene, &context, rays, unsigned(size), sizeof(RTCRayHit));
    for (size_t k = 0; k < size; ++k) {
      const RTCRayHit& rh = rays[k];
      out[first + k] = rh.hit.geomID == RTC_INVALID_GEOMETRY_ID
                           ? RayHit{}
                           : RayHit{true, triangle_element_[rh.hit.primID], double(rh.ray.tfar)};
    }
  }
}

}  // namespace radlab
