// The point-to-polygon kernel: the batched Lambert evaluator and its inline atan2
// (formfactor/integrate/point_polygon.h, fast_atan.h), the per-node quadrature and the
// logarithm-free order rule.
//
// Tolerances are derived in the comments next to them, never tuned to the measured error.
#include "formfactor/integrate/point_polygon.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <glm/gtc/matrix_transform.hpp>
#include <numbers>
#include <numeric>

#include "core/error.h"
#include "core/random.h"
#include "experiments/problem/problem.h"
#include "formfactor/integrate/fast_atan.h"
#include "formfactor/integrate/polygon_integral.h"
#include "formfactor/integrate/quadrature.h"
#include "formfactor/matrix/diagnostics.h"
#include "formfactor/matrix/matrix.h"
#include "formfactor/matrix/matrix_cache.h"
#include "formfactor/methods/exact.h"
#include "formfactor/methods/hemicube.h"
#include "formfactor/methods/raycast.h"
#include "formfactor/visibility/shaft.h"
#include "formfactor/visibility/visibility.h"
#include "scene/builtin/builtin_scenes.h"
#include "scene/geometry.h"
#include "scene/validate.h"
#include "tests/formfactor_support.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

using testing::scene_of;
using testing::square_z;
using namespace radlab::testing;

double relative_error(double value, double reference) {
  return reference == 0.0 ? std::abs(value) : std::abs(value - reference) / std::abs(reference);
}

// Both builds of atan2_upper's polynomial (fma through libm here where the CPU has none: the
// same roundings as the hardware instruction) against std::atan2 on 3.7 million points: angles
// uniform over [0, pi] at radii from 1e-20 to 1e20; tiny angles (down to 1e-300) next to 0 and
// next to pi; angles next to pi/2; and angles within 1% of the region boundaries k pi/8, where
// the reduction changes formula. The bound: a correctly rounded result is within 2^-53
// relative (1.1e-16); the reduced argument carries up to three roundings and the result one,
// against std::atan2's own (< 1 ulp), so a few ulp: 4e-16 (measured: 2.8e-16, at pi/8).
TEST(FastAtan, MatchesStdAtan2OverTheUpperHalfPlane) {
  Pcg32 rng(2024);
  const double pi = std::numbers::pi;
  double worst[2] = {0.0, 0.0};
  auto check = [&](double y, double x) {
    const double reference = std::atan2(y, x);
    worst[0] = std::max(worst[0], relative_error(atan2_upper<false>(y, x), reference));
    worst[1] = std::max(worst[1], relative_error(atan2_upper<true>(y, x), reference));
  };
  for (int k = 0; k < 1000000; ++k) {
    const double angle = pi * rng.next_double(),
                 radius = std::pow(10.0, 40.0 * rng.next_double() - 20.0);
    check(radius * std::sin(angle), radius * std::cos(angle));
  }
  for (int k = 0; k < 500000; ++k) {
    const double tiny = std::pow(10.0, -300.0 * rng.next_double()), x = 0.5 + rng.next_double();
    check(tiny * x, x);   // next to 0
    check(tiny * x, -x);  // next to pi
    const double small = std::pow(10.0, -16.0 * rng.next_double());
    check(x, small * x);  // next to pi/2, either side
    check(x, -small * x);
  }
  for (int boundary = 1; boundary <= 7; ++boundary)
    for (int k = 0; k < 100000; ++k) {
      const double angle = boundary * pi / 8.0 * (1.0 + 0.02 * (rng.next_double() - 0.5));
      check(std::sin(angle), std::cos(angle));
    }
  EXPECT_LE(worst[0], 4e-16);
  EXPECT_LE(worst[1], 4e-16);
  // The axes exactly.
  EXPECT_EQ(atan2_upper(0.0, 1.0), 0.0);
  EXPECT_EQ(atan2_upper(0.0, -1.0), pi);
  EXPECT_EQ(atan2_upper(1.0, 0.0), pi / 2);
  EXPECT_EQ(atan2_upper(1.0, -0.0), pi / 2);
  EXPECT_EQ(atan2_upper(1e-300, 1.0), 1e-300);
}

