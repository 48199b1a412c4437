// Quadrature rules over elements: Gauss–Legendre tensor rules mapped onto quads (bilinearly) and
// triangles (collapsed square, Duffy), with weights that sum to 1 (fractions of the element's
// area). Used to integrate the point-to-polygon form factor over the receiving point.
#pragma once

#include <span>
#include <vector>

#include "scene/scene.h"

namespace radlab {

struct QuadraturePoint {
  Vec3 position;
  double weight;  // fraction of the element's area; the weights of a rule sum to 1
};

// Gauss–Legendre nodes and weights on [0,1] for `order` points (1..32).
void gauss_legendre_unit(int order, std::vector<double>& nodes, std::vector<double>& weights);

// An order x order rule over a triangle, quad, or convex n-gon (a fan of triangles). Fan
// triangles of zero area get no points; a polygon of zero area still gets finite weights that
// sum to 1 (its integral, area times mean, is 0 whatever they are).
void element_quadrature(std::span<const Vec3> corners, int order,
                        std::vector<QuadraturePoint>& out);

// The same rule as structure of arrays (point k is (x[k], y[k], z[k]) with weight[k]), for the
// batched point-to-polygon evaluator; the same values, bit for bit, as the overload above.
struct QuadratureRule {
  std::vector<double> x, y, z, weight;
  size_t size() const { return weight.size(); }
};
void element_quadrature(std::span<const Vec3> corners, int order, QuadratureRule& out);

}  // namespace radlab
