// Checks a freshly read scene and repairs what can be repaired honestly, with a warning:
//
// - reflectance outside [0,1], NaN, or negative/NaN/infinite emission: InputError naming the
//   material (no repair is honest);
// - repeated consecutive vertices are merged;
// - fewer than 3 distinct vertices or zero area: the polygon is dropped with a warning naming it
//   (MGF and OBJ exports often contain such slivers; they carry no area, so no light);
// - non-planar beyond kPlanarityTolerance x diameter: split into triangles (each planar);
// - planar but non-convex (a hole joined by a seam, a corner visited twice): split into triangles
//   by a constrained Delaunay triangulation (scene/triangulate.h);
// - coincident overlapping polygons (scene/overlap.h): same-facing overlaps removed
//   from the later polygon and face-to-face contacts from both unless `keep_overlaps`,
//   back-to-back ones reported.
// - self-intersecting (two edges cross, e.g. a pentagram), more than kMaxPolygonCorners corners,
//   coordinates beyond kMaxCoordinate, emission beyond kMaxEmission: InputError.
#pragma once

#include <cmath>
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

// Relative difference between two areas that is rounding, not geometry: a split's triangles
// against the polygon, the scene's area account below. A sum of N doubles errs by at most
// N x 1.1e-16 of the sum of their magnitudes (recursive summation, to first order; Higham,
// Accuracy and Stability of Numerical Algorithms, 4.2): 1e-9 covers N up to ~9e6 areas, above
// the 5e6 polygons radlab reads at most (core/limits.h).
inline constexpr double kAreaTolerance = 1e-9;

// Where the area read went (m^2), checked on every load: what was read equals what is kept plus
// what the warnings name as dropped, lost in a split or removed by the overlap repair, minus the
// surplus of non-planar polygons' triangles over their projected (Newell) area. `unaccounted()`
// beyond `rounding()` is a warning (a defect of the loader, not of the scene).
struct AreaAccount {
  double read = 0.0;                  // the readers' polygons, Newell area
  double dropped = 0.0;               // degenerate polygons dropped (each named)
  double split_lost = 0.0;            // triangulations that did not cover their polygon (named)
  double non_planar_surplus = 0.0;    // split triangles' area above their projected area
  double kept_before_overlaps = 0.0;  // after the splits, before the overlap repair
  double overlaps_removed = 0.0;      // removed by the overlap repair (each named)
  double kept = 0.0;                  // the validated scene
  double unaccounted() const {
    return read - dropped - split_lost + non_planar_surplus - overlaps_removed - kept;
  }
  // What rounding alone can leave unaccounted: kAreaTolerance of the magnitudes the account
  // adds up, not of `read`. The terms can dwarf what was read and cancel: a polygon far off its
  // plane has triangles of 1e21 m^2 over a projection of 1e11 m^2, so the surplus and `kept`
  // both carry 1e21 m^2 and their difference rounds by its last bit, 131072 m^2, 4e-8 of the
  // 3e12 m^2 read (three fuzz findings, docs/reliability.md). For a planar scene the magnitudes
  // are read + kept = 2 x read, as before.
  double rounding() const {
    return kAreaTolerance *
           (read + dropped + std::abs(split_lost) + non_planar_surplus + overlaps_removed + kept);
  }
  bool balanced() const { return std::abs(unaccounted()) <= rounding(); }
};

struct ValidationReport {
  std::vector<std::string> warnings;
  int dropped = 0;         // degenerate polygons removed
  int triangulated = 0;    // non-planar or non-convex polygons split into triangles
  OverlapReport overlaps;  // coincident polygons found (and repaired unless kept)
  AreaAccount area;
};

// Validates and repairs `scene` in place. Throws InputError for what cannot be repaired.
ValidationReport validate_scene(Scene& scene, bool keep_overlaps = false);

// Throws InputError if nothing in the scene emits.
void require_emitter(const Scene& scene);

// Prints the report's warnings to stderr (the first few in full, then a count).
void print_warnings(const ValidationReport& report);

}  // namespace radlab
