#include "render/renderer.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <numbers>
#include <vector>

namespace radlab {
namespace {

// Coordinates in the element's plane: two orthonormal axes perpendicular to the normal.
void plane_axes(const Vec3& n, Vec3& u, Vec3& v) {
  const Vec3 a = std::abs(n.x) < 0.9 ? Vec3(1, 0, 0) : Vec3(0, 1, 0);
  u = glm::normalize(glm::cross(n, a));
  v = glm::cross(n, u);
}

// Inverse of the bilinear map of a planar quad, by Newton's method from the centre (a planar
// convex quad's map is invertible; three or four iterations converge to rounding).
void inverse_bilinear(std::span<const Vec3> c, const Vec3& n, const Vec3& p, double& s,
                      double& t) {
  Vec3 u, v;
  plane_axes(n, u, v);
  auto to2 = [&](const Vec3& q) { return glm::dvec2(glm::dot(q - c[0], u), glm::dot(q - c[0], v)); };
  const glm::dvec2 a = to2(c[0]), b = to2(c[1]), cc = to2(c[2]), d = to2(c[3]), target = to2(p);
  s = t = 0.5;
  for (int iteration = 0; iteration < 8; ++iteration) {
    const glm::dvec2 f = (1 - s) * (1 - t) * a + s * (1 - t) * b + s * t * cc + (1 - s) * t * d -
                         target;
    const glm::dvec2 fs = (1 - t) * (b - a) + t * (cc - d);
    const glm::dvec2 ft = (1 - s) * (d - a) + s * (cc - b);
    const double det = fs.x * ft.y - fs.y * ft.x;
    if (det == 0) break;
    const double ds = (f.x * ft.y - f.y * ft.x) / det;
    const double dt = (fs.x * f.y - fs.y * f.x) / det;
    s -= ds;
    t -= dt;
    if (std::abs(ds) + std::abs(dt) < 1e-12) break;
  }
  s = std::clamp(s, 0.0, 1.0);
  t = std::clamp(t, 0.0, 1.0);
}

}  // namespace

void interpolation_weights(std::span<const Vec3> c, const Vec3& n, const Vec3& p,
                           std::span<double> w) {
  if (c.size() == 3) {
    const double area = glm::dot(glm::cross(c[1] - c[0], c[2] - c[0]), n);
    w[0] = glm::dot(glm::cross(c[1] - p, c[2] - p), n) / area;
    w[1] = glm::dot(glm::cross(c[2] - p, c[0] - p), n) / area;
    w[2] = 1.0 - w[0] - w[1];
    return;
  }
  if (c.size() == 4) {
    double s = 0, t = 0;
    inverse_bilinear(c, n, p, s, t);
    w[0] = (1 - s) * (1 - t);
    w[1] = s * (1 - t);
    w[2] = s * t;
    w[3] = (1 - s) * t;
    return;
  }
  // Mean-value coordinates (Floater 2003): smooth inside a convex polygon, exact at vertices.
  const size_t m = c.size();
  double total = 0.0;
  for (size_t i = 0; i < m; ++i) {
    const Vec3 d = c[i] - p;
    const double r = glm::length(d);
    if (r < 1e-14) {
      std::fill(w.begin(), w.end(), 0.0);
      w[i] = 1.0;
      return;
    }
    auto half_tan = [&](const Vec3& a, const Vec3& b) {
      const double angle = std::atan2(glm::dot(glm::cross(a, b), n), glm::dot(a, b));
      return std::tan(0.5 * angle);
    };
    const Vec3 prev = c[(i + m - 1) % m] - p, next = c[(i + 1) % m] - p;
    w[i] = (half_tan(prev, d) + half_tan(d, next)) / r;
    total += w[i];
  }
  for (size_t i = 0; i < m; ++i) w[i] /= total;
}

Camera default_camera(const Mesh& mesh) {
  Vec3 lo(1e300), hi(-1e300);
  for (const Vec3& v : mesh.vertices) {
    lo = glm::min(lo, v);
    hi = glm::max(hi, v);
  }
  const Vec3 centre = 0.5 * (lo + hi);
  const double radius = std::max(0.5 * glm::length(hi - lo), 1e-9);
  Camera camera;
  camera.vertical_fov_degrees = 45.0;
  // Far enough that the bounding sphere fits the 45-degree view.
  const double distance = radius / std::sin(0.5 * camera.vertical_fov_degrees * std::numbers::pi / 180);
  camera.eye = centre + distance * glm::normalize(Vec3(0.6, 0.5, -1.0));
  camera.look_at = centre;
  camera.up = Vec3(0, 1, 0);
  return camera;
}

Image render_field(const Mesh& mesh, const EmbreeScene& embree,
                   std::span<const glm::dvec3> values, const Camera& camera, int width, int height,
                   bool smooth) {
  // Vertex values: area-weighted means of the elements sharing each vertex.
  std::vector<glm::dvec3> vertex_value;
  if (smooth) {
    vertex_value.assign(mesh.vertices.size(), glm::dvec3(0.0));
    std::vector<double> weight(mesh.vertices.size(), 0.0);
    for (size_t e = 0; e < mesh.size(); ++e)
      for (uint32_t v : mesh.element_vertices(e)) {
        vertex_value[v] += mesh.area[e] * values[e];
        weight[v] += mesh.area[e];
      }
    for (size_t v = 0; v < vertex_value.size(); ++v)
      if (weight[v] > 0) vertex_value[v] /= weight[v];
  }
  const Vec3 forward = glm::normalize(camera.look_at - camera.eye);
  const Vec3 right = glm::normalize(glm::cross(forward, camera.up));
  const Vec3 up = glm::cross(right, forward);
  const double tan_half = std::tan(0.5 * camera.vertical_fov_degrees * std::numbers::pi / 180.0);
  const double aspect = double(width) / double(height);
  Image image(width, height);
  tbb::parallel_for(tbb::blocked_range<int>(0, height), [&](const tbb::blocked_range<int>& rows) {
    std::vector<Vec3> corners;
    std::vector<double> weights;
    for (int y = rows.begin(); y != rows.end(); ++y)
      for (int x = 0; x < width; ++x) {
        glm::dvec3 sum(0.0);
        for (int sample = 0; sample < 4; ++sample) {
          const double sx = x + 0.25 + 0.5 * (sample & 1);
          const double sy = y + 0.25 + 0.5 * (sample >> 1);
          const double px = (2.0 * sx / width - 1.0) * aspect * tan_half;
          const double py = (1.0 - 2.0 * sy / height) * tan_half;
          const Vec3 direction = glm::normalize(forward + px * right + py * up);
          const RayHit hit = embree.intersect(camera.eye, direction, 0.0, 1e30);
          if (!hit.hit) continue;
          const size_t e = hit.element;
          if (glm::dot(direction, mesh.normal[e]) >= 0.0) continue;  // the back of a surface
          if (!smooth) {
            sum += values[e];
            continue;
          }
          // Project the hit onto the element's plane (Embree works in float).
          Vec3 p = camera.eye + hit.distance * direction;
          p -= glm::dot(p - mesh.centroid[e], mesh.normal[e]) * mesh.normal[e];
          mesh.corners(e, corners);
          weights.resize(corners.size());
          interpolation_weights(corners, mesh.normal[e], p, weights);
          const auto vertices = mesh.element_vertices(e);
          for (size_t k = 0; k < vertices.size(); ++k)
            sum += weights[k] * vertex_value[vertices[k]];
        }
        float* out = image.pixel(x, y);
        for (int c = 0; c < 3; ++c) out[c] = float(0.25 * sum[c]);
      }
  });
  return image;
}

Image render_radiosity(const Mesh& mesh, const EmbreeScene& embree, const Radiosity& values,
                       const Camera& camera, int width, int height) {
  std::vector<glm::dvec3> rgb(values.size());
  for (size_t i = 0; i < values.size(); ++i) rgb[i] = values.rgb(i);
  return render_field(mesh, embree, rgb, camera, width, height, true);
}

}  // namespace radlab
