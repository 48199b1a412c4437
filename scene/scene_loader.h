// Turns a scene spec from the command line into a validated Scene:
// `builtin:NAME[:k=v,...]`, `path/to/file.obj` (with .mtl), or `path/to/file.mgf`.
#pragma once

#include <string>

#include "scene/scene.h"
#include "scene/validate.h"

namespace radlab {

struct LoadedScene {
  Scene scene;
  ValidationReport report;
};

// Loads and validates; prints the validation warnings unless `print_warnings` is false.
// `keep_overlaps`: coincident polygons are left as they are (validate_scene).
LoadedScene load_scene(const std::string& spec, bool print_warnings = true,
                       bool keep_overlaps = false);

}  // namespace radlab
