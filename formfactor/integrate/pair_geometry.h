// What the quadrature of a pair needs to know of its geometry, shared by `raycast` and `exact`
// (and the visibility tracer): each element's radius, and how far below the integrand's size its
// mean falls when the pair grazes j's plane (the Bernstein bound's `scale`, polygon_integral.h).
#pragma once

#include <span>
#include <vector>

#include "scene/mesh.h"

namespace radlab {

// Each element's largest centroid-to-corner distance.
std::vector<double> element_radii(const Mesh& mesh);

// The integrand of F_ij vanishes on j's plane, roughly in proportion to the height h(x) of x above
// it, so a pair that nearly grazes j's plane (a kept sliver ending on it, near-coplanar elements)
// has a mean far below the integrand's size on the Bernstein ellipse: the error bound's constant
// is about max|h| on the ellipse over the mean of h. h is linear, so its mean over the kept part
// `from` of i (the fraction `kept` of it) is its value at the kept part's centroid, and on the
// ellipse it grows by at most |grad h| = sin(angle between the planes) per unit of i's
// `diameter`. Returns mean / (max + growth), <= 1.
double grazing_scale(const Mesh& mesh, size_t i, size_t j, std::span<const Vec3> from, double kept,
                     double diameter);

// The distance from x to the convex planar polygon p (unit normal n).
double point_polygon_distance(const Vec3& x, std::span<const Vec3> p, const Vec3& n);

// The distance between two convex planar polygons (unit normals na, nb) that do not cross each
// other: the least of each one's corners to the other polygon and of their edges to each other
// (the closest points of disjoint convex polygons lie at a corner or on two edges). Where the
// polygons cross, it is the distance their outlines keep, not 0: callers pass polygons on one
// side of each other's plane.
double polygon_distance(std::span<const Vec3> a, const Vec3& na, std::span<const Vec3> b,
                        const Vec3& nb);

}  // namespace radlab
