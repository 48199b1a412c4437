// Checks a freshly read scene and repairs what can be repaired honestly, with a warning:
//
// - reflectance outside [0,1], NaN, or negative/NaN/infinite emission: InputError naming the
//   material (no repair is honest);
// - repeated consecutive vertices are merged;
// - fewer than 3 distinct vertices or zero area: the polygon is dropped with a warning naming it
//   (MGF and OBJ exports often contain such slivers; they carry no area, so no light);
// - non-planar beyond kPlanarityTolerance x diameter: split into triangles (each planar);
// - planar but non-convex: split into triangles by ear clipping;
// - coincident overlapping polygons (scene/overlap.h): same-facing overlaps removed
//   from the later polygon and face-to-face contacts from both unless `keep_overlaps`,
//   back-to-back ones reported.
// - self-intersecting (two edges cross, e.g. a pentagram), more than kMaxPolygonCorners corners,
//   coordinates beyond kMaxCoordinate, emission beyond kMaxEmission: InputError.
#pragma once

#include <string>
#include <vector>

#include "scene/overlap.h"
#include "scene/scene.h"

namespace radlab {

// Relative tolerance for planarity: largest vertex distance from the polygon's plane divided by
// the polygon's diameter. 1e-4 is 0.1 mm on a 1 m wall, well above the rounding of any scene
// file and well below any defect a modeller meant; the Cornell box's red wall (~0.8 mm) exceeds it.
inline constexpr double kPlanarityTolerance = 1e-4;

// Input bounds (docs/reliability_input.md): corners per polygon (the checks below are O(n^2);
// the largest RenderPark face has 74), vertex coordinates (m) and emission.
inline constexpr size_t kMaxPolygonCorners = 512;
inline constexpr double kMaxCoordinate = 1e12;
inline constexpr double kMaxEmission = 1e30;

struct ValidationReport {
  std::vector<std::string> warnings;
  int dropped = 0;         // degenerate polygons removed
  int triangulated = 0;    // non-planar or non-convex polygons split into triangles
  OverlapReport overlaps;  // coincident polygons found (and repaired unless kept)
};

// Validates and repairs `scene` in place. Throws InputError for what cannot be repaired.
ValidationReport validate_scene(Scene& scene, bool keep_overlaps = false);

// Throws InputError if nothing in the scene emits.
void require_emitter(const Scene& scene);

// Prints the report's warnings to stderr (the first few in full, then a count).
void print_warnings(const ValidationReport& report);

}  // namespace radlab
