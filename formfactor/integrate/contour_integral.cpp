#include "formfactor/integrate/contour_integral.h"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <limits>
#include <numbers>
#include <vector>

#include "formfactor/integrate/fast_atan.h"
#include "formfactor/integrate/polygon_integral.h"
#include "scene/geometry.h"

namespace radlab {
namespace {

// The 15-point Gauss–Kronrod rule on [-1, 1]: nodes 0..6 and the centre (7) with their Kronrod
// weights; the odd nodes 1, 3, 5 and the centre are the 7-point Gauss rule's, with its weights.
constexpr double kNode[8] = {
    0.991455371120812639206854697526329, 0.949107912342758524526189684047851,
    0.864864423359769072789712788640926, 0.741531185599394439863864773280788,
    0.586087235467691130294144845693013, 0.405845151377397166906606412076961,
    0.207784955007898467600689403773245, 0.0};
constexpr double kKronrod[8] = {
    0.022935322010529224963732008058970, 0.063092092629978553290700663189204,
    0.104790010322250183839876322541518, 0.140653259715525918745189590510238,
    0.169004726639267902826583426598550, 0.190350578064785409913256402421014,
    0.204432940075298892414161999234649, 0.209482141084727828012999174891714};
constexpr double kGauss[4] = {  // at nodes 1, 3, 5 and the centre
    0.129484966168869693270611432679082, 0.279705391489276667901467771423780,
    0.381830050505118944950369775488975, 0.417959183673469387755102040816327};
constexpr int kPoints = 15;

// Below these (in units of the pair's size) edges count as collinear, break points as equal.
constexpr double kCollinear = 1e-12;
constexpr double kNarrowest = 1e-13;
// Polygons narrower than this many plane epsilons (callers' clip_to_front tolerance, 1e-9 of
// the scene's size) are left to the area rule (contour_form_factor_front).
constexpr double kResolvable = 1000.0;
// Rounding per evaluated term, in units of its magnitude: the inner closed form's few
// operations and the sums over cells and edge pairs (a generous count of epsilons).
constexpr double kRounding = 64.0 * std::numeric_limits<double>::epsilon();

struct Edge {
  Vec3 start, direction;  // unit direction
  double length = 0.0;
};

// ∫ ln sqrt(τ² + h²) dτ, with h >= 0 (0 at τ = 0, where τ ln|τ| -> 0).
double log_distance_antiderivative(double tau, double h) {
  const double square = tau * tau + h * h;
  if (tau == 0.0 || square == 0.0) return 0.0;  // (an underflowing square: |τ| < 1e-154)
  // atan2(τ, h) = sign(τ) atan2(|τ|, h): the inline upper half-plane atan2 (fast_atan.h).
  return 0.5 * tau * std::log(square) - tau + h * std::copysign(atan2_upper(std::abs(tau), h), tau);
}

// Φ with Φ'' = ln|z|, Φ(0) = 0: z² ln|z| / 2 - 3 z² / 4.
double log_second_antiderivative(double z) {
  if (z == 0.0) return 0.0;
  return z * z * (0.5 * std::log(std::abs(z)) - 0.75);
}

struct EdgePair {
  const Edge* p;
  const Edge* q;
  double weight;  // e_p · e_q
};

// The inner integral ∫_0^{L_q} ln |x - Q(t)| dt in closed form, and the magnitude of the terms
// it took the difference of (for the rounding floor).
struct Inner {
  double value, magnitude;
};
Inner inner_integral(const Vec3& x, const Edge& q) {
  const Vec3 d = x - q.start;
  const double along = glm::dot(d, q.direction);
  const double h = glm::length(d - along * q.direction);
  const double end = log_distance_antiderivative(q.length - along, h);
  const double begin = log_distance_antiderivative(-along, h);
  return {end - begin, std::abs(end) + std::abs(begin)};
}

struct Cell {
  const EdgePair* pair;
  double a, b;                     // the outer parameter's interval on edge p
  double value, error, magnitude;  // Kronrod estimate, |K15 - G7|, Σ w |terms|
  double weighted_error() const { return std::abs(pair->weight) * error; }
};

Cell kronrod_cell(const EdgePair& pair, double a, double b) {
  const double centre = 0.5 * (a + b), half = 0.5 * (b - a);
  const Edge& p = *pair.p;
  double kronrod = 0.0, gauss = 0.0, magnitude = 0.0;
  for (int k = 0; k < 8; ++k) {
    const int sides = k == 7 ? 1 : 2;
    for (int side = 0; side < sides; ++side) {
      const double s = centre + (side == 0 ? -half : half) * kNode[k];
      const Inner g = inner_integral(p.start + s * p.direction, *pair.q);
      kronrod += kKronrod[k] * g.value;
      magnitude += kKronrod[k] * g.magnitude;
      if (k == 7)
        gauss += kGauss[3] * g.value;
      else if (k % 2 == 1)
        gauss += kGauss[k / 2] * g.value;
    }
  }
  return {&pair, a, b, half * kronrod, half * std::abs(kronrod - gauss), half * magnitude};
}

// ∫∫ ln|x - y| over two collinear edges, in closed form.
Inner collinear_integral(const Edge& p, const Edge& q) {
  const double c = glm::dot(q.start - p.start, p.direction);
  const double d = c + q.length * glm::dot(q.direction, p.direction);
  const double lo = std::min(c, d), hi = std::max(c, d), length = p.length;
  const double terms[4] = {log_second_antiderivative(length - lo), log_second_antiderivative(-lo),
                           log_second_antiderivative(length - hi), log_second_antiderivative(-hi)};
  return {terms[0] - terms[1] - terms[2] + terms[3],
          std::abs(terms[0]) + std::abs(terms[1]) + std::abs(terms[2]) + std::abs(terms[3])};
}

bool collinear(const Edge& p, const Edge& q) {
  if (glm::length(glm::cross(p.direction, q.direction)) > kCollinear) return false;
  for (const Vec3& x : {q.start, q.start + q.length * q.direction}) {
    const Vec3 d = x - p.start;
    if (glm::length(d - glm::dot(d, p.direction) * p.direction) > kCollinear) return false;
  }
  return true;
}

// The outer integrand's kinks on edge p: the feet of q's ends on p's line, and where the two
// lines come closest; the parameters strictly inside (0, L_p), sorted, with both ends.
void break_points(const Edge& p, const Edge& q, std::vector<double>& out) {
  out.clear();
  const auto add = [&](double s) { out.push_back(std::clamp(s, 0.0, p.length)); };
  add(0.0);
  add(p.length);
  add(glm::dot(q.start - p.start, p.direction));
  add(glm::dot(q.start + q.length * q.direction - p.start, p.direction));
  const double b = glm::dot(p.direction, q.direction);
  const double denominator = 1.0 - b * b;
  if (denominator > kCollinear) {
    const Vec3 w = p.start - q.start;
    add((b * glm::dot(q.direction, w) - glm::dot(p.direction, w)) / denominator);
  }
  std::sort(out.begin(), out.end());
  // Points within the margin of the one before are dropped; L_p replaces the last one kept.
  const double margin = kNarrowest * std::max(p.length, 1.0);
  size_t kept = 1;  // out[0] = 0
  for (size_t k = 1; k < out.size(); ++k)
    if (out[k] - out[kept - 1] > margin) out[kept++] = out[k];
  if (kept == 1) kept = 2;  // an edge shorter than the margin: one cell
  out[kept - 1] = p.length;
  out.resize(kept);
}

double distance_to_edge(const Vec3& x, const Edge& q) {
  const double along = std::clamp(glm::dot(x - q.start, q.direction), 0.0, q.length);
  return glm::distance(x, q.start + along * q.direction);
}

// Between break points the integrand is analytic but, where edge q passes at a distance δ from
// a break point, varies on the scale δ there: a cell much wider than its distance from such a
// point is not resolved, and its two rules can agree by chance (a pair 1e-5 apart stated 5.9e-10
// with 7.1e-10 true error). So the cells are graded towards each break point, widths δ, 2δ,
// 4δ, ... (δ > 0; at δ = 0 the adaptive splits do it), each no wider than its distance from
// the break point, where the Kronrod difference is a reliable estimate.
void grade(const Edge& p, const Edge& q, const std::vector<double>& points,
           std::vector<double>& out) {
  out.clear();
  const double floor = kNarrowest * std::max(p.length, 1.0);
  for (size_t k = 0; k + 1 < points.size(); ++k) {
    const double a = points[k], b = points[k + 1], middle = 0.5 * (a + b);
    out.push_back(a);
    const double from_a = std::max(distance_to_edge(p.start + a * p.direction, q), floor);
    for (double w = from_a; a + w < middle; w *= 2.0) out.push_back(a + w);
    const size_t rising = out.size();
    const double from_b = std::max(distance_to_edge(p.start + b * p.direction, q), floor);
    for (double w = from_b; b - w > middle; w *= 2.0) out.push_back(b - w);
    std::reverse(out.begin() + std::ptrdiff_t(rising), out.end());
  }
  out.push_back(points.back());
}

// The edges of a polygon in the scaled frame, in the order that runs counterclockwise about
// `normal`: the corners' own order unless their winding (Newell's sum) says otherwise. A sliver
// whose corners are nearly collinear can wind against its element's normal by rounding (a
// 3.4e-10 m^2 triangle of hospital.mgf's tafeltje.mgf:917 did), which would flip the sign.
void edges_of(std::span<const Vec3> corners, const Vec3& normal, const Vec3& origin, double scale,
              std::vector<Edge>& out) {
  out.clear();
  const size_t n = corners.size();
  Vec3 winding{0.0};
  for (size_t k = 0; k < n; ++k)
    winding += glm::cross(corners[k] - origin, corners[(k + 1) % n] - origin);
  const bool reverse = glm::dot(winding, normal) < 0.0;
  for (size_t k = 0; k < n; ++k) {
    const size_t from = reverse ? n - 1 - k : k, to = reverse ? (2 * n - 2 - k) % n : (k + 1) % n;
    const Vec3 a = (corners[from] - origin) / scale;
    const Vec3 b = (corners[to] - origin) / scale;
    const double length = glm::distance(a, b);
    if (length > 0.0) out.push_back({a, (b - a) / length, length});
  }
}

}  // namespace

ContourIntegral contour_form_factor(std::span<const Vec3> i, const Vec3& normal_i,
                                    std::span<const Vec3> j, const Vec3& normal_j, double area_i,
                                    double relative_tolerance, long long max_evaluations) {
  ContourIntegral result;
  if (i.size() < 3 || j.size() < 3 || !(area_i > 0.0)) return result;
  // Coordinates relative to a corner of i and in units of the pair's extent: the logarithms'
  // constant part, which cancels over the closed outlines, then stays small.
  const Vec3 origin = i[0];
  double scale = 0.0;
  for (const Vec3& x : i) scale = std::max(scale, glm::distance(x, origin));
  for (const Vec3& x : j) scale = std::max(scale, glm::distance(x, origin));
  if (!(scale > 0.0) || !std::isfinite(scale)) return result;
  thread_local std::vector<Edge> edges_i, edges_j;
  thread_local std::vector<EdgePair> pairs;
  thread_local std::vector<Cell> cells;
  thread_local std::vector<double> points, graded;
  edges_of(i, normal_i, origin, scale, edges_i);
  edges_of(j, normal_j, origin, scale, edges_j);
  pairs.clear();
  cells.clear();
  pairs.reserve(edges_i.size() * edges_j.size());  // stable addresses for the cells
  double closed = 0.0, closed_magnitude = 0.0;     // the collinear pairs' exact part
  for (const Edge& p : edges_i)
    for (const Edge& q : edges_j) {
      const double weight = glm::dot(p.direction, q.direction);
      if (weight == 0.0) continue;
      if (collinear(p, q)) {
        const Inner c = collinear_integral(p, q);
        closed += weight * c.value;
        closed_magnitude += std::abs(weight) * c.magnitude;
        continue;
      }
      pairs.push_back({&p, &q, weight});
      break_points(p, q, points);
      grade(p, q, points, graded);
      for (size_t k = 0; k + 1 < graded.size(); ++k)
        cells.push_back(kronrod_cell(pairs.back(), graded[k], graded[k + 1]));
    }
  long long evaluations = kPoints * static_cast<long long>(cells.size());

  const auto by_error = [](const Cell& x, const Cell& y) {
    return x.weighted_error() < y.weighted_error();
  };
  double value = 0.0, error = 0.0, magnitude = 0.0;
  // Sums afresh from the cells (a running sum of differences drifts: polygon_integral.cpp).
  const auto resum = [&] {
    value = closed;
    error = 0.0;
    magnitude = closed_magnitude;
    for (const Cell& c : cells) {
      value += c.pair->weight * c.value;
      error += c.weighted_error();
      magnitude += std::abs(c.pair->weight) * c.magnitude;
    }
  };
  resum();
  std::make_heap(cells.begin(), cells.end(), by_error);
  for (;;) {
    const double floor = kRounding * magnitude;
    const double target = relative_tolerance * std::abs(value);
    if (error + floor <= target) {
      resum();  // confirm with fresh sums before stopping
      if (error + kRounding * magnitude <= relative_tolerance * std::abs(value)) break;
    }
    if (floor >= target || cells.empty() || evaluations + 2 * kPoints > max_evaluations) break;
    std::pop_heap(cells.begin(), cells.end(), by_error);
    const Cell worst = cells.back();
    const double middle = 0.5 * (worst.a + worst.b);
    if (!(worst.b - worst.a > kNarrowest * worst.pair->p->length) || worst.error == 0.0) {
      std::push_heap(cells.begin(), cells.end(), by_error);
      break;  // the worst cell cannot be split further: what it holds is stated
    }
    cells.pop_back();
    const Cell left = kronrod_cell(*worst.pair, worst.a, middle);
    const Cell right = kronrod_cell(*worst.pair, middle, worst.b);
    evaluations += 2 * kPoints;
    const double w = worst.pair->weight, aw = std::abs(w);
    value += w * (left.value + right.value - worst.value);
    error += aw * (left.error + right.error - worst.error);
    magnitude += aw * (left.magnitude + right.magnitude - worst.magnitude);
    for (const Cell& c : {left, right}) {
      cells.push_back(c);
      std::push_heap(cells.begin(), cells.end(), by_error);
    }
  }
  resum();
  const double stated = error + kRounding * magnitude;
  const double normaliser = 2.0 * std::numbers::pi * area_i / (scale * scale);
  result.form_factor = value / normaliser;
  result.error = stated / normaliser;
  result.evaluations = evaluations;
  // F is never negative: a negative value beyond the stated error means the outlines' windings
  // or the clipping went wrong, and the caller must integrate the pair another way.
  result.converged =
      std::isfinite(value) && stated <= relative_tolerance * std::abs(value) && value >= -stated;
  return result;
}

ContourIntegral contour_form_factor_front(std::span<const Vec3> from, const Vec3& point_i,
                                          const Vec3& normal_i, std::span<const Vec3> to,
                                          const Vec3& normal_j, double area_i, double epsilon,
                                          double relative_tolerance, long long max_evaluations) {
  thread_local std::vector<Vec3> seen;
  seen.assign(to.begin(), to.end());
  if (!(clip_to_front(seen, point_i, normal_i, epsilon) > 0.0)) return {};
  // A polygon narrower than kResolvable epsilons is not resolved by the geometry: the identity
  // needs each polygon on its own side of the other's plane, and a sliver lying along the other's
  // edge can be on either side by that edge's own departure from its plane (hospital.mgf's
  // tafeltje.mgf:917: a triangle 5.5e-8 m wide along the top edge of a face whose top edge leaves
  // the face's plane by 2.3e-7 m; the identity gave -0.50 where the area rule gives +0.50).
  const auto width = [](std::span<const Vec3> p) {
    double longest = 0.0;
    for (size_t k = 0; k < p.size(); ++k)
      longest = std::max(longest, glm::distance(p[k], p[(k + 1) % p.size()]));
    return longest > 0.0 ? 2.0 * geometry::area(p) / longest : 0.0;
  };
  if (width(from) <= kResolvable * epsilon || width(seen) <= kResolvable * epsilon) return {};
  return contour_form_factor(from, normal_i, seen, normal_j, area_i, relative_tolerance,
                             max_evaluations);
}

}  // namespace radlab
