// Wavefront OBJ + MTL input (DESIGN §7): each face is one input polygon, in file order.
// MTL: Kd is the reflectance, Ke the emission; other statements are ignored. Errors name the file
// and line. Vertex indices may be negative (relative), and v/vt/vn forms are accepted.
#pragma once

#include <string>

#include "scene/scene.h"

namespace radlab {

// Reads an OBJ file (and the MTL libraries it names, relative to its folder).
Scene read_obj(const std::string& path);

}  // namespace radlab
