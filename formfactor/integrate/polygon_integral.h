// The unoccluded form factor between two planar convex polygons,
//
//   F_ij = (1/A_i) * integral over x in P_i of F_{dx->P_j} dA_x,
//
// by quadrature over P_i of the exact point-to-polygon formula (point_polygon.h). Two rules:
// a fixed Gauss–Legendre tensor rule (cheap, spectrally accurate when the polygons are well
// separated), and adaptive subdivision of P_i (for near and touching pairs, where the integrand's
// derivative is singular along a shared edge; the singularity is integrable and the adaptive rule
// converges to it — tests/formfactor/closed_forms_test.cpp shows it). Cells of zero area (a clipped
// polygon's collinear corners) contribute nothing and cost nothing.
#pragma once

#include <algorithm>
#include <cmath>
#include <functional>
#include <span>
#include <vector>

#include "scene/scene.h"

namespace radlab {

struct PolygonRef {
  std::span<const Vec3> corners;
  Vec3 normal;  // unit, front side
};

// Fixed rule: order x order Gauss points over P_i.
double polygon_form_factor_fixed(const PolygonRef& from, const PolygonRef& to, int order);

// Adaptive rule: P_i's quad, or each triangle of its fan (triangles, clipped quads, n-gons), is
// split 4 ways again and again, always the cell whose 3x3 Gauss rule differs most from its
// children's, until the differences summed over all cells are within `relative_tolerance` of the
// whole integral (or within `absolute_floor`, in units of the result), at most `max_depth`
// levels. A global budget: cells along a shared edge, a small share of the integral, stop once
// their absolute error is small instead of being refined to max_depth (exact on the Cornell box:
// 14 M evaluations instead of 953 M). Returns a non-finite integrand value at once.
// `evaluations`, if given, accumulates the number of point-to-polygon evaluations.
double polygon_form_factor_adaptive(const PolygonRef& from, const PolygonRef& to,
                                    double relative_tolerance, double absolute_floor, int max_depth,
                                    long long* evaluations = nullptr);

// The same adaptive rule with another integrand g(x) over P_i in place of F_{dx->P_j} (null:
// F_{dx->P_j} itself): the mean of g over P_i. `to` still steers the refinement near P_j. For
// integrands bounded by F_{dx->P_j} (the visible part of P_j, exact.h's clip mode).
//   `max_evaluations` (> 0) caps the work: the rule then also stops, before the tolerance, once
// it has evaluated the integrand that often (checked before each split, so it may exceed the cap
// by one split's 144: each of 4 children is prepared with its own 4 children's 3x3 rules).
// `estimated_error`, if given, receives the rule's estimated error of the result (in its units, a
// mean over P_i): the sum of its leaves' estimates, including cells kept at max_depth — within the
// tolerance when the rule converged, larger when the cap or the depth limit stopped it, so the
// caller can state it.
using PointIntegrand = std::function<double(const Vec3&)>;
double polygon_integral_adaptive(const PolygonRef& from, const PolygonRef& to,
                                 const PointIntegrand* integrand, double relative_tolerance,
                                 double absolute_floor, int max_depth,
                                 long long* evaluations = nullptr, long long max_evaluations = 0,
                                 double* estimated_error = nullptr);

// The same rule with the triangles (3 corners each, in a plane with unit `normal`) as its
// starting cells, under one global error budget and one work cap: the mean of F_{dx->P_j} over
// their union, as if integrated over that union from those cells. For a pair much closer than
// its size, whose integrand must be resolved from small cells (raycast.cpp). Integrating each
// cell on its own gave each its own relative tolerance and its own cap: cells whose share of the
// pair is tiny were refined to 1e-4 of their own value, and a pair of 12,288 cells could take
// 12,288 caps (office1/graz.mgf: one pair ran for over 10 minutes). With `split_every_root`
// each triangle is split once before the global rule starts (otherwise only the first cell
// taken is), and the cap counts from there.
double polygon_integral_adaptive_triangles(std::span<const Vec3> triangles, const Vec3& normal,
                                           const PolygonRef& to, double relative_tolerance,
                                           double absolute_floor, int max_depth,
                                           long long* evaluations = nullptr,
                                           long long max_evaluations = 0,
                                           double* estimated_error = nullptr,
                                           bool split_every_root = true);

// Cuts the convex polygon `corners` into `count` strips of equal width across `axis` (unit, in
// its plane) and appends each strip's fan triangles, 3 corners each, to `triangles`: starting
// cells about as long as they are wide for a thin element (raycast.cpp), whose own cells the
// adaptive rule, halving both sides, would keep as thin as it is. Strips that clip to nothing
// (a corner on a cut) add nothing; the triangles cover the polygon.
void append_strip_triangles(std::span<const Vec3> corners, const Vec3& axis, int count,
                            std::vector<Vec3>& triangles);

// The integrand F_{dx -> P_j} is zero for x behind P_j's plane and jumps there when P_i straddles
// that plane (elements not split where another polygon stands on them, e.g. a box on a floor):
// both rules converge slowly across a jump. This keeps the part of `corners` on or in front of
// the plane through `point` with unit `normal` and returns the fraction of the area kept (1:
// nothing cut, `corners` untouched; 0: nothing left, including a sliver no more than `epsilon`
// metres in front). Corners within `epsilon` of the plane count as on it, so the result has no
// repeated corners. Integrate over the kept part and multiply by the fraction. `lowest`, if
// given, receives the least height above the plane of the kept corners (0 when anything was cut
// or a corner is within `epsilon` of the plane).
double clip_to_front(std::vector<Vec3>& corners, const Vec3& point, const Vec3& normal,
                     double epsilon, double* lowest = nullptr);

// Chooses the number of Gauss points per axis a fixed rule needs for a relative tolerance, from
// the Bernstein-ellipse bound for an integrand analytic within distance `gap` of an element of
// diameter `diameter`: error <= C r^(-2m) / scale, r = a + sqrt(a^2 - 1), a = 1 + 2 gap/diameter,
// so m = ceil(ln(C / (tolerance * scale)) / (2 ln r)).
//   C = 1000 covers the bound's own factor ((64/15) / (r^2 - 1) per axis) and the integrand's
// size on the ellipse relative to its mean: the kernel ~1/|x - y|^4 has poles on the ellipse's
// boundary, so that ratio is large. With C = 1 (the rule before) 12% of the fixed-rule pairs of
// builtin:cornell --subdiv 6 missed 1e-4, by up to 50x (order 1 on office2); with C = 1000 and
// raycast's `scale` the worst of cornell 6, office and the RenderPark corridor and office2
// against order m+6 is 1.06e-4, for 2.5x the (cheap) fixed-rule evaluations.
//   `scale` (<= 1) is the caller's estimate of how much smaller the integrand's mean is than its
// size (raycast: integrands that vanish on a plane crossing or near the element).
class FixedOrderRule {
 public:
  FixedOrderRule(double relative_tolerance, int max_order);
  // The smallest sufficient order, or 0 when no fixed rule up to max_order suffices (the caller
  // then integrates adaptively). Inline (below): exact's rows ask it for every pair.
  int order(double gap, double diameter, double scale = 1.0) const;