// A random convex polygon: corners on an ellipse in a random plane, counter-clockwise about the
// returned front normal.
std::vector<Vec3> random_polygon(Pcg32& rng, size_t corners, Vec3& normal) {
  const Vec3 centre(rng.next_double() - 0.5, rng.next_double() - 0.5, rng.next_double() - 0.5);
  Vec3 u = glm::normalize(
      Vec3(rng.next_double() - 0.5, rng.next_double() - 0.5, rng.next_double() - 0.5));
  Vec3 v = glm::normalize(glm::cross(u, Vec3(0.3, 0.5, 0.8)));
  normal = glm::cross(u, v);
  const double a = 0.05 + rng.next_double(), b = 0.05 + rng.next_double();
  std::vector<double> angles(corners);
  for (double& angle : angles) angle = 2.0 * std::numbers::pi * rng.next_double();
  std::sort(angles.begin(), angles.end());
  std::vector<Vec3> polygon;
  for (double angle : angles)
    polygon.push_back(centre + a * std::cos(angle) * u + b * std::sin(angle) * v);
  return polygon;
}

// The batched evaluator against the scalar formula, both builds, on random polygons of 3 to 17
// corners (17: beyond the batched kernels, all scalar) and batches of 1 to 150 points (partial
// lanes, several blocks): points in front and above the tangent plane (the batched path), points
// whose tangent plane cuts the polygon (clipped, on the scalar path), points behind the polygon
// (0), points a hair in front of its plane (edge terms ~0.1 cancelling to ~1e-9: recomputed with
// the unfused inline atan2, so exactly the scalar result on x86-64) and far points (moderate
// cancellation, the batched path). Same formula and geometry, the atan2 polynomial fused or not:
// within 1e-13 relative (the batched path recomputes a point whose terms cancel by more than
// 300x, where the difference could exceed that), and exactly 0 where the scalar result is 0.
TEST(PointToPolygonBatch, MatchesTheScalarFormula) {
  Pcg32 rng(7);
  std::vector<Vec3> scratch;
  double worst = 0.0;
  size_t total = 0, behind = 0, clipped = 0, grazing = 0;
  for (int trial = 0; trial < 400; ++trial) {
    Vec3 normal;
    const size_t corners = 3 + size_t(trial) % 15;  // 3..17: the batched kernels go to 16
    const std::vector<Vec3> polygon = random_polygon(rng, corners, normal);
    const Vec3 centre =
        std::accumulate(polygon.begin(), polygon.end(), Vec3(0.0)) / double(corners);
    const size_t count = 1 + rng.next_below(150);
    std::vector<double> x(count), y(count), z(count);
    const Vec3 n = glm::normalize(
        Vec3(rng.next_double() - 0.5, rng.next_double() - 0.5, rng.next_double() - 0.5) -
        0.8 * normal);
    for (size_t k = 0; k < count; ++k) {
      const Vec3 offset(rng.next_double() - 0.5, rng.next_double() - 0.5, rng.next_double() - 0.5);
      Vec3 p;
      switch (k % 4) {
        case 0:
          p = centre + 3.0 * offset;
          break;  // anywhere
        case 1:
          p = centre + 8.0 * offset + 6.0 * normal;
          break;  // far
        case 2:
          p = centre + 2.0 * offset + (1e-9 - glm::dot(2.0 * offset, normal)) * normal;
          break;  // grazing
        default:
          p = centre + offset + 0.5 * normal;
          break;  // near, in front
      }
      x[k] = p.x;
      y[k] = p.y;
      z[k] = p.z;
    }
    for (BatchKernel kernel : {BatchKernel::kBest, BatchKernel::kBaseline}) {
      std::vector<double> out(count, -1.0);
      point_to_polygon_form_factors({x.data(), y.data(), z.data(), count}, n, polygon, normal,
                                    out.data(), scratch, kernel);
      for (size_t k = 0; k < count; ++k) {
        const Vec3 p(x[k], y[k], z[k]);
        const double scalar = point_to_polygon_form_factor(p, n, polygon, normal, scratch);
        const bool in_front = glm::dot(p - polygon[0], normal) > 0.0;
        if (scalar == 0.0) {
          EXPECT_EQ(out[k], 0.0) << "trial " << trial << " point " << k;
#if defined(__x86_64__)
        } else if (k % 4 == 2 && in_front) {
          EXPECT_EQ(out[k], scalar) << "grazing: trial " << trial << " point " << k;
#endif
        } else {
          worst = std::max(worst, relative_error(out[k], scalar));
          EXPECT_LE(relative_error(out[k], scalar), 1e-13) << "trial " << trial << " point " << k;
        }
        if (kernel != BatchKernel::kBest) continue;
        ++total;
        behind += !in_front;
        bool below = false;
        for (const Vec3& corner : polygon) below = below || glm::dot(corner - p, n) < 0.0;
        clipped += below && in_front;
        grazing += k % 4 == 2 && in_front;
      }
    }
  }
  // Every kind of point occurred often.
  EXPECT_GT(behind, total / 10);
  EXPECT_GT(clipped, total / 20);
  EXPECT_GT(grazing, total / 20);
  std::printf("batched vs scalar: %zu points (%zu behind, %zu clipped, %zu grazing), worst %.2g\n",
              total, behind, clipped, grazing, worst);
}

