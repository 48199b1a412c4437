// Turns a scene spec from the command line into a validated Scene:
// `builtin:NAME[:k=v,...]`, `path/to/file.obj` (with .mtl), or `path/to/file.mgf`.
#pragma once

#include <string>
#include <vector>

#include "scene/scene.h"
#include "scene/validate.h"

namespace radlab {

struct LoadedScene {
  Scene scene;
  ValidationReport report;
};

// The folder MGF includes and OBJ material libraries must lie in (MgfOptions::include_root,
// ObjOptions::include_root) for every later load_scene; empty (the default): the folder of the
// scene file. The command line's --mgf-include-root.
void set_mgf_include_root(const std::string& folder);

// Loads and validates; prints the validation warnings unless `print_warnings` is false. Scene
// files must be regular files (not /dev/zero, a FIFO or a folder). `keep_overlaps`: coincident
// polygons are left as they are (validate_scene).
LoadedScene load_scene(const std::string& spec, bool print_warnings = true,
                       bool keep_overlaps = false);

// The files `spec` reads, with the SHA-256 of their bytes (Scene::sources), from running its
// reader without validating or printing anything; none for a builtin. InputError as load_scene
// when a file cannot be read.
std::vector<SourceFile> scene_source_files(const std::string& spec);

}  // namespace radlab
