// The unoccluded form factor of two planar polygons by Stokes' theorem: the area integral over
// both polygons becomes a double integral over their outlines (Sparrow 1963; View3D's "1AI"
// line integrals, Walton 2002, NISTIR 6925),
//
//   A_i F_ij = (1/2π) Σ_p Σ_q (e_p · e_q) ∫_0^{L_p} ∫_0^{L_q} ln |P_p(s) − Q_q(t)| dt ds,
//
// p over the edges of P_i, q over those of P_j (unit directions e, lengths L, both outlines
// counterclockwise about their own normals; a negative result is reported as not converged). The
// identity needs the kernel cos θ_i cos θ_j / r² to keep its sign over both polygons, so each must
// lie wholly in front of the other's plane: callers clip them first (clip_to_front), which is also
// what F^u means.
//
// Why: for near and touching pairs the area rule needs many cells (the integrand varies on the
// scale of the gap, and its derivative is singular along a shared edge), while here the inner
// integral is elementary, ∫ ln sqrt(τ² + h²) dτ, and only the outer one is numerical: one
// dimension, smooth between break points placed where the singularities are (the feet of the
// other edge's ends and the lines' closest approach), so a Gauss–Kronrod rule converges in a few
// levels. Collinear edges (a shared edge) have a closed form for the whole double integral.
//
// Error: the Kronrod rule's difference from its Gauss points, |K15 − G7| per cell, summed with
// |e_p · e_q| over every cell of every edge pair, refined worst first until within
// `relative_tolerance` of the result. Rounding sets a floor (the terms' logarithms cancel across
// the closed outlines; coordinates are first scaled to the pair's size so that the cancelling
// part stays small): it is estimated from the terms' magnitudes and included in the stated
// error. When the tolerance cannot be met within `max_evaluations` (or under that floor) the
// result says so (converged = false) and callers integrate the pair another way.
#pragma once

#include <span>

#include "scene/scene.h"

namespace radlab {

struct ContourIntegral {
  double form_factor = 0.0;   // F_ij
  double error = 0.0;         // the estimated error of F_ij (Kronrod differences and rounding)
  long long evaluations = 0;  // points of the outer integrals (each one inner closed form)
  bool converged = false;     // error within relative_tolerance * form_factor
};

// F_ij for convex polygons i and j with unit normals (the front sides; the corners are taken
// counterclockwise about them whichever way they are listed), each wholly in front of the
// other's plane; `area_i` is the area F_ij is relative to (A_i of the whole element
// when i was clipped). Cost: ~15 points per edge pair that is not perpendicular, more near
// touching edges.
ContourIntegral contour_form_factor(std::span<const Vec3> i, const Vec3& normal_i,
                                    std::span<const Vec3> j, const Vec3& normal_j, double area_i,
                                    double relative_tolerance, long long max_evaluations);

// Callers (raycast, exact) integrate a pair started from one cell by the adaptive area rule while
// it is cheap, and pass it to the contour integral only once the area rule has spent this many
// evaluations without finishing (touching and near pairs, tight tolerances): the area rule needs
// fewer points than the contour integral on pairs it finishes early.
inline constexpr long long kAreaRuleFirst = 4096;

// The same for `from`, the part of i in front of j's plane, and the corners `to` of j, which is
// clipped here to the front of i's plane (through point_i, with unit normal normal_i; up to
// `epsilon`, as clip_to_front): F^u_ij as raycast and exact define it. Not converged (and 0) when
// nothing of j lies in front, or when either part is narrower than 1000 epsilons (a sliver along
// the other's edge, on the side of its plane that rounding decides: contour_integral.cpp).
ContourIntegral contour_form_factor_front(std::span<const Vec3> from, const Vec3& point_i,
                                          const Vec3& normal_i, std::span<const Vec3> to,
                                          const Vec3& normal_j, double area_i, double epsilon,
                                          double relative_tolerance, long long max_evaluations);

}  // namespace radlab
