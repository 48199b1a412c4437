// The unoccluded form factor between two planar convex polygons,
//
//   F_ij = (1/A_i) * integral over x in P_i of F_{dx->P_j} dA_x,
//
// by quadrature over P_i of the exact point-to-polygon formula (point_polygon.h). Two rules:
// a fixed Gauss–Legendre tensor rule (cheap, spectrally accurate when the polygons are well
// separated), and adaptive subdivision of P_i (for near and touching pairs, where the integrand's
// derivative is singular along a shared edge; the singularity is integrable and the adaptive rule
// converges to it — tests/formfactor_test.cpp shows it).
#pragma once

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

// Adaptive rule: recursive 4-way subdivision of P_i with 3x3 Gauss rules until parent and children
// agree to `relative_tolerance` (with a floor of `absolute_floor`), at most `max_depth` levels.
// `evaluations`, if given, accumulates the number of point-to-polygon evaluations.
double polygon_form_factor_adaptive(const PolygonRef& from, const PolygonRef& to,
                                    double relative_tolerance, double absolute_floor, int max_depth,
                                    long long* evaluations = nullptr);

// The integrand F_{dx -> P_j} is zero for x behind P_j's plane and jumps there when P_i straddles
// that plane (elements not split where another polygon stands on them, e.g. a box on a floor):
// both rules converge slowly across a jump. This keeps the part of `corners` on or in front of
// the plane through `point` with unit `normal` (up to `epsilon` metres) and returns the fraction
// of the area kept (1: nothing cut, `corners` untouched; 0: nothing left). Integrate over the
// kept part and multiply by the fraction.
double clip_to_front(std::vector<Vec3>& corners, const Vec3& point, const Vec3& normal,
                     double epsilon);

// Chooses the number of Gauss points per axis a fixed rule needs for a relative tolerance, from
// the Bernstein-ellipse bound for an integrand analytic within distance `gap` of an element of
// diameter `diameter`: error ~ r^(-2m), r = a + sqrt(a^2 - 1), a = 1 + 2 gap / diameter.
// Thresholds are precomputed, so choosing costs a few comparisons per pair.
class FixedOrderRule {
 public:
  FixedOrderRule(double relative_tolerance, int max_order);
  // The smallest sufficient order, or 0 when no fixed rule up to max_order suffices (the caller
  // then integrates adaptively).
  int order(double gap, double diameter) const {
    if (!(gap > 0.0) || !(diameter > 0.0)) return 0;
    const double ratio = gap / diameter;
    for (size_t m = 1; m < min_ratio_.size(); ++m)
      if (ratio >= min_ratio_[m]) return int(m);
    return 0;
  }

 private:
  std::vector<double> min_ratio_;  // min_ratio_[m]: smallest gap/diameter that order m handles
};

}  // namespace radlab
