// Wavefront OBJ + MTL input (DESIGN §7): each face is one input polygon, in file order.
// MTL: Kd is the reflectance, Ke the emission; other statements are ignored. Errors name the file
// and line. Vertex indices may be negative (relative), and v/vt/vn forms are accepted.
// `mtllib` names regular files inside the OBJ's own folder (or ObjOptions::include_root), as MGF
// includes are confined: an OBJ from elsewhere must not make radlab read /etc/shadow and print it
// line by line as "unknown MTL statement" warnings. A material library's first statement must be
// `newmtl`; what radlab echoes of a line it does not understand is a few printable characters.
#pragma once

#include <string>

#include "scene/scene.h"

namespace radlab {

struct ObjOptions {
  // Material libraries must resolve inside this folder (empty: the folder of the OBJ file); the
  // command line's --mgf-include-root, which confines MGF includes the same way.
  std::string include_root;
  // Warn about unknown MTL statements (off when only the files read are wanted: a sweep's
  // identity reads each scene once before its runs load it).
  bool print_warnings = true;
};

// Reads an OBJ file (and the MTL libraries it names, relative to its folder).
Scene read_obj(const std::string& path, const ObjOptions& options = {});

}  // namespace radlab