// Quadrature points of one element share its plane. A polygon crossing that plane (a floor
// running on behind a small face standing on it) is clipped to it once for the whole batch,
// not per point; each point's value must still be the scalar formula's on the part above its
// tangent plane. The configuration is rotated off the axes so that the corners the clip makes
// lie on the plane only up to rounding (they then count as on it: below_tangent_plane's
// slack). Reference: the scalar formula on the rectangle already cut at the plane by hand (its
// corners on the plane exactly, so nothing is clipped), and on the whole rectangle (clipped per
// point). Both within 1e-13 relative: the batch differs from the scalar path by a few ulp per
// edge term (point_polygon_batch.cpp), and the terms here cancel little (F ~ 0.01-0.3).
TEST(PointToPolygonBatch, CoplanarPointsClipTheCrossingPolygonOnce) {
  const glm::dmat4 turn =
      glm::rotate(glm::rotate(glm::dmat4(1.0), 0.7, Vec3(1, 2, 3)), 0.3, Vec3(-2, 1, 0.5));
  const auto rotated = [&](const Vec3& v) { return Vec3(turn * glm::dvec4(v, 1.0)); };
  const auto turned = [&](const Vec3& v) { return Vec3(turn * glm::dvec4(v, 0.0)); };
  // Points on the floor z = 0 facing up; a wall at y = 1 facing them, reaching below the floor.
  const Vec3 n = turned(Vec3(0, 0, 1)), wall_normal = turned(Vec3(0, -1, 0));
  std::vector<Vec3> wall, above;
  for (const Vec3& v : {Vec3(-1, 1, -1), Vec3(1, 1, -1), Vec3(1, 1, 2), Vec3(-1, 1, 2)})
    wall.push_back(rotated(v));
  for (const Vec3& v : {Vec3(-1, 1, 0), Vec3(1, 1, 0), Vec3(1, 1, 2), Vec3(-1, 1, 2)})
    above.push_back(rotated(v));
  std::vector<double> x, y, z;
  for (int a = 0; a < 9; ++a)
    for (int b = 0; b < 7; ++b) {
      const Vec3 p = rotated(Vec3(-0.8 + 0.2 * a, -0.5 + 0.2 * b, 0.0));
      x.push_back(p.x), y.push_back(p.y), z.push_back(p.z);
    }
  std::vector<Vec3> scratch;
  for (BatchKernel kernel : {BatchKernel::kBest, BatchKernel::kBaseline}) {
    std::vector<double> out(x.size(), -1.0);
    point_to_polygon_form_factors({x.data(), y.data(), z.data(), x.size()}, n, wall, wall_normal,
                                  out.data(), scratch, kernel);
    for (size_t k = 0; k < x.size(); ++k) {
      const Vec3 p(x[k], y[k], z[k]);
      const double cut = point_to_polygon_form_factor(p, n, above, wall_normal, scratch);
      const double whole = point_to_polygon_form_factor(p, n, wall, wall_normal, scratch);
      ASSERT_GT(cut, 0.005);
      EXPECT_LE(relative_error(out[k], cut), 1e-13) << "point " << k;
      EXPECT_LE(relative_error(whole, cut), 1e-13) << "point " << k;
    }
  }
}

