// The pinhole renderer: camera rays, Embree hits, flat or interpolated element values.
#include "render/renderer.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/error.h"

namespace radlab {
namespace {

double radians(double degrees) {
  return degrees * std::numbers::pi / 180.0;
}

bool finite(const Vec3& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

// Camera rays for a width x height image: image x runs right, image y runs down.
class PinholeView {
 public:
  PinholeView(const Camera& camera, int width, int height)
      : eye_(camera.eye), width_(width), height_(height) {
    forward_ = glm::normalize(camera.look_at - camera.eye);
    right_ = glm::normalize(glm::cross(forward_, camera.up));
    up_ = glm::cross(right_, forward_);
    tan_half_ = std::tan(0.5 * radians(camera.vertical_fov_degrees));
    aspect_ = double(width) / double(height);
  }
  const Vec3& eye() const { return eye_; }
  // Unit direction through image point (x, y) in pixel units, (0,0) the top-left corner.
  Vec3 direction(double x, double y) const {
    const double px = (2.0 * x / width_ - 1.0) * aspect_ * tan_half_;
    const double py = (1.0 - 2.0 * y / height_) * tan_half_;
    return glm::normalize(forward_ + px * right_ + py * up_);
  }

 private:
  Vec3 eye_, forward_, right_, up_;
  int width_, height_;
  double tan_half_ = 0.0, aspect_ = 1.0;
};

// Sample offsets inside a pixel: the centres of its 2x2 strata.
constexpr double kSampleOffset[4][2] = {{0.25, 0.25}, {0.75, 0.25}, {0.25, 0.75}, {0.75, 0.75}};

// The first hit on the front of an element: the backs of surfaces are culled (rays pass through
// them). Each step restarts just beyond the last hit; 1e-6 relative is well above float rounding
// of the hit distance, so the same triangle is never found twice. Gives up (a miss) after
// kMaxLayers backs, which only a pathological stack of surfaces reaches.
RayHit first_front_hit(const Mesh& mesh, const EmbreeScene& embree, const Vec3& eye,
                       const Vec3& direction) {
  constexpr int kMaxLayers = 32;
  double t_near = 0.0;
  for (int layer = 0; layer < kMaxLayers; ++layer) {
    const RayHit hit = embree.intersect(eye, direction, t_near, std::numeric_limits<float>::max());
    if (!hit.hit || glm::dot(direction, mesh.normal[hit.element]) < 0.0) return hit;
    t_near = hit.distance * (1.0 + 1e-6) + 1e-12;
  }
  return RayHit{};
}

}  // namespace

void check_camera(const Camera& camera) {
  if (!finite(camera.eye) || !finite(camera.look_at) || !finite(camera.up) ||
      !std::isfinite(camera.vertical_fov_degrees))
    throw InputError("camera: eye, look_at, up and vertical_fov_degrees must be finite");
  if (!(camera.vertical_fov_degrees > 0.0 && camera.vertical_fov_degrees < 180.0))
    throw InputError("camera: vertical_fov_degrees = " +
                     std::to_string(camera.vertical_fov_degrees) + " must lie in (0, 180)");
  const Vec3 view = camera.look_at - camera.eye;
  if (glm::length(view) == 0.0) throw InputError("camera: eye and look_at are the same point");
  const double up = glm::length(camera.up);
  if (!(glm::length(glm::cross(glm::normalize(view), camera.up)) > 1e-9 * up))
    throw InputError("camera: up is zero or parallel to the view direction");
}

Camera default_camera(const Mesh& mesh, double aspect) {
  if (mesh.vertices.empty()) throw InputError("default_camera: the mesh is empty, nothing to view");
  Vec3 lo(std::numeric_limits<double>::infinity()), hi(-lo);
  for (const Vec3& v : mesh.vertices) {
    lo = glm::min(lo, v);
    hi = glm::max(hi, v);
  }
  const Vec3 centre = 0.5 * (lo + hi);
  // A flat or point-like mesh still gets a finite distance.
  const double radius = std::max(0.5 * glm::length(hi - lo), 1e-6 * (1.0 + glm::length(centre)));
  Camera camera;
  camera.vertical_fov_degrees = 45.0;
  const double tan_vertical = std::tan(0.5 * radians(camera.vertical_fov_degrees));
  // 5% margin, so the box does not touch the frame.
  const double tan_half = 0.95 * tan_vertical * std::min(1.0, aspect > 0.0 ? aspect : 1.0);
  // A sphere of radius r is inside a cone of half-angle a seen from distance r / sin(a).
  const double distance = radius / std::sin(std::atan(tan_half));
  camera.eye = centre + distance * glm::normalize(Vec3(0.6, 0.5, -1.0));
  camera.look_at = centre;
  camera.up = Vec3(0.0, 1.0, 0.0);
  return camera;
}

Image render_field(const Mesh& mesh, const EmbreeScene& embree, std::span<const glm::dvec3> values,
                   const Camera& camera, int width, int height, bool smooth) {
  if (values.size() != mesh.size())
    throw std::invalid_argument("render_field: " + std::to_string(values.size()) + " values for " +
                                std::to_string(mesh.size()) + " elements");
  if (width < 1 || height < 1)
    throw UsageError("image size " + std::to_string(width) + "x" + std::to_string(height) +
                     ": width and height must be at least 1");
  check_camera(camera);
  std::vector<glm::dvec3> vertex_values;
  if (smooth) vertex_values = smooth_vertex_values(mesh, values);
  const PinholeView view(camera, width, height);
  Image image(width, height);
  tbb::parallel_for(tbb::blocked_range<int>(0, height), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y != rows.end(); ++y)
      for (int x = 0; x < width; ++x) {
        glm::dvec3 sum(0.0);
        for (const auto& offset : kSampleOffset) {
          const Vec3 direction = view.direction(x + offset[0], y + offset[1]);
          const RayHit hit = first_front_hit(mesh, embree, view.eye(), direction);
          if (!hit.hit) continue;
          const size_t e = hit.element;
          sum += smooth ? interpolate_on_element(mesh, vertex_values, e,
                                                 view.eye() + hit.distance * direction)
                        : values[e];
        }
        float* out = image.pixel(x, y);
        for (int c = 0; c < 3; ++c) out[c] = float(sum[c] / double(std::size(kSampleOffset)));
      }
  });
  return image;
}

Image render_radiosity(const Mesh& mesh, const EmbreeScene& embree, const Radiosity& values,
                       const Camera& camera, int width, int height, bool smooth) {
  std::vector<glm::dvec3> rgb(values.size());
  for (size_t i = 0; i < values.size(); ++i) rgb[i] = values.rgb(i);
  return render_field(mesh, embree, rgb, camera, width, height, smooth);
}

}  // namespace radlab
