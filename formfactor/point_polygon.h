// The form factor from a differential area at x (unit normal n) to a planar polygon, by
// Lambert's contour formula (Nusselt's analogue; Lambert 1760, see Howell's catalogue, B-1):
//
//   F_{dx->P} = 1/(2 pi) * sum_k  gamma_k * n . (a_k x a_{k+1}) / |a_k x a_{k+1}|
//
// with a_k = v_k - x and gamma_k the angle between a_k and a_{k+1}, taken by atan2 so it stays
// accurate for nearly parallel edges. The formula is exact for an unoccluded polygon entirely
// above x's tangent plane, so the polygon is first clipped to that half-space. Returns 0 when x
// sees the polygon's back.
#pragma once

#include <span>
#include <vector>

#include "scene/scene.h"

namespace radlab {

// `polygon_normal` is the polygon's front unit normal; `scratch` avoids allocations on hot paths.
double point_to_polygon_form_factor(const Vec3& x, const Vec3& n, std::span<const Vec3> polygon,
                                    const Vec3& polygon_normal, std::vector<Vec3>& scratch);

}  // namespace radlab
