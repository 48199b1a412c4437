// The form factor from a differential area at x to the part of a polygon P_j that x sees past
// a set of convex occluders: deterministic visibility by polygon clipping, the integrand of
// `exact --ff-set visibility=clip` (exact.h).
//
// Method (the hidden-surface step of Nishita & Nakamae 1985, "Continuous tone representation of
// three-dimensional objects taking account of shadows and interreflection", and of View3D's
// obstruction clipping, Walton 2002, NISTIR 6925, done here per quadrature point):
//   1. Each occluder O is clipped to the cone from x over P_j (the planes through x and each edge
//      of P_j) and to the front of P_j's plane: what is left is exactly the part of O that lies
//      on some segment from x to P_j.
//   2. That part is projected centrally from x onto P_j's plane: its shadow S_O, a convex polygon
//      inside P_j. An occluder wholly in front of P_j and at most 0.9 of x's height above it
//      skips step 1: it is projected whole (stably: its shadow lies at most 10 times as far from
//      x), and step 3 cuts its shadow to P_j, the cone's planes projecting onto P_j's edge lines
//      (the cone's cut cost more than the rest together).
//   3. The visible part of P_j is P_j minus the union of the shadows, kept as a list of convex
//      pieces (convex minus convex is at most |S| convex pieces, clipped edge by edge). A piece
//      from which a whole shadow takes at most a sliver stays whole.
//   4. F_{dx->visible} = sum over the pieces of Lambert's point-to-polygon formula
//      (point_polygon.h), which is exact for each piece.
// The result is exact up to rounding for every x: no sampling, no seed. Occluders whose plane
// passes within `epsilon` of x are seen edge-on and block nothing (a box face standing on the
// receiver's plane). Pieces below 1e-13 of P_j's area (slivers of coincident edges) are dropped.
//
// Cost: O(occluders * corners) clipping per point, plus one Lambert evaluation per piece; a
// point whose cone meets no occluder costs one plain evaluation.
#pragma once

#include <glm/vec2.hpp>
#include <span>
#include <vector>

#include "scene/scene.h"

namespace radlab {

struct Occluder {
  std::span<const Vec3> corners;  // convex, planar
  Vec3 normal;                    // unit (either side: occluders block from both)
};

// Scratch space for visible_form_factor, reused across calls to avoid allocations. The vectors
// are buffers that only grow (their sizes are capacities, not the work polygons' sizes).
struct VisibleScratch {
  std::vector<Vec3> clipped, tmp, piece3, lambert;                // 3D work polygons
  std::vector<glm::dvec2> shadow, pieces, next, rest, out, tmp2;  // 2D, in P_j's plane
  std::vector<size_t> first, next_first;  // offsets of the pieces in `pieces` / `next`
  std::vector<double> height;             // signed heights of a polygon's corners
  std::vector<double> depth;              // an occluder's corners' heights above P_j
  std::vector<Vec3> cone;                 // the planes of the cone from x over P_j ...
  std::vector<double> cone_offset;        // ... and their offsets
};

// P_j set up once for the many points x of a quadrature over P_i: the 2D frame of its plane, its
// corners in that frame and its area do not depend on x. `corners` is referenced, not copied:
// it must outlive the calls. set() reuses the storage, so a thread_local target allocates only
// when a polygon has more corners than any before. In a quadrature over P_i:
//   thread_local VisibleTarget target;
//   target.set(to, to_normal);
//   ... visible_form_factor(x, n, target, occluders, epsilon, scratch) for each point x.
struct VisibleTarget {
  VisibleTarget() = default;
  VisibleTarget(std::span<const Vec3> to, const Vec3& to_normal) { set(to, to_normal); }
  void set(std::span<const Vec3> to, const Vec3& to_normal);

  std::span<const Vec3> corners;  // convex, counter-clockwise about `normal`
  Vec3 normal{0.0};               // unit, P_j's front
  Vec3 e1{0.0}, e2{0.0};          // the frame: origin corners[0], e1 along the first edge
  std::vector<glm::dvec2> flat;   // the corners in the frame
  double area = 0.0;              // P_j's area (from `flat`)
  glm::dvec2 lo{0.0}, hi{0.0};    // P_j's box in the frame
};

// F_{dx -> visible part of `to`} for x with unit normal n. `occluders` may include polygons that
// block nothing from x (they cost a clip each). Returns 0 when x is behind `to`'s plane.
// `blocked` (if given) is set when some occluder cast a shadow on `to` from x, `hidden` when
// the shadows cover all of `to`.
double visible_form_factor(const Vec3& x, const Vec3& n, std::span<const Vec3> to,
                           const Vec3& to_normal, std::span<const Occluder> occluders,
                           double epsilon, VisibleScratch& scratch, bool* blocked = nullptr,
                           bool* hidden = nullptr);
// The same with P_j prepared (the same value to the last bit; it spares the per-call set-up).
double visible_form_factor(const Vec3& x, const Vec3& n, const VisibleTarget& to,
                           std::span<const Occluder> occluders, double epsilon,
                           VisibleScratch& scratch, bool* blocked = nullptr,
                           bool* hidden = nullptr);

// Pair-level tests that spare the per-point clipping (exact.cpp's clip mode):
// True when `o` cannot block any segment from `from` to `to`: every corner of both lies on one
// side of o's plane (within `epsilon`: a segment meeting the plane only at an end point).
bool separated_by_plane(const Occluder& o, std::span<const Vec3> from, std::span<const Vec3> to,
                        double epsilon);
// True when `o` alone hides all of `to` from every point of the convex polygon `from`: it does
// from each corner of `from`. (Sound: the umbra of a convex occluder for a convex source, the
// points every segment from which to the source meets the occluder, is convex — for each
// source point p it is {p + t (y - p) : y in o, t >= 1}, a convex set, and the umbra is their
// intersection.)
bool hides_from_corners(const Occluder& o, std::span<const Vec3> from, const Vec3& n,
                        std::span<const Vec3> to, const Vec3& to_normal, double epsilon,
                        VisibleScratch& scratch);

}  // namespace radlab
