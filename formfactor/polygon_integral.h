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
                                    double relative_tolerance, double absolute_floor,
                                    int max_depth, long long* evaluations = nullptr);

// The number of Gauss points per axis that a fixed rule needs for `relative_tolerance`, from the
// Bernstein-ellipse bound for an integrand analytic within distance `gap` of an element of
// diameter `diameter`: error ~ rho^(-2m), rho = a + sqrt(a^2 - 1), a = 1 + 2 gap / diameter.
// Returns 0 when no fixed rule up to `max_order` suffices (the caller then goes adaptive).
int fixed_order_for(double gap, double diameter, double relative_tolerance, int max_order);

}  // namespace radlab
