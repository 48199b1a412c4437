// Planar tessellation of MGF's curved and solid primitives (sph, cyl, cone, ring, torus, prism),
// from plain numbers to polygons: the MGF reader checks the statement and transforms the result
// to world space; this code only makes the geometry, so it can be tested without MGF text.
//
// Method: `segments` equal steps around every circle (the reader uses 4 x the MGF option
// quarter_circle_divisions, 16 by default); vertices lie on the true surface, so every area is
// below the true one by the chord factor (docs/scenes.md has the table: cylinder 16 quads
// sin(pi/16)/(pi/16) - 1 = -0.64%, sphere -3.2%, ring -2.6%, torus -2.2%).
// Orientation as the MGF reference says: outward for positive radii (a prism: for a positive
// length), inward for negative ones; a ring faces along its normal.
// Cost: O(segments) polygons (a sphere segments^2 / 2, a torus segments^2).
// Left out: the checks of the statement (zero radii, coincident end points), which the reader
// reports with its file and line; the functions assume what their comments require.
#pragma once

#include <vector>

#include "scene/scene.h"

namespace radlab::tessellate {

using Polygons = std::vector<std::vector<Vec3>>;

// Truncated cone (a cylinder when r1 == r2) from p1 to p2 (p1 != p2), open ends: quads, or
// triangles where one radius is 0 (not both). Radii of one sign; negative faces the axis.
Polygons cone(const Vec3& p1, double r1, const Vec3& p2, double r2, int segments);

// Sphere (radius != 0): segments / 2 latitude bands from the +z pole, triangles at the poles.
Polygons sphere(const Vec3& centre, double radius, int segments);

// Flat ring between rmin and rmax (0 <= rmin < rmax; a disc of triangles when rmin = 0) about
// `centre`, facing along the unit `normal`.
Polygons ring(const Vec3& centre, const Vec3& normal, double rmin, double rmax, int segments);

// Torus about the unit `normal` through `centre`: tube centre radius |rmin + rmax| / 2, tube
// radius |rmax - rmin| / 2; segments x segments quads; inward when rmax < 0.
Polygons torus(const Vec3& centre, const Vec3& normal, double rmin, double rmax, int segments);

// Closed right prism (base of non-zero area, length != 0): the base as given (its winding normal
// n), the far end at -n * length reversed, one quad per edge.
Polygons prism(const std::vector<Vec3>& base, double length);

}  // namespace radlab::tessellate
