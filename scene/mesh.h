// The mesh: elements (the unknowns of the radiosity system) made by subdividing the polygons.
//
// Elements keep input order: all elements of polygon 0 first, then polygon 1, and so on. Within a
// polygon, elements share vertices (a structured grid), so images can interpolate radiosity
// smoothly across a polygon.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "scene/scene.h"

namespace radlab {

struct MeshOptions {
  int subdivisions = 1;       // K: a quad becomes K x K elements, a triangle K^2
  double element_size = 0.0;  // if > 0: choose K per polygon so edges are at most this long (m)
};

class Mesh {
 public:
  size_t size() const { return area.size(); }
  std::span<const uint32_t> element_vertices(size_t element) const {
    return {vertex_index.data() + first_vertex[element],
            first_vertex[element + 1] - first_vertex[element]};
  }
  // Copies the corner positions of an element (3 or 4, more only for unsplit n-gons).
  void corners(size_t element, std::vector<Vec3>& out) const;

  std::vector<Vec3> vertices;          // shared within a polygon
  std::vector<uint32_t> vertex_index;  // corners of all elements, concatenated
  std::vector<uint32_t> first_vertex;  // size()+1 offsets into vertex_index
  std::vector<uint32_t> polygon;       // the input polygon each element came from
  std::vector<double> area;
  std::vector<Vec3> normal;
  std::vector<Vec3> centroid;
  std::vector<uint32_t> first_element_of_polygon;  // polygons+1 offsets: elements of polygon p
  double total_area = 0.0;
};

// The subdivision K of one polygon, in double (`--element-size 1e-12` asks for 10^12 per edge,
// which must be seen before it becomes an int).
double polygon_subdivisions(const std::vector<Vec3>& vertices, const MeshOptions& options);

// The number of elements build_mesh makes, computed in double before anything is allocated.
double estimate_elements(const Scene& scene, const MeshOptions& options);

// Subdivides every polygon of a (validated) scene (subdivisions below 1 count as 1). Throws
// UsageError for an element size that is negative or not finite, and InputError when the element
// estimate exceeds limits().elements (core/limits.h), before allocating.
Mesh build_mesh(const Scene& scene, const MeshOptions& options);

}  // namespace radlab
