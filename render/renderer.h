// Images of a per-element field seen through a pinhole camera, traced with Embree primary rays.
//
// - Anti-aliasing: 2x2 stratified samples per pixel at the centres of the four strata, averaged
//   (a box filter). Fixed, not jittered, so images are deterministic and identical between runs
//   and thread counts; 4 rays per pixel smooth element and polygon edges enough for viewing.
// - Back faces are culled, as a z-buffer display with back-face culling does: surfaces are
//   one-sided (light leaves the front only, scene.h), so a ray passes through the back of an
//   element and sees what lies behind it. A closed room seen from outside (default_camera) thus
//   shows its inside through the near walls. A ray that meets no front face gives black.
// - smooth = true: Gouraud-style interpolation across the elements of each input polygon
//   (interpolation.h), for radiosity images. smooth = false: each element shows its own value,
//   for error maps, which must not blur one element's error into its neighbours.
//
// Rows are traced in parallel with TBB; the result does not depend on the thread count.
#pragma once

#include <glm/vec3.hpp>
#include <span>

#include "core/radiosity.h"
#include "formfactor/visibility/embree_scene.h"
#include "render/image.h"
#include "render/interpolation.h"
#include "scene/mesh.h"
#include "scene/scene.h"

namespace radlab {

// A view for scenes without a camera: looks at the centre of the mesh's bounding box from
// outside, along the fixed diagonal (0.6, 0.5, -1) (from +x, above, -z), up = +y, vertical field
// of view 45 degrees, far enough that the box's bounding sphere fits the view with a 5% margin of
// an image of the given aspect (width / height; the sphere is fitted to the narrower of the two
// directions). Throws InputError for an empty mesh (nothing to frame).
Camera default_camera(const Mesh& mesh, double aspect = 1.0);

// Throws InputError naming the broken rule if the camera cannot form an image: non-finite
// values, eye == look_at, up parallel to the view direction, or a field of view outside (0, 180).
void check_camera(const Camera& camera);

// Renders `element_values` (linear RGB, one per element). Throws InputError for a bad camera,
// UsageError for a width or height below 1, std::invalid_argument if the number of values is not
// mesh.size().
Image render_field(const Mesh& mesh, const EmbreeScene& embree,
                   std::span<const glm::dvec3> element_values, const Camera& camera, int width,
                   int height, bool smooth);

// Image of a radiosity solution (a grey solution renders grey): Gouraud-shaded from vertex
// radiosities (smooth, the default: Cohen et al. 1988's display) or flat per element.
Image render_radiosity(const Mesh& mesh, const EmbreeScene& embree, const Radiosity& values,
                       const Camera& camera, int width, int height, bool smooth = true);

}  // namespace radlab
