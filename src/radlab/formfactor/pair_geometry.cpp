#include "radlab/formfactor/pair_geometry.h"

#include <algorithm>
#include <glm/geometric.hpp>

#include "radlab/scene/geometry.h"

namespace radlab {

std::vector<double> element_radii(const Mesh& mesh) {
  std::vector<double> radius(mesh.size());
  for (size_t e = 0; e < mesh.size(); ++e) {
    double r = 0.0;
    for (uint32_t v : mesh.element_vertices(e))
      r = std::max(r, glm::distance(mesh.vertices[v], mesh.centroid[e]));
    radius[e] = r;
  }
  return radius;
}

double grazing_scale(const Mesh& mesh, size_t i, size_t j, std::span<const Vec3> from, double kept,
                     double diameter) {
  double height_max = 0.0;
  for (const Vec3& v : from)
    height_max = std::max(height_max, glm::dot(v - mesh.centroid[j], mesh.normal[j]));
  const Vec3 centre = kept < 1.0 ? geometry::centroid(from) : mesh.centroid[i];
  const double height_mean = glm::dot(centre - mesh.centroid[j], mesh.normal[j]);
  const double slope = glm::length(glm::cross(mesh.normal[i], mesh.normal[j]));
  return height_mean / (height_max + slope * diameter);
}

}  // namespace radlab
