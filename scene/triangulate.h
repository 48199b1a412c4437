// Triangulation of one polygon whose outline is not a convex loop: non-convex faces, faces with a
// hole joined to the outline by a seam (an edge walked there and back, as Radiance-to-MGF
// converters write them: RenderPark's office3/office.mgf:41, a wall with a window), faces that
// visit a corner twice, and non-planar faces that are not convex in projection.
//
// Method: CGAL's constrained Delaunay triangulation (Constrained_triangulation_plus_2, exact
// predicates and constructions) of the polygon's edges in its best plane (Newell normal), keeping
// the triangles that lie inside by the even-odd rule: crossing an edge of the triangulation flips
// inside and outside once for every polygon edge that covers it, so a seam (covered twice) changes
// nothing and a hole's outline (once) does. Triangles are wound counter-clockwise about the
// polygon's normal and reuse the polygon's own corners (a new corner, where two edges touch, is
// placed in the plane). Cost: O(n log n) for n corners (n <= kMaxPolygonCorners). Left out: edges
// that cross are refused by the validator first, except on non-planar faces, whose projection may
// cross itself: those are split at the crossings; regions the outline winds round twice count as
// outside (even-odd), which the loader's area check then reports.
#pragma once

#include <vector>

#include "scene/scene.h"

namespace radlab {

// The triangles covering `polygon` (at least 3 corners, non-zero Newell area), wound as the
// polygon. Empty when nothing lies inside.
std::vector<std::vector<Vec3>> triangulate_polygon(const std::vector<Vec3>& polygon);

}  // namespace radlab
