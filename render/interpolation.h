// Smooth shading of per-element values, the way radiosity images are classically shown
// (Gouraud shading of element vertex values, Cohen et al. 1988 §3.4: "the radiosity at the
// vertices interpolated from adjacent elements").
//
// 1. Vertex values: each mesh vertex takes the area-weighted mean of the elements of its own
//    polygon that touch it. Vertices are shared only within an input polygon, so creases between
//    polygons stay sharp; vertices of one polygon at the same position (the mesher repeats the
//    points on the fan diagonals of a subdivided n-gon) are merged first, so there is no seam
//    inside a polygon either.
// 2. Inside an element, the value interpolates its corners' values: barycentric coordinates on
//    triangles, inverse bilinear coordinates on quads (the mesher's quads are bilinear grid cells),
//    mean-value coordinates (Floater 2003) on the larger convex polygons left unsplit. All three
//    are exact at the corners, linear along each edge (so neighbours agree on a shared edge: the
//    image is continuous across a polygon) and reproduce affine fields exactly.
#pragma once

#include <glm/vec3.hpp>
#include <span>
#include <vector>

#include "scene/mesh.h"

namespace radlab {

// Weights of point p over the corners of a planar convex polygon with unit normal `normal`
// (either orientation); p is taken in the polygon's plane. `weights` has one entry per corner.
// They sum to 1, are 1 at their own corner and reproduce affine functions. Slightly outside the
// polygon (rounding of a ray hit) they extrapolate smoothly (quads: clamped to the quad).
void interpolation_weights(std::span<const Vec3> corners, const Vec3& normal, const Vec3& p,
                           std::span<double> weights);

// Per mesh vertex: the area-weighted mean of `element_values` (one per element) over the
// elements of the vertex's polygon that touch it or a vertex of that polygon at the same
// position. Vertices no element uses get 0.
std::vector<glm::dvec3> smooth_vertex_values(const Mesh& mesh,
                                             std::span<const glm::dvec3> element_values);

// The value at point p on element `element` (p is projected onto the element's plane first),
// interpolated from `vertex_values` (one per mesh vertex, e.g. from smooth_vertex_values).
glm::dvec3 interpolate_on_element(const Mesh& mesh, std::span<const glm::dvec3> vertex_values,
                                  size_t element, const Vec3& p);

}  // namespace radlab
