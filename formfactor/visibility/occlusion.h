// What visibility work a scene needs. A scene whose polygons all bound one convex region (every
// vertex lies on or in front of every polygon's plane: a closed box seen from inside, any convex
// room) cannot occlude: the segment between two points on the boundary of a convex set stays
// inside it. Then no visibility rays are cast at all (DESIGN §2).
#pragma once

#include "scene/mesh.h"

namespace radlab {

// `tolerance` is relative to the scene's bounding-box diagonal.
bool is_convex_enclosure(const Scene& scene, double tolerance = 1e-9);

}  // namespace radlab