// Lambert's formula is the signed integral of cos over the solid angle, so a corner a hair
// below x's tangent plane (elevation -5e-10 rad, within below_tangent_plane's slack: no clip)
// changes F by less than (5e-10)^2 against the polygon clipped to the plane: only rounding
// shows (1e-15 absolute, F ~ 0.1). A corner well below (-1e-3 rad, beyond the slack) is clipped,
// and F is again the clipped polygon's; had it been left unclipped, the part below would have
// counted about -(1e-3)^2 / pi ~ -3e-7, which the same bound would catch.
TEST(PointToPolygon, CornerAHairBelowTheTangentPlaneChangesNothing) {
  const Vec3 x(0.0), n(0, 0, 1);
  std::vector<Vec3> scratch, clipped;
  for (const double elevation : {5e-10, 1e-3}) {
    // A quad standing in front of x, its first corner (distance sqrt 2) just below x's plane.
    const std::vector<Vec3> quad = {
        {-1, 1, -elevation * std::sqrt(2.0)}, {1, 1, 0}, {1, 1.1, 1}, {-1, 1.1, 1}};
    const Vec3 normal = glm::normalize(glm::cross(quad[1] - quad[0], quad[3] - quad[0]));
    ASSERT_GT(glm::dot(x - quad[0], normal), 0.0);  // x sees its front
    geometry::clip_to_halfspace(quad, x, n, clipped);
    const double f = point_to_polygon_form_factor(x, n, quad, normal, scratch);
    const double reference = point_to_polygon_form_factor(x, n, clipped, normal, scratch);
    EXPECT_GT(reference, 0.05);
    EXPECT_NEAR(f, reference, 1e-15) << "elevation " << elevation;
    EXPECT_EQ(below_tangent_plane(quad[0] - x, n), elevation > kTangentSlack)
        << "elevation " << elevation;
  }
}

// The structure-of-arrays rule is the same rule, bit for bit (quads by their per-node path).
TEST(Quadrature, StructureOfArraysIsTheSameRule) {
  const std::vector<std::vector<Vec3>> cells = {
      {{0, 0, 0}, {1, 0, 0}, {1.2, 0.9, 0.1}, {-0.1, 1.1, 0.05}},            // general quad
      {{0, 0, 0}, {2, 0, 0}, {2, 1, 0}, {0, 1, 0}},                          // rectangle
      {{0, 0, 0}, {1, 0, 0}, {0.3, 0.8, 0.2}},                               // triangle
      {{0, 0, 0}, {1, 0, 0}, {1.3, 0.6, 0}, {0.5, 1.2, 0}, {-0.2, 0.7, 0}},  // pentagon
      {{0, 0, 0}, {1, 0, 0}, {1, 0, 0}, {0, 0, 0}}};                         // zero-area quad
  for (const std::vector<Vec3>& cell : cells)
    for (int order : {1, 2, 3, 5, 8, 32}) {
      std::vector<QuadraturePoint> points;
      QuadratureRule rule;
      element_quadrature(cell, order, points);
      element_quadrature(cell, order, rule);
      ASSERT_EQ(rule.size(), points.size());
      for (size_t k = 0; k < points.size(); ++k) {
        EXPECT_EQ(rule.x[k], points[k].position.x);
        EXPECT_EQ(rule.y[k], points[k].position.y);
        EXPECT_EQ(rule.z[k], points[k].position.z);
        EXPECT_EQ(rule.weight[k], points[k].weight);
      }
    }
}

