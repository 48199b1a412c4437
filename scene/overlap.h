// Coincident surfaces in a scene of planar polygons: finding and repairing them on loading.
//
// Two one-sided polygons in the same plane that face the same way and overlap are one surface
// counted twice: an element looking at them receives F twice (row sums above 1: hospital's
// furniture included twice, office2's desk tops), and no ray can tell which is in front. Facing
// opposite ways there are two cases. Each behind the other (back to back) they are a two-sided
// sheet, which is allowed, but the pair is reported. Each in front of the other (face to face)
// they are a contact, such as hospital's window frames resting on their sills a few micrometres
// above them: the overlap sees nothing but itself, yet no ray resolves the gap, so it saw past
// the other polygon into the wall (row sums up to 1.04). Exactly coincident (within kContactGap)
// the two cases cannot be told apart, and the pair is kept as a sheet. Parallel polygons facing
// the same way a little apart (stacked: a rug on a floor) are allowed too: visibility
// (formfactor/visibility/visibility.h) resolves them when the gap exceeds float rounding (8 float
// ulps); below kCoincidentTolerance they are treated as coincident.
//
// Repair (the default): the later polygon of a coincident same-facing pair loses the overlap
// (convex polygon minus convex polygon, as up to n convex pieces); a later polygon wholly inside
// an earlier one is dropped. Both polygons of a contact lose the overlap: light neither reaches
// nor leaves it. Each repair is a warning naming both polygons (file:line) and what was done.
// `keep` leaves the geometry as it is and only warns.
//
// Cost: polygons are bucketed by plane (normal and offset quantised, neighbouring buckets
// checked) and found through an R-tree of their bounding boxes (Boost.Geometry), so a polygon is
// compared only with the earlier ones of its plane whose boxes meet its own: O(n log n) even
// when every polygon lies in one plane (a tessellated floor of 10,082 triangles: 54 ms, 4.0 s when
// all pairs of a plane were compared; 199,712 triangles 1.1 s; bench/bench_loading.cpp).
// Left out: overlaps between non-parallel polygons (interpenetration) are not searched for here;
// the row-sum diagnostic (formfactor/matrix/diagnostics.h) names them where they matter.
#pragma once

#include <string>
#include <vector>

#include "scene/scene.h"

namespace radlab {

// Distance (relative to the scene's bounding-box diagonal) below which parallel planes coincide:
// 1e-5 is 0.1 mm in a 10 m scene. Visibility rays resolve surfaces stacked more than about
// 8 float roundings apart (4e-6 of the largest coordinate, visibility.cpp); closer than this, the
// loader treats them as one surface. Below any gap a modeller meant in a room-sized scene.
inline constexpr double kCoincidentTolerance = 1e-5;

// Distance (relative to the diagonal) by which one of two coincident opposite-facing polygons
// must lie in front of the other for the pair to be a contact rather than a two-sided sheet:
// above the rounding of the polygons' centroids (hospital's exactly coincident pairs are within
// 3e-12 m, its modelled contacts 3e-9 m to 1e-4 m apart, in a 19 m scene).
inline constexpr double kContactGap = 1e-11;

// A piece the repair cuts off below this fraction of its polygon's area is a rounding sliver and
// dropped (its area counted as removed): 1e-9 is far below any overlap a modeller meant and far
// above the rounding of a cut (~1e-16 of the polygon's size squared).
inline constexpr double kSliverFraction = 1e-9;

// The most convex pieces the repair cuts one polygon into before it refuses the scene
// (InputError naming the polygon): the repair's cost grows with the pieces times the polygons
// overlapping it. Every RenderPark scene loads far below it (tests/scene/readers).
inline constexpr size_t kMaxRepairPieces = 4096;

struct OverlapReport {
  std::vector<std::string> warnings;
  int same_facing = 0;        // coincident same-facing overlapping pairs found
  int back_to_back = 0;       // coincident opposite-facing pairs kept as two-sided sheets
  int contacts = 0;           // coincident face-to-face pairs (contacts) found
  double contact_area = 0.0;  // total area of the contacts, m^2 (each pair counted once)
  int dropped = 0;            // polygons wholly covered by an earlier one or a contact (repair)
  int clipped = 0;            // polygons cut to the part outside one (repair)
  double overlap_area = 0.0;  // total area of the same-facing overlaps, m^2
  double removed_area = 0.0;  // area the repair took from the scene, m^2 (the loader's account)
};

// Finds coincident overlapping polygons; removes same-facing overlaps and contacts unless `keep`.
OverlapReport resolve_coincident_polygons(Scene& scene, bool keep);

namespace geometry {
// Area of the intersection of two convex polygons, `b` projected onto `a`'s plane.
double overlap_area(const std::vector<Vec3>& a, const std::vector<Vec3>& b);
// `a` minus `b` (both convex, `b` projected onto a's plane) as convex pieces.
std::vector<std::vector<Vec3>> subtract_convex(const std::vector<Vec3>& a,
                                               const std::vector<Vec3>& b);
}  // namespace geometry

}  // namespace radlab
