#include "formfactor/integrate/polygon_integral.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <glm/geometric.hpp>

#include "formfactor/integrate/pair_geometry.h"
#include "formfactor/integrate/point_polygon.h"
#include "formfactor/integrate/quadrature.h"

namespace radlab {
namespace {

thread_local std::vector<Vec3> t_clip;

// The rule's weighted sum of F_{dx->P_j}, the points evaluated in one batch (point_polygon.h).
double apply_rule(const QuadratureRule& rule, const Vec3& n, const PolygonRef& to) {
  thread_local std::vector<double> values;
  const size_t count = rule.size();
  values.resize(count);
  point_to_polygon_form_factors({rule.x.data(), rule.y.data(), rule.z.data(), count}, n, to.corners,
                                to.normal, values.data(), t_clip);
  double sum = 0.0;
  for (size_t k = 0; k < count; ++k) sum += rule.weight[k] * values[k];
  return sum;
}

double rule_on(std::span<const Vec3> corners, const Vec3& n, const PolygonRef& to, int order,
               long long* evaluations) {
  thread_local QuadratureRule rule;
  element_quadrature(corners, order, rule);
  if (evaluations) *evaluations += static_cast<long long>(rule.size());
  return apply_rule(rule, n, to);
}

// The fixed rules of the polygon integrated last, one per order: a form-factor row integrates
// over the same element i against every j, so its rules are built once per order and row
// instead of once per pair (building one cost about a third of evaluating it). Recognised by
// its corners, compared bit for bit, so a hit is the very rule element_quadrature would build; a
// polygon clipped differently for each j (i in front of j's plane in part only) takes the slot
// and gives it back at the next whole one.
struct CachedRule {
  std::vector<Vec3> corners;
  QuadratureRule rule;
};

const QuadratureRule& fixed_rule(std::span<const Vec3> corners, int order) {
  thread_local std::array<CachedRule, 33> cache;
  CachedRule& slot = cache[size_t(std::clamp(order, 1, 32))];
  // Bit patterns, not ==: -0 and 0 (and NaNs) are told apart, so a hit is the same input.
  const auto same = [](const Vec3& a, const Vec3& b) { return std::memcmp(&a, &b, sizeof a) == 0; };
  if (!std::equal(corners.begin(), corners.end(), slot.corners.begin(), slot.corners.end(), same)) {
    slot.corners.assign(corners.begin(), corners.end());
    element_quadrature(corners, order, slot.rule);
  }
  return slot.rule;
}

// Area of a convex polygon from edge vectors relative to its first corner: unlike Newell's sum of
// absolute cross products it keeps its relative accuracy for cells far smaller than their distance
// from the origin (the children of a sliver near a shared corner).
double cell_area(std::span<const Vec3> c) {
  Vec3 twice(0.0);
  for (size_t k = 1; k + 1 < c.size(); ++k) twice += glm::cross(c[k] - c[0], c[k + 1] - c[0]);
  return 0.5 * glm::length(twice);
}

// Adaptive integration over cells: quads, or triangles (p0, p1, p2) as collapsed quads
// (p0, p1, p2, p0), whose bilinear map is the Duffy map of the triangle rules (quadrature.h). A
// bilinear map restricted to a quarter of its parameter square is the bilinear map of the
// quarter's four corner images, so every cell's children are cells of the same kind.
using Quad = std::array<Vec3, 4>;

std::array<Quad, 4> quarters(const Quad& c) {
  const Vec3 m01 = 0.5 * (c[0] + c[1]), m12 = 0.5 * (c[1] + c[2]), m23 = 0.5 * (c[2] + c[3]),
             m30 = 0.5 * (c[3] + c[0]), mid = 0.25 * (c[0] + c[1] + c[2] + c[3]);
  return {
      {{c[0], m01, mid, m30}, {m01, c[1], m12, mid}, {mid, m12, c[2], m23}, {m30, mid, m23, c[3]}}};
}

struct Integrand {
  const Vec3& normal;
  const PolygonRef& to;
  long long* evaluations;
  double to_shortest_edge;                // the smallest feature of P_j a cell must resolve
  const PointIntegrand* point = nullptr;  // another integrand in place of F_{dx->to}
  // Integral over the cell (not normalised): area * mean of F_{dx->to} by the 3x3 Gauss rule.
  double operator()(const Quad& c) const {
    const double a = cell_area(c);
    if (!(a > 0.0)) return 0.0;
    if (!point) return a * rule_on(c, normal, to, 3, evaluations);
    thread_local QuadratureRule rule;
    element_quadrature(c, 3, rule);
    if (evaluations) *evaluations += static_cast<long long>(rule.size());
    double sum = 0.0;
    for (size_t k = 0; k < rule.size(); ++k)
      sum += rule.weight[k] * (*point)(Vec3(rule.x[k], rule.y[k], rule.z[k]));
    return a * sum;
  }
};

// A leaf of the adaptive partition: its estimate is the sum of its four children's rules, its
// error estimate the difference from its own rule (conservative: the error of the coarser one),
// but at least 1/256 of its parent's. For a smooth integrand the 3x3 rule's error falls as h^6
// per unit area, so each child of a cell has about 1/256 of the cell's error; a smaller
// difference is the two rules agreeing by chance, not convergence (without this bound a
// Cornell block face standing on a floor element stopped at 333 evaluations, 4.3x off its 1e-4).
struct Cell {
  Quad corners;
  std::array<double, 4> children{};
  double value = 0.0;
  double estimated_error = 0.0;  // from the rules (passed down as the children's lower bound)
  double error = 0.0;            // the error the global rule works with (may be a bound instead)
  int depth = 0;
};

Cell prepare(const Quad& corners, double own, int depth, double parent_error, const Integrand& f) {
  Cell cell;
  cell.corners = corners;
  cell.depth = depth;
  const auto kids = quarters(corners);
  for (size_t k = 0; k < 4; ++k) {
    cell.children[k] = f(kids[k]);
    cell.value += cell.children[k];
  }
  cell.estimated_error = std::max(std::abs(cell.value - own), parent_error / 256.0);
  cell.error = cell.estimated_error;
  // A cell within its own size of P_j and larger than P_j's shortest edge may hold a feature of
  // the integrand far smaller than itself (P_j touching P_i along a short edge, e.g. a desk leg
  // under a large top), which its 3x3 rules and its children's can all miss and agree on (0.5%
  // off at 1e-4 in office2). Until it is no larger than that edge its estimate is not trusted:
  // its error is its largest possible integral, area * max F_{dx->P_j} = area, so the global
  // rule refines it. (Its children still take their lower bound from the estimate.)
  Vec3 centre(0.0);
  for (const Vec3& v : corners) centre += 0.25 * v;
  double radius = 0.0;
  for (const Vec3& v : corners) radius = std::max(radius, glm::distance(v, centre));
  if (2.0 * radius > f.to_shortest_edge &&
      point_polygon_distance(centre, f.to.corners, f.to.normal) < 2.0 * radius)
    cell.error = std::max(cell.error, cell_area(corners));
  return cell;
}

// Global adaptive rule over the root cells: repeatedly splits the leaf with the largest error
// estimate until the estimated total error is within max(tolerance * |total|, floor), or no leaf
// may be split again. The budget is the whole integral's: cells along a singular edge, a tiny
// share of the integral however poorly resolved relative to their own size, stop once their
// absolute error is small. (The rule this replaces asked every cell for `tolerance` relative to
// its own value, so it refined every cell along a shared edge to max_depth.)
// With `max_evaluations` > 0 it also stops once the integrand has been evaluated that often
// (`*f.evaluations` counted from the call), and `remaining`, if given, receives the estimated
// error of the returned value: the leaves' estimates plus those of the cells kept at max_depth.
// With `split_every_root`, every root is split once before the global rule starts (many small
// roots, each of whose coarse rules can agree by chance, raycast.cpp's close pairs), and the cap
// counts from there; otherwise only the first cell taken is.
double integrate_cells(std::span<const Quad> roots, const Integrand& f, double tolerance,
                       double floor, int max_depth, long long max_evaluations = 0,
                       double* remaining = nullptr, bool split_every_root = false) {
  thread_local std::vector<Cell> heap;
  heap.clear();
  const auto by_error = [](const Cell& a, const Cell& b) { return a.error < b.error; };
  double value = 0.0, error = 0.0, settled = 0.0, settled_error = 0.0;
  long long start = *f.evaluations;
  auto push = [&](const Cell& cell) {
    heap.push_back(cell);
    value += cell.value;
    error += cell.error;
    std::push_heap(heap.begin(), heap.end(), by_error);
  };
  for (const Quad& root : roots) {
    const Cell cell = prepare(root, f(root), 0, 0.0, f);
    if (!split_every_root || max_depth < 1) {
      push(cell);
      continue;
    }
    const auto kids = quarters(cell.corners);
    for (size_t k = 0; k < 4; ++k)
      push(prepare(kids[k], cell.children[k], 1, cell.estimated_error, f));
  }
  // The cap counts the refinement beyond that start, as it does for a single root.
  if (split_every_root) start = *f.evaluations;
  // Split at least once: a root's rules are coarse enough to agree by chance.
  long long steps = 0;
  for (bool first = true; !heap.empty(); first = false) {
    // A non-finite value does not improve with refinement: return it (diagnostics report it).
    if (!std::isfinite(value) || !std::isfinite(error)) return value + error;
    // The running sums are made by adding children and taking parents away; over many steps
    // their rounding, on the scale of the first and largest cells' errors, can exceed a tight
    // tolerance itself. examp1.mgf's reflector strips at tolerance 1e-9: the running error sum
    // stood at 6.7e-16 against 1.55e-16 allowed while the cells' own errors summed to 3.1e-19,
    // and the pair refined on for ever (to exact's work cap). So both are summed afresh from the
    // cells at steps 1024, 2048, 4096, ...: O(1) a step on average, and an integral that
    // converges in fewer steps (nearly all) is unchanged, bit for bit.
    if (++steps >= 1024 && (steps & (steps - 1)) == 0) {
      value = 0.0, error = 0.0;
      for (const Cell& cell : heap) value += cell.value, error += cell.error;
    }
    if (!first && error <= std::max(tolerance * std::abs(value + settled), floor)) break;
    if (max_evaluations > 0 && *f.evaluations - start >= max_evaluations) break;
    std::pop_heap(heap.begin(), heap.end(), by_error);
    const Cell cell = heap.back();
    heap.pop_back();
    value -= cell.value;
    error -= cell.error;
    if (cell.depth >= max_depth) {  // as fine as allowed: keep its estimate
      settled += cell.value;
      settled_error += cell.estimated_error;
      continue;
    }
    const auto kids = quarters(cell.corners);
    for (size_t k = 0; k < 4; ++k)
      push(prepare(kids[k], cell.children[k], cell.depth + 1, cell.estimated_error, f));
    error = std::max(error, 0.0);  // the running sums drift; the test needs a few digits only
  }
  double total = settled, left = settled_error;  // fresh sums over the leaves
  for (const Cell& cell : heap) total += cell.value, left += cell.error;
  if (remaining) *remaining = left;
  return total;
}

}  // namespace

double polygon_form_factor_fixed(const PolygonRef& from, const PolygonRef& to, int order) {
  return apply_rule(fixed_rule(from.corners, order), from.normal, to);
}

double polygon_form_factor_adaptive(const PolygonRef& from, const PolygonRef& to,
                                    double relative_tolerance, double absolute_floor, int max_depth,
                                    long long* evaluations) {
  return polygon_integral_adaptive(from, to, nullptr, relative_tolerance, absolute_floor, max_depth,
                                   evaluations);
}

namespace {

// The global adaptive rule over `roots` (quads, or triangles as collapsed quads) of total `area`
// (> 0), against P_j: the mean of the integrand over their union, and the estimated error of
// that mean.
double integrate_roots(std::span<const Quad> roots, double area, const Vec3& normal,
                       const PolygonRef& to, const PointIntegrand* integrand,
                       double relative_tolerance, double absolute_floor, int max_depth,
                       long long* evaluations, long long max_evaluations, double* estimated_error,
                       bool split_every_root) {
  double shortest = 1e300;
  for (size_t k = 0; k < to.corners.size(); ++k)
    shortest =
        std::min(shortest, glm::distance(to.corners[k], to.corners[(k + 1) % to.corners.size()]));
  long long counted = 0;  // the cap needs a count even when the caller asks for none
  const Integrand f{normal, to, &counted, shortest, integrand};
  double remaining = 0.0;
  const double mean = integrate_cells(roots, f, relative_tolerance, absolute_floor * area,
                                      max_depth, max_evaluations, &remaining, split_every_root) /
                      area;
  if (evaluations) *evaluations += counted;
  if (estimated_error) *estimated_error = remaining / area;
  return mean;
}

}  // namespace

double polygon_integral_adaptive(const PolygonRef& from, const PolygonRef& to,
                                 const PointIntegrand* integrand, double relative_tolerance,
                                 double absolute_floor, int max_depth, long long* evaluations,
                                 long long max_evaluations, double* estimated_error) {
  if (estimated_error) *estimated_error = 0.0;
  const std::span<const Vec3> c = from.corners;
  const double area = cell_area(c);
  if (!(area > 0.0)) return 0.0;
  // Root cells: a quad as it is; a triangle, or each triangle of an n-gon's fan, as a collapsed
  // quad. (An n-gon's own rule is its fan's rules, so the fan is the starting partition, not a
  // refinement to compare against: that comparison accepted any first estimate.)
  thread_local std::vector<Quad> roots;
  roots.clear();
  if (c.size() == 4) {
    roots.push_back({c[0], c[1], c[2], c[3]});
  } else {
    for (size_t k = 1; k + 1 < c.size(); ++k) roots.push_back({c[0], c[k], c[k + 1], c[0]});
  }
  return integrate_roots(roots, area, from.normal, to, integrand, relative_tolerance,
                         absolute_floor, max_depth, evaluations, max_evaluations, estimated_error,
                         false);
}

double polygon_integral_adaptive_triangles(std::span<const Vec3> triangles, const Vec3& normal,
                                           const PolygonRef& to, double relative_tolerance,
                                           double absolute_floor, int max_depth,
                                           long long* evaluations, long long max_evaluations,
                                           double* estimated_error, bool split_every_root) {
  if (estimated_error) *estimated_error = 0.0;
  thread_local std::vector<Quad> roots;
  roots.clear();
  // The total is the sum of the cells' own areas, so that their shares sum to 1 however the
  // areas round (with Newell's areas, shares that did not gave hospital.mgf rows summing to 143).
  double area = 0.0;
  for (size_t k = 0; k + 2 < triangles.size(); k += 3) {
    roots.push_back({triangles[k], triangles[k + 1], triangles[k + 2], triangles[k]});
    area += cell_area(roots.back());
  }
  if (!(area > 0.0)) return 0.0;
  return integrate_roots(roots, area, normal, to, nullptr, relative_tolerance, absolute_floor,
                         max_depth, evaluations, max_evaluations, estimated_error,
                         split_every_root);
}

void append_strip_triangles(std::span<const Vec3> corners, const Vec3& axis, int count,
                            std::vector<Vec3>& triangles) {
  if (corners.size() < 3 || count < 1) return;
  double low = 1e300, high = -1e300;
  for (const Vec3& c : corners) {
    low = std::min(low, glm::dot(c, axis));
    high = std::max(high, glm::dot(c, axis));
  }
  const double step = (high - low) / double(count);
  // Each strip is the polygon clipped to low + s step <= t <= low + (s + 1) step, by the two
  // half-planes in turn (Sutherland-Hodgman; convex in, convex out). The first strip's low cut
  // and the last's high cut are the polygon's own extent: skipped, so no corner is moved.
  thread_local std::vector<Vec3> strip, next;
  const auto clip = [](std::vector<Vec3>& in, std::vector<Vec3>& out, const Vec3& direction,
                       double cut, double sign) {
    out.clear();
    for (size_t k = 0; k < in.size(); ++k) {
      const Vec3& a = in[k];
      const Vec3& b = in[(k + 1) % in.size()];
      const double ha = sign * (glm::dot(a, direction) - cut),
                   hb = sign * (glm::dot(b, direction) - cut);
      if (ha >= 0.0) out.push_back(a);
      if ((ha > 0.0 && hb < 0.0) || (ha < 0.0 && hb > 0.0))
        out.push_back(a + (ha / (ha - hb)) * (b - a));
    }
    std::swap(in, out);
  };
  for (int s = 0; s < count; ++s) {
    strip.assign(corners.begin(), corners.end());
    if (s > 0) clip(strip, next, axis, low + double(s) * step, 1.0);
    if (s + 1 < count) clip(strip, next, axis, low + double(s + 1) * step, -1.0);
    for (size_t k = 1; k + 1 < strip.size(); ++k)
      triangles.insert(triangles.end(), {strip[0], strip[k], strip[k + 1]});
  }
}

double clip_to_front(std::vector<Vec3>& corners, const Vec3& point, const Vec3& normal,
                     double epsilon, double* lowest) {
  // Signed heights; a corner within epsilon of the plane counts as on it. Cutting an edge only
  // between a corner clearly in front and one clearly behind keeps the result free of repeated
  // corners (an exact-zero height followed by a negative one used to add the same corner twice,
  // and the zero-area fan triangle gave 0/0 weights in the quadrature).
  thread_local std::vector<double> height;
  const size_t count = corners.size();
  height.resize(count);
  bool behind = false, in_front = false;
  double least = 1e300;
  for (size_t k = 0; k < count; ++k) {
    const double h = glm::dot(corners[k] - point, normal);
    height[k] = std::abs(h) <= epsilon ? 0.0 : h;
    behind = behind || height[k] < 0.0;
    in_front = in_front || height[k] > 0.0;
    least = std::min(least, height[k]);
  }
  if (lowest) *lowest = behind ? 0.0 : least;
  if (!behind) return 1.0;
  // Nothing more than epsilon in front: at most a sliver on the plane, where the integrand is 0.
  if (!in_front) return 0.0;
  const double area = cell_area(corners);
  thread_local std::vector<Vec3> kept;
  kept.clear();
  for (size_t k = 0; k < count; ++k) {
    const size_t next = (k + 1) % count;
    const double ha = height[k], hb = height[next];
    if (ha >= 0.0) kept.push_back(corners[k]);
    if ((ha > 0.0 && hb < 0.0) || (ha < 0.0 && hb > 0.0))
      kept.push_back(corners[k] + (ha / (ha - hb)) * (corners[next] - corners[k]));
  }
  const double kept_area = kept.size() >= 3 ? cell_area(kept) : 0.0;
  if (!(kept_area > 0.0) || !(area > 0.0)) return 0.0;
  corners.assign(kept.begin(), kept.end());
  return std::min(1.0, kept_area / area);
}

FixedOrderRule::FixedOrderRule(double relative_tolerance, int max_order)
    : log_inverse_tolerance_(std::log(1000.0 / relative_tolerance)),
      inverse_tolerance_(std::exp(log_inverse_tolerance_)),
      max_order_(max_order) {}

}  // namespace radlab
