// The contour (Stokes) form factor, contour_integral.h: against Howell's catalogue, against the
// area rule on near and touching pairs, reciprocity, and its own error statement.
#include "formfactor/integrate/contour_integral.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <random>

#include "formfactor/integrate/polygon_integral.h"
#include "scene/geometry.h"
#include "tests/formfactor_support.h"

namespace radlab {
namespace {

using testing::catalogue;

Vec3 normal_of(const std::vector<Vec3>& p) {  // Newell's sum
  Vec3 n{0.0};
  for (size_t k = 0; k < p.size(); ++k) n += glm::cross(p[k] - p[0], p[(k + 1) % p.size()] - p[0]);
  return glm::normalize(n);
}

// The area rule (Lambert's formula over i, adaptive) at a tight tolerance, on i's part in front
// of j's plane: the independent value the contour integral is checked against.
double area_rule(std::vector<Vec3> i, const std::vector<Vec3>& j) {
  const Vec3 ni = normal_of(i), nj = normal_of(j);
  const double whole = geometry::area(i);
  const double kept = clip_to_front(i, j[0], nj, 0.0);
  if (kept <= 0.0) return 0.0;
  const PolygonRef a{i, ni}, b{j, nj};
  return kept * polygon_form_factor_adaptive(a, b, 1e-10, 1e-16, 30) * (whole > 0 ? 1.0 : 0.0);
}

// i and j each clipped to the front of the other's plane, as callers pass them.
ContourIntegral contour(std::vector<Vec3> i, std::vector<Vec3> j, double tolerance) {
  const double area_i = geometry::area(i);
  const Vec3 ni = normal_of(i), nj = normal_of(j);
  const std::vector<Vec3> i0 = i;
  clip_to_front(i, j[0], nj, 0.0);
  clip_to_front(j, i0[0], ni, 0.0);
  return contour_form_factor(i, ni, j, nj, area_i, tolerance, 2000000);
}

TEST(ContourIntegral, MatchesHowellsCatalogue) {
  for (const auto& c : catalogue()) {
    SCOPED_TRACE(c.name);
    const ContourIntegral r = contour(c.emitter, c.receiver, 1e-12);
    EXPECT_TRUE(r.converged);
    // The catalogue's 12 digits are its own rounding (5e-13); the rule states its error.
    EXPECT_NEAR(r.form_factor, c.value, r.error + 5e-13);
    EXPECT_LE(r.error, 1e-12 * r.form_factor);
  }
}

TEST(ContourIntegral, StatedErrorIsHonestAtLooseTolerances) {
  // At 1e-4 the rule stops early; the true error must still lie within what it states.
  for (const auto& c : catalogue()) {
    SCOPED_TRACE(c.name);
    const ContourIntegral r = contour(c.emitter, c.receiver, 1e-4);
    EXPECT_TRUE(r.converged);
    EXPECT_LE(std::abs(r.form_factor - c.value), r.error + 5e-13);
  }
}

// Random pairs that are near, touching or sharing part of an edge, in random orientations.
struct Pair {
  std::vector<Vec3> i, j;
};

std::vector<Pair> near_pairs(unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Pair> pairs;
  for (int k = 0; k < 24; ++k) {
    // i: a quad or triangle on z = 0 facing up; j: a polygon hinged on a line near i's edge,
    // tilted by an angle in (5, 175) degrees, offset by a gap from 0 (touching) to 1e-2.
    const double w = 0.2 + u(rng), h = 0.05 + u(rng);
    std::vector<Vec3> i = {{0, 0, 0}, {w, 0, 0}, {w, h, 0}};
    if (k % 2 == 0) i.push_back({0, h, 0});
    const double angle = (5.0 + 170.0 * u(rng)) * 3.14159265358979 / 180.0;
    const double gap = (k % 3 == 0) ? 0.0 : std::pow(10.0, -2.0 - 3.0 * u(rng));
    const double x0 = -0.3 * u(rng), x1 = w * (0.5 + u(rng)), d = 0.1 + u(rng);
    // j's edge on the line y = 0 (shared with i's edge where the gap is 0), rising over i.
    const Vec3 up{0, std::cos(angle), std::sin(angle)};
    const Vec3 base{0, -gap, gap * 0.5};
    std::vector<Vec3> j = {base + Vec3{x1, 0, 0}, base + Vec3{x0, 0, 0},
                           base + Vec3{x0, 0, 0} + d * up, base + Vec3{x1, 0, 0} + 0.7 * d * up};
    // Random rotation and translation of the whole pair.
    const Vec3 axis = glm::normalize(Vec3{u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5});
    const double turn = 6.28318530717959 * u(rng);
    const Vec3 shift{u(rng) * 10, u(rng) * 10, u(rng) * 10};
    const auto move = [&](Vec3 x) {
      const double c = std::cos(turn), s = std::sin(turn);
      return x * c + glm::cross(axis, x) * s + axis * glm::dot(axis, x) * (1 - c) + shift;
    };
    for (Vec3& x : i) x = move(x);
    for (Vec3& x : j) x = move(x);
    pairs.push_back({i, j});
  }
  return pairs;
}

TEST(ContourIntegral, AgreesWithTheAreaRuleOnNearAndTouchingPairs) {
  // At every tolerance the true error (against the area rule at 1e-10, allowed its own 1e-10 F)
  // lies within the error the contour integral states. Before its cells were graded towards the
  // break points a pair 1e-5 apart stated 5.9e-10 at 1e-9 and was 7.1e-10 off.
  int checked = 0;
  for (const Pair& p : near_pairs(7)) {
    const double reference = area_rule(p.i, p.j);
    if (reference <= 1e-6) continue;
    for (double tolerance : {1e-4, 1e-6, 1e-9}) {
      const ContourIntegral r = contour(p.i, p.j, tolerance);
      ASSERT_TRUE(r.converged) << "pair " << checked << " at " << tolerance;
      EXPECT_LE(r.error, tolerance * r.form_factor);
      EXPECT_NEAR(r.form_factor, reference, r.error + 1e-10 * reference)
          << "pair " << checked << " at " << tolerance;
    }
    ++checked;
  }
  EXPECT_GE(checked, 16);  // most pairs exchange light
}

TEST(ContourIntegral, IsReciprocal) {
  for (const Pair& p : near_pairs(11)) {
    const ContourIntegral ij = contour(p.i, p.j, 1e-10);
    const ContourIntegral ji = contour(p.j, p.i, 1e-10);
    const double ai = geometry::area(p.i), aj = geometry::area(p.j);
    EXPECT_NEAR(ai * ij.form_factor, aj * ji.form_factor,
                ai * (ij.error + ji.error * aj / ai) + 1e-15);
  }
}

TEST(ContourIntegral, CornersListedEitherWayGiveTheSameValue) {
  for (const auto& c : catalogue()) {
    SCOPED_TRACE(c.name);
    std::vector<Vec3> i = c.emitter, j = c.receiver;
    const Vec3 ni = normal_of(i), nj = normal_of(j);
    const double forward = contour_form_factor(i, ni, j, nj, 1.0, 1e-10, 100000).form_factor;
    std::reverse(i.begin(), i.end());
    std::reverse(j.begin(), j.end());
    const ContourIntegral backward = contour_form_factor(i, ni, j, nj, 1.0, 1e-10, 100000);
    EXPECT_TRUE(backward.converged);
    EXPECT_NEAR(backward.form_factor, forward, 1e-10 * forward);
  }
}

// hospital.mgf's tafeltje.mgf:917 left a triangle of 3.4e-10 m^2, 5.5e-8 m wide, facing down
// along the top edge of a vertical face, and that edge leaves the face's plane by 2.3e-7 m: the
// sliver is in front of the face only by that departure, the identity's premise does not hold,
// and it gave F = -0.50 (the area rule +0.50; the row lost the entry). Such a pair is left to
// the area rule: too thin to resolve, and a negative value is never reported as converged.
TEST(ContourIntegral, SliverAlongAnEdgeIsLeftToTheAreaRule) {
  std::vector<Vec3> sliver = {{5.4182744, 2.979528, 0.4001},
                              {5.4069968, 2.9825496, 0.4001},
                              {5.406297214, 2.9827371, 0.4001}};
  const std::vector<Vec3> face = {{5.4182744, 2.979528, 0.4001}, {5.4069968, 2.9825496, 0.4001},
                                  {5.4032, 2.9835672, 0.4001},   {5.4032, 2.9835672, 0.0241},
                                  {5.4192, 2.97928, 0.0241},     {5.4192, 2.97928, 0.4001}};
  const Vec3 down{0, 0, -1}, side = normal_of(face);
  const double epsilon = 1.89e-8;  // hospital.mgf's plane epsilon
  ASSERT_GT(clip_to_front(sliver, face[0], side, epsilon), 0.9);
  const ContourIntegral raw = contour_form_factor(sliver, down, face, side, 3.4e-10, 1e-4, 200000);
  EXPECT_LT(raw.form_factor, 0.0);  // what the identity gives here
  EXPECT_FALSE(raw.converged);
  EXPECT_FALSE(
      contour_form_factor_front(sliver, face[0], side, face, side, 3.4e-10, epsilon, 1e-4, 200000)
          .converged);
  // A strip 1e-5 wide along a wall's edge (plane epsilon 1e-9) is resolved and right: F -> 1/2.
  const std::vector<Vec3> wall = testing::square_x0();
  const std::vector<Vec3> strip = {{0, 0, 0}, {1e-5, 0, 0}, {1e-5, 1, 0}, {0, 1, 0}};
  const ContourIntegral r = contour_form_factor_front(strip, wall[0], Vec3{1, 0, 0}, wall,
                                                      Vec3{1, 0, 0}, 1e-5, 1e-9, 1e-6, 200000);
  ASSERT_TRUE(r.converged);
  const double reference =
      polygon_form_factor_adaptive({strip, Vec3{0, 0, 1}}, {wall, Vec3{1, 0, 0}}, 1e-7, 1e-16, 30);
  EXPECT_NEAR(r.form_factor, reference, r.error + 1e-7 * reference);
}

TEST(ContourIntegral, SaysWhenItRanOutOfWork) {
  const auto& c = catalogue()[4];  // perpendicular squares sharing an edge
  std::vector<Vec3> i = c.emitter, j = c.receiver;
  const ContourIntegral r = contour_form_factor(i, normal_of(i), j, normal_of(j), 1.0, 1e-12, 60);
  EXPECT_FALSE(r.converged);
  EXPECT_GT(r.error, 1e-12 * r.form_factor);
}

TEST(ContourIntegral, DegenerateInputGivesZeroNotConverged) {
  const std::vector<Vec3> line = {{0, 0, 0}, {1, 0, 0}};
  const ContourIntegral r = contour_form_factor(line, Vec3{0, 0, 1}, testing::square_x0(),
                                                Vec3{1, 0, 0}, 1.0, 1e-6, 1000);
  EXPECT_FALSE(r.converged);
  EXPECT_EQ(r.form_factor, 0.0);
}

}  // namespace
}  // namespace radlab