// The order rule without logarithms chooses the orders the logarithm formula chooses: on random
// pairs, and on pairs built to sit on and a few ulp either side of every boundary between two
// orders (where X = ln(C / (tol scale)) / (2 ln r) is an integer).
TEST(FixedOrderRule, ChoosesTheOrdersOfTheLogarithmFormula) {
  auto formula = [](double tolerance, int max_order, double gap, double diameter, double scale) {
    if (!(gap > 0.0) || !(diameter > 0.0) || !(scale > 0.0)) return 0;
    const double a = 1.0 + 2.0 * gap / diameter;
    const double log_r = std::log(a + std::sqrt(a * a - 1.0));
    const double m =
        std::ceil((std::log(1000.0 / tolerance) - std::log(std::min(scale, 1.0))) / (2.0 * log_r));
    if (!(m <= double(max_order))) return 0;
    return std::max(1, int(m));
  };
  Pcg32 rng(11);
  size_t compared = 0, fixed = 0;
  for (double tolerance : {1e-2, 1e-4, 1e-7}) {
    for (int max_order : {1, 8, 32}) {
      const FixedOrderRule rule(tolerance, max_order);
      for (int k = 0; k < 20000; ++k) {
        const double gap = std::pow(10.0, 6.0 * rng.next_double() - 4.0);
        const double diameter = std::pow(10.0, 2.0 * rng.next_double() - 1.0);
        const double scale = k % 3 == 0 ? 1.0 : std::pow(10.0, -8.0 * rng.next_double());
        const int expected = formula(tolerance, max_order, gap, diameter, scale);
        EXPECT_EQ(rule.order(gap, diameter, scale), expected)
            << gap << " " << diameter << " " << scale;
        ++compared;
        fixed += expected > 0;
      }
      // On the boundaries: r^(2m) scale = C / tolerance exactly (in real numbers), then nudged.
      for (int m = 1; m <= std::min(max_order + 1, 33); ++m)
        for (double scale : {1.0, 0.3, 1e-5}) {
          const double log_r = std::log(1000.0 / tolerance / scale) / (2.0 * m);
          const double a = std::cosh(log_r), diameter = 1.0;
          const double gap = (a - 1.0) * diameter / 2.0;
          double g = gap;
          for (int step = 0; step < 8; ++step) g = std::nextafter(g, 0.0);
          for (int step = 0; step < 17; ++step, g = std::nextafter(g, 1e300)) {
            EXPECT_EQ(rule.order(g, diameter, scale),
                      formula(tolerance, max_order, g, diameter, scale))
                << "m " << m << " gap " << g << " scale " << scale;
            ++compared;
          }
        }
      // Degenerate input: what the formula gives.
      for (double gap : {0.0, -1.0, std::nan("")})
        EXPECT_EQ(rule.order(gap, 1.0, 1.0), formula(tolerance, max_order, gap, 1.0, 1.0));
      EXPECT_EQ(rule.order(1.0, 1.0, 0.0), 0);
      EXPECT_EQ(rule.order(1e300, 1e-300, 1.0), formula(tolerance, max_order, 1e300, 1e-300, 1.0));
    }
  }
  EXPECT_GT(fixed, compared / 4);
}

}  // namespace
}  // namespace radlab