 private:
  double log_inverse_tolerance_;  // ln(C / relative_tolerance)
  double inverse_tolerance_;      // exp of the above, C / relative_tolerance
  int max_order_;
};

inline int FixedOrderRule::order(double gap, double diameter, double scale) const {
  if (!(gap > 0.0) || !(diameter > 0.0) || !(scale > 0.0)) return 0;
  const double a = 1.0 + 2.0 * gap / diameter;
  const double r = a + std::sqrt(a * a - 1.0);
  const double s = std::min(scale, 1.0);
  // The order m below is the smallest integer >= X = ln(K / s) / (2 ln r), K = C / tolerance,
  // i.e. the smallest m with r^(2m) s >= K. That test needs no logarithm: r^(2m) s by repeated
  // multiplication (relative error < 1e-14 for m <= 32) against K with a margin of 1e-9, far
  // above both computations' rounding. When m passes with the margin and m - 1 fails with it
  // (or m = 1), X lies clearly in (m - 1, m] and the formula below gives m too; otherwise (X
  // within the margin of an integer, or not finite) the formula decides. Same orders, without
  // two logarithms per pair.
  constexpr double kMargin = 1e-9;
  const double high = inverse_tolerance_ * (1.0 + kMargin),
               low = inverse_tolerance_ * (1.0 - kMargin);
  const double r2 = r * r;
  double power = r2 * s, previous = 0.0;  // r^(2m) s and r^(2(m - 1)) s
  int m = 1;
  for (; m <= max_order_; ++m) {
    if (power >= high) break;
    previous = power;
    power *= r2;
  }
  if (m > max_order_) {
    if (previous < low) return 0;  // X > max_order: no fixed rule suffices
  } else if (m == 1 || previous < low) {
    return m;
  }
  const double log_r = std::log(r);
  // Error ~ C r^(-2m) / scale <= tol  <=>  m >= ln(C / (tol scale)) / (2 ln r).
  const double order = std::ceil((log_inverse_tolerance_ - std::log(s)) / (2.0 * log_r));
  if (!(order <= double(max_order_))) return 0;
  return std::max(1, int(order));
}

}  // namespace radlab
