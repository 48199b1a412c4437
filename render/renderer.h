// Images of a per-element field seen through a pinhole camera: Embree primary rays, 2x2
// stratified samples per pixel (fixed pattern, deterministic), one-sided surfaces (a ray that
// meets the back of an element sees black, like light leaving it).
//
// Smooth mode interpolates across the elements of one input polygon the way radiosity images are
// classically shown (Gouraud shading of element vertex values, Cohen 1988 §3.4): each vertex takes
// the area-weighted mean of the elements sharing it (vertices are shared only within a polygon,
// so creases stay sharp), and the hit point interpolates its element's vertex values — barycentric
// on triangles, inverse bilinear on quads, mean-value coordinates on larger polygons. Flat mode
// shows each element's own value (error maps must not blur).
#pragma once

#include <glm/vec3.hpp>
#include <span>

#include "core/radiosity.h"
#include "formfactor/embree_scene.h"
#include "render/image.h"
#include "scene/mesh.h"

namespace radlab {

// A view of the whole mesh from outside its bounding box, along a fixed diagonal, 45 degrees.
Camera default_camera(const Mesh& mesh);

Image render_field(const Mesh& mesh, const EmbreeScene& embree,
                   std::span<const glm::dvec3> element_values, const Camera& camera, int width,
                   int height, bool smooth);

// Smooth image of a radiosity solution (grey solutions render grey).
Image render_radiosity(const Mesh& mesh, const EmbreeScene& embree, const Radiosity& values,
                       const Camera& camera, int width, int height);

// Interpolation weights of point p (in the element's plane) over the element's corners; they sum
// to 1 and reproduce affine functions. Exposed for tests.
void interpolation_weights(std::span<const Vec3> corners, const Vec3& normal, const Vec3& p,
                           std::span<double> weights);

}  // namespace radlab
