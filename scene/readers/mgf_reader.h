// MGF input: Greg Ward's Materials and Geometry Format (version 2.0 entities), as used by the
// RenderPark scenes. docs/scenes.md ("MGF") has the full list of choices; in short:
//
// - Geometry: `f` is one input polygon (convex or not: validate_scene splits what needs it);
//   `sph`, `cyl`, `cone`, `ring`, `torus` and `prism` are tessellated into planar polygons with
//   `quarter_circle_divisions` segments per quarter circle (default 4: 16 around, RenderPark's
//   default), vertices on the true surface (inscribed), oriented as the MGF entity reference says
//   (outward unless radii or length are negative; rings face along their centre's normal).
// - Contexts: `o` (objects, nesting), `xf` (transforms -t -rx -ry -rz -s -mx -my -mz -i -a, arrays
//   included, composed as MGF prescribes: an inner context's arguments act first), `i` includes
//   (relative to the including file, with optional transform; regular files inside the
//   scene's folder or MgfOptions::include_root only; at most 10,000 inclusions and 32 levels),
//   vertex `v`/`p`/`n`, colour `c`, material `m`. Names are global (MGF's rule: `v name`
//   "reestablishes a previous context" wherever it was defined); a later `v name =` replaces an
//   earlier one. Every context opened in a file must be closed in that file.
// - Materials: `rd` with its colour is the reflectance, `ed` (lumens per m^2) with its colour the
//   emission, both converted from CIE (x, y) + luminance to linear RGB (Rec. 709 primaries, equal-
//   energy white, see scene/cie_colour.h). `rs`, `ts`, `td`, `ir` and `sides` are read,
//   checked and otherwise ignored (diffuse radiosity only; polygons are one-sided, front by
//   winding).
// - `ies` luminaires are ignored with a warning. Unknown entities are errors naming file:line;
//   a line whose first word cannot be an MGF keyword at all (it does not begin with a letter,
//   e.g. a stray path in office1/graz.mgf) is skipped with a warning.
// Errors are InputError "file:line: message", with the include chain when there is one.
#pragma once

#include <string>
#include <vector>

#include "scene/scene.h"

namespace radlab {

struct MgfOptions {
  // Segments per quarter circle for curved primitives. More: curved areas closer to the true
  // ones (the inscribed cylinder's area is sin(pi/2k)/(pi/2k) of the true one: -0.64% at k = 4,
  // -0.16% at k = 8) but proportionally more polygons (a sphere makes 8k^2 of them).
  int quarter_circle_divisions = 4;
  // Print the warnings (summarised) on stderr.
  bool print_warnings = true;
  // Includes must resolve inside this folder (empty: the folder of the file read). Reading a
  // file outside the scene's own folder is an explicit choice (`--mgf-include-root DIR`): a
  // scene file must not make radlab read arbitrary files (e.g. `i /etc/passwd`).
  std::string include_root;
};

// What the reader did, for `radlab scenes`, tests and docs.
struct MgfStats {
  int files = 0;  // distinct files parsed (each include counted once)
  int faces = 0;  // `f` entities executed (every array instance counts)
  int spheres = 0, cylinders = 0, cones = 0, rings = 0, tori = 0, prisms = 0;
  int tessellated_polygons = 0;  // polygons made from the curved primitives and prisms
  int out_of_gamut = 0;          // converted materials whose colour had to be desaturated
  int ignored_lines = 0;         // distinct stray lines and `ies` entities skipped with a warning
  std::vector<std::string> warnings;
};

// Reads an MGF file and everything it includes. Polygons keep file order (array instances in
// order, the first array index varying fastest).
Scene read_mgf(const std::string& path, const MgfOptions& options = {}, MgfStats* stats = nullptr);

}  // namespace radlab
