#include "scene/mesh.h"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>

#include "core/error.h"
#include "core/limits.h"
#include "core/text.h"
#include "scene/geometry.h"

namespace radlab {

void Mesh::corners(size_t element, std::vector<Vec3>& out) const {
  out.clear();
  for (uint32_t v : element_vertices(element)) out.push_back(vertices[v]);
}

namespace {

double longest_edge(const std::vector<Vec3>& v) {
  double longest = 0.0;
  for (size_t i = 0; i < v.size(); ++i)
    longest = std::max(longest, glm::distance(v[i], v[(i + 1) % v.size()]));
  return longest;
}

class MeshBuilder {
 public:
  explicit MeshBuilder(Mesh& mesh) : mesh_(mesh) { mesh_.first_vertex.push_back(0); }

  uint32_t add_vertex(const Vec3& p) {
    mesh_.vertices.push_back(p);
    return uint32_t(mesh_.vertices.size() - 1);
  }

  void add_element(std::initializer_list<uint32_t> corners, uint32_t polygon) {
    add_element(std::vector<uint32_t>(corners), polygon);
  }
  void add_element(const std::vector<uint32_t>& corners, uint32_t polygon) {
    std::vector<Vec3> p;
    for (uint32_t c : corners) {
      mesh_.vertex_index.push_back(c);
      p.push_back(mesh_.vertices[c]);
    }
    mesh_.first_vertex.push_back(uint32_t(mesh_.vertex_index.size()));
    mesh_.polygon.push_back(polygon);
    double a = geometry::area(p);
    mesh_.area.push_back(a);
    mesh_.normal.push_back(geometry::unit_normal(p));
    mesh_.centroid.push_back(geometry::centroid(p));
    mesh_.total_area += a;
  }

  // K x K bilinear grid over a planar convex quad: every sub-quad is planar and convex.
  void quad_grid(const std::vector<Vec3>& q, int k, uint32_t polygon) {
    std::vector<uint32_t> index(size_t(k + 1) * size_t(k + 1));
    for (int b = 0; b <= k; ++b)
      for (int a = 0; a <= k; ++a) {
        double s = double(a) / k, t = double(b) / k;
        Vec3 p = (1 - s) * (1 - t) * q[0] + s * (1 - t) * q[1] + s * t * q[2] + (1 - s) * t * q[3];
        index[size_t(b) * (k + 1) + a] = add_vertex(p);
      }
    for (int b = 0; b < k; ++b)
      for (int a = 0; a < k; ++a) {
        auto at = [&](int x, int y) { return index[size_t(y) * (k + 1) + x]; };
        add_element({at(a, b), at(a + 1, b), at(a + 1, b + 1), at(a, b + 1)}, polygon);
      }
  }

  // K^2 sub-triangles of a triangle (K along each edge), same orientation as the parent.
  void triangle_grid(const Vec3& p0, const Vec3& p1, const Vec3& p2, int k, uint32_t polygon) {
    // Row b (0..k) holds k-b+1 vertices: p0 + a/k (p1-p0) + b/k (p2-p0).
    std::vector<std::vector<uint32_t>> row(size_t(k + 1));
    for (int b = 0; b <= k; ++b)
      for (int a = 0; a + b <= k; ++a)
        row[size_t(b)].push_back(
            add_vertex(p0 + (double(a) / k) * (p1 - p0) + (double(b) / k) * (p2 - p0)));
    for (int b = 0; b < k; ++b)
      for (int a = 0; a + b < k; ++a) {
        add_element({row[b][a], row[b][a + 1], row[b + 1][a]}, polygon);
        if (a + b + 1 < k) add_element({row[b][a + 1], row[b + 1][a + 1], row[b + 1][a]}, polygon);
      }
  }

 private:
  Mesh& mesh_;
};

}  // namespace

double polygon_subdivisions(const std::vector<Vec3>& v, const MeshOptions& options) {
  if (options.element_size > 0)
    return std::max(1.0, std::ceil(longest_edge(v) / options.element_size - 1e-9));
  return std::max(1.0, double(options.subdivisions));
}

double estimate_elements(const Scene& scene, const MeshOptions& options) {
  double total = 0.0;
  for (const Polygon& polygon : scene.polygons) {
    const double k = polygon_subdivisions(polygon.vertices, options);
    const size_t n = polygon.vertices.size();
    // As build_mesh: a quad or triangle makes K^2, an unsplit n-gon 1, a fanned n-gon (n-2) K^2.
    total += n <= 4 ? k * k : k == 1 ? 1.0 : double(n - 2) * k * k;
  }
  return total;
}

Mesh build_mesh(const Scene& scene, const MeshOptions& options) {
  if (!(options.element_size >= 0) || !std::isfinite(options.element_size))
    throw UsageError("the element size must be a finite number > 0, got " +
                     text::format_double(options.element_size));
  const double estimate = estimate_elements(scene, options);
  const std::string mesh_name = options.element_size > 0
                                    ? "element size " + text::format_double(options.element_size)
                                    : "subdivision " + std::to_string(options.subdivisions);
  check_limit("elements", estimate, scene.name + ": mesh at " + mesh_name);
  // Vertex and element indices are 32-bit: beyond ~1e9 elements no limit may be raised.
  if (estimate > 1e9)
    throw InputError(scene.name + ": the mesh at " + mesh_name + " has " + format_count(estimate) +
                     " elements, beyond radlab's 32-bit indices");
  Mesh mesh;
  MeshBuilder builder(mesh);
  mesh.first_element_of_polygon.push_back(0);
  for (size_t p = 0; p < scene.polygons.size(); ++p) {
    const std::vector<Vec3>& v = scene.polygons[p].vertices;
    // At most sqrt(1e9) after the estimate above, so it fits an int.
    const int k = int(polygon_subdivisions(v, options));
    const auto polygon = uint32_t(p);
    if (v.size() == 4) {
      builder.quad_grid(v, k, polygon);
    } else if (v.size() == 3) {
      builder.triangle_grid(v[0], v[1], v[2], k, polygon);
    } else if (k == 1) {
      std::vector<uint32_t> corners;
      for (const Vec3& q : v) corners.push_back(builder.add_vertex(q));
      builder.add_element(corners, polygon);
    } else {
      // A convex n-gon: a fan of triangles, each subdivided.
      for (size_t i = 1; i + 1 < v.size(); ++i)
        builder.triangle_grid(v[0], v[i], v[i + 1], k, polygon);
    }
    mesh.first_element_of_polygon.push_back(uint32_t(mesh.size()));
  }
  return mesh;
}

}  // namespace radlab
