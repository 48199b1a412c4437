#include "formfactor/polygon_integral.h"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>

#include "formfactor/point_polygon.h"
#include "formfactor/quadrature.h"
#include "scene/geometry.h"

namespace radlab {
namespace {

thread_local std::vector<Vec3> t_clip;

double apply_rule(const std::vector<QuadraturePoint>& points, const Vec3& n, const PolygonRef& to) {
  double sum = 0.0;
  for (const QuadraturePoint& q : points)
    sum += q.weight * point_to_polygon_form_factor(q.position, n, to.corners, to.normal, t_clip);
  return sum;
}

double rule_on(std::span<const Vec3> corners, const Vec3& n, const PolygonRef& to, int order,
               long long* evaluations) {
  thread_local std::vector<QuadraturePoint> points;
  element_quadrature(corners, order, points);
  if (evaluations) *evaluations += static_cast<long long>(points.size());
  return apply_rule(points, n, to);
}

// Children of a triangle (4, by edge midpoints) or a quad (4, by the bilinear midpoint); other
// polygons are first split into a fan of triangles.
std::vector<std::vector<Vec3>> children(std::span<const Vec3> c) {
  std::vector<std::vector<Vec3>> out;
  if (c.size() == 3) {
    Vec3 m01 = 0.5 * (c[0] + c[1]), m12 = 0.5 * (c[1] + c[2]), m20 = 0.5 * (c[2] + c[0]);
    out = {{c[0], m01, m20}, {m01, c[1], m12}, {m20, m12, c[2]}, {m01, m12, m20}};
  } else if (c.size() == 4) {
    Vec3 m01 = 0.5 * (c[0] + c[1]), m12 = 0.5 * (c[1] + c[2]), m23 = 0.5 * (c[2] + c[3]),
         m30 = 0.5 * (c[3] + c[0]), mid = 0.25 * (c[0] + c[1] + c[2] + c[3]);
    out = {
        {c[0], m01, mid, m30}, {m01, c[1], m12, mid}, {mid, m12, c[2], m23}, {m30, mid, m23, c[3]}};
  } else {
    for (size_t k = 1; k + 1 < c.size(); ++k) out.push_back({c[0], c[k], c[k + 1]});
  }
  return out;
}

// Integral over `cell` (not normalised by area): area(cell) * mean of F_{dx->to}.
double adaptive(std::span<const Vec3> cell, double cell_estimate, const Vec3& n,
                const PolygonRef& to, double tolerance, double floor, int depth,
                long long* evaluations) {
  auto kids = children(cell);
  std::vector<double> estimates(kids.size());
  double sum = 0.0;
  for (size_t k = 0; k < kids.size(); ++k) {
    estimates[k] = geometry::area(kids[k]) * rule_on(kids[k], n, to, 3, evaluations);
    sum += estimates[k];
  }
  const double error = std::abs(sum - cell_estimate);
  if (depth <= 0 || error <= std::max(tolerance * std::abs(sum), floor)) return sum;
  double refined = 0.0;
  for (size_t k = 0; k < kids.size(); ++k)
    refined +=
        adaptive(kids[k], estimates[k], n, to, tolerance, 0.25 * floor, depth - 1, evaluations);
  return refined;
}

}  // namespace

double polygon_form_factor_fixed(const PolygonRef& from, const PolygonRef& to, int order) {
  return rule_on(from.corners, from.normal, to, order, nullptr);
}

double polygon_form_factor_adaptive(const PolygonRef& from, const PolygonRef& to,
                                    double relative_tolerance, double absolute_floor, int max_depth,
                                    long long* evaluations) {
  const double area = geometry::area(from.corners);
  const double whole = area * rule_on(from.corners, from.normal, to, 3, evaluations);
  return adaptive(from.corners, whole, from.normal, to, relative_tolerance, absolute_floor * area,
                  max_depth, evaluations) /
         area;
}

double clip_to_front(std::vector<Vec3>& corners, const Vec3& point, const Vec3& normal,
                     double epsilon) {
  bool behind = false;
  for (const Vec3& v : corners) behind = behind || glm::dot(v - point, normal) < -epsilon;
  if (!behind) return 1.0;
  const double area = geometry::area(corners);
  thread_local std::vector<Vec3> kept;
  geometry::clip_to_halfspace(corners, point, normal, kept);
  const double kept_area = kept.size() >= 3 ? geometry::area(kept) : 0.0;
  if (!(kept_area > 0.0) || !(area > 0.0)) return 0.0;
  corners.assign(kept.begin(), kept.end());
  return std::min(1.0, kept_area / area);
}

FixedOrderRule::FixedOrderRule(double relative_tolerance, int max_order)
    : min_ratio_(size_t(max_order) + 1, 0.0) {
  for (int m = 1; m <= max_order; ++m) {
    // Error ~ r^(-2m) <= tol  <=>  r >= tol^(-1/(2m));  a = (r + 1/r)/2;  gap/diameter = (a-1)/2.
    const double r = std::pow(relative_tolerance, -1.0 / (2.0 * m));
    const double a = 0.5 * (r + 1.0 / r);
    min_ratio_[size_t(m)] = 0.5 * (a - 1.0);
  }
}

}  // namespace radlab
