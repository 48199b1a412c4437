// Geometry of single planar polygons: area, normal, centroid, planarity and convexity checks,
// and clipping against a plane. Used by the scene checks, the mesher and the form factors.
#pragma once

#include <span>
#include <vector>

#include "scene/scene.h"

namespace radlab::geometry {

// Newell's vector: twice the vector area. Robust for any planar or near-planar polygon.
Vec3 newell_vector(std::span<const Vec3> vertices);
double area(std::span<const Vec3> vertices);
Vec3 unit_normal(std::span<const Vec3> vertices);  // zero vector for a degenerate polygon
Vec3 centroid(std::span<const Vec3> vertices);     // area centroid
double diameter(std::span<const Vec3> vertices);   // largest vertex-to-vertex distance

// Largest distance of a vertex from the polygon's best plane (through the vertex mean, normal
// from Newell's vector).
double planarity_defect(std::span<const Vec3> vertices);

// True when the polygon, projected on its own plane, turns the same way at every vertex
// (collinear vertices are allowed).
bool is_convex(std::span<const Vec3> vertices);

// Keeps the part of `vertices` with (p - origin) . normal >= 0 (Sutherland–Hodgman, one plane).
void clip_to_halfspace(std::span<const Vec3> vertices, const Vec3& origin, const Vec3& normal,
                       std::vector<Vec3>& out);

}  // namespace radlab::geometry
