#include "formfactor/integrate/quadrature.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <glm/geometric.hpp>
#include <mutex>
#include <numbers>

namespace radlab {
namespace {

struct Rule {
  std::vector<double> nodes, weights;
};

// Newton iteration on the Legendre polynomial, nodes mapped to [0,1].
Rule compute_rule(int order) {
  Rule rule;
  const int n = order;
  for (int i = 0; i < n; ++i) {
    double x = std::cos(std::numbers::pi * (i + 0.75) / (n + 0.5));
    double dp = 0.0;
    for (int iteration = 0; iteration < 100; ++iteration) {
      double p0 = 1.0, p1 = x;
      for (int k = 2; k <= n; ++k) {
        double pk = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = pk;
      }
      dp = n * (x * p1 - p0) / (x * x - 1.0);
      double dx = p1 / dp;
      x -= dx;
      if (std::abs(dx) < 1e-16) break;
    }
    rule.nodes.push_back(0.5 * (1.0 - x));
    rule.weights.push_back(1.0 / ((1.0 - x * x) * dp * dp));  // (2/((1-x^2)p'^2)) / 2
  }
  return rule;
}

const Rule& cached_rule(int order) {
  static std::array<Rule, 33> rules;
  static std::once_flag once;
  std::call_once(once, [] {
    for (int k = 1; k <= 32; ++k) rules[size_t(k)] = compute_rule(k);
  });
  return rules[size_t(std::clamp(order, 1, 32))];
}

// Emit(position, weight) receives the rule's points in order.
template <class Emit>
void triangle_rule(const Vec3& p0, const Vec3& p1, const Vec3& p2, double area_fraction,
                   const Rule& rule, Emit&& emit) {
  // x(u, v) = p0 + u (p1 - p0) + u v (p2 - p1), Jacobian 2A u: the collapsed square.
  const size_t n = rule.nodes.size();
  for (size_t a = 0; a < n; ++a)
    for (size_t b = 0; b < n; ++b) {
      double u = rule.nodes[a], v = rule.nodes[b];
      Vec3 x = p0 + u * (p1 - p0) + u * v * (p2 - p1);
      emit(x, area_fraction * 2.0 * u * rule.weights[a] * rule.weights[b]);
    }
}

template <class Emit>
void element_rule(std::span<const Vec3> c, int order, Emit&& emit) {
  const Rule& rule = cached_rule(order);
  const size_t n = rule.nodes.size();
  if (c.size() == 4) {
    // Bilinear map of the unit square; weight = |dx/ds x dx/dt| / area.
    const Vec3 total = glm::cross(c[2] - c[0], c[3] - c[1]);  // 2 x vector area
    const double area2 = glm::length(total);
    for (size_t a = 0; a < n; ++a)
      for (size_t b = 0; b < n; ++b) {
        double s = rule.nodes[a], t = rule.nodes[b];
        Vec3 x = (1 - s) * (1 - t) * c[0] + s * (1 - t) * c[1] + s * t * c[2] + (1 - s) * t * c[3];
        Vec3 ds = (1 - t) * (c[1] - c[0]) + t * (c[2] - c[3]);
        Vec3 dt = (1 - s) * (c[3] - c[0]) + s * (c[2] - c[1]);
        double jacobian = glm::length(glm::cross(ds, dt));
        // A degenerate quad (zero area) has no area to share out: plain tensor weights, so the
        // weights still sum to 1 and stay finite.
        const double share = area2 > 0.0 ? 2.0 * jacobian / area2 : 1.0;
        emit(x, share * rule.weights[a] * rule.weights[b]);
      }
    return;
  }
  // Triangles and fans: split the weight by each triangle's share of the area; zero-area fan
  // triangles (a clipped polygon's collinear corners) get no points. A polygon of zero area has no
  // share to split: its first triangle takes all the weight, so the weights sum to 1 and stay
  // finite.
  double total = 0.0;
  for (size_t k = 1; k + 1 < c.size(); ++k)
    total += 0.5 * glm::length(glm::cross(c[k] - c[0], c[k + 1] - c[0]));
  for (size_t k = 1; k + 1 < c.size(); ++k) {
    const double a = 0.5 * glm::length(glm::cross(c[k] - c[0], c[k + 1] - c[0]));
    const double share = total > 0.0 ? a / total : (k == 1 ? 1.0 : 0.0);
    if (share > 0.0) triangle_rule(c[0], c[k], c[k + 1], share, rule, emit);
  }
}

}  // namespace

void gauss_legendre_unit(int order, std::vector<double>& nodes, std::vector<double>& weights) {
  const Rule& rule = cached_rule(order);
  nodes = rule.nodes;
  weights = rule.weights;
}

void element_quadrature(std::span<const Vec3> c, int order, std::vector<QuadraturePoint>& out) {
  out.clear();
  element_rule(c, order, [&out](const Vec3& x, double w) { out.push_back({x, w}); });
}

void element_quadrature(std::span<const Vec3> c, int order, QuadratureRule& out) {
  const Rule& rule = cached_rule(order);
  const size_t n = rule.nodes.size();
  if (c.size() == 4) {
    // The quad rule above, computed once per node where a factor depends on one node only (the
    // same expressions, so the same values): dx/ds depends on t alone, dx/dt on s alone.
    const size_t count = n * n;
    out.x.resize(count);
    out.y.resize(count);
    out.z.resize(count);
    out.weight.resize(count);
    const Vec3 total = glm::cross(c[2] - c[0], c[3] - c[1]);
    const double area2 = glm::length(total);
    std::array<Vec3, 32> ds, dt;
    for (size_t k = 0; k < n; ++k) {
      const double u = rule.nodes[k];
      ds[k] = (1 - u) * (c[1] - c[0]) + u * (c[2] - c[3]);
      dt[k] = (1 - u) * (c[3] - c[0]) + u * (c[2] - c[1]);
    }
    for (size_t a = 0; a < n; ++a)
      for (size_t b = 0; b < n; ++b) {
        const double s = rule.nodes[a], t = rule.nodes[b];
        const Vec3 x =
            (1 - s) * (1 - t) * c[0] + s * (1 - t) * c[1] + s * t * c[2] + (1 - s) * t * c[3];
        const double jacobian = glm::length(glm::cross(ds[b], dt[a]));
        const double share = area2 > 0.0 ? 2.0 * jacobian / area2 : 1.0;
        const size_t k = a * n + b;
        out.x[k] = x.x;
        out.y[k] = x.y;
        out.z[k] = x.z;
        out.weight[k] = share * rule.weights[a] * rule.weights[b];
      }
    return;
  }
  out.x.clear();
  out.y.clear();
  out.z.clear();
  out.weight.clear();
  element_rule(c, order, [&out](const Vec3& x, double w) {
    out.x.push_back(x.x);
    out.y.push_back(x.y);
    out.z.push_back(x.z);
    out.weight.push_back(w);
  });
}

}  // namespace radlab
