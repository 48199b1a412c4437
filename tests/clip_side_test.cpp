// Which side clip mode integrates (exact.cpp, ExactFormFactors::pair_integral with may_turn;
// docs/formfactors.md, "Which side to integrate"). A floor element under the edge of a box
// [0.25,0.75]^3 and an equal ceiling element beside the box's top: seen from a floor point, the
// shadow of the box's bottom edge (0.25 above the floor) is magnified 3x on the ceiling and sweeps
// across the ceiling element's edge as the point moves, a kink line through the middle of the
// floor element; seen from a ceiling point, the shadow moves 1/3 as fast and stays inside the
// floor element. The nearest occluder is nearer the floor element, so the pair is integrated
// over the ceiling element. Asserted: both one-way integrations converge to the same value (two
// independent integrations, reciprocity), the turned one meets a coarse tolerance where the
// floor's does not, with fewer evaluations.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "radlab/formfactor/exact.h"
#include "radlab/scene/mesh.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

std::vector<Vec3> rect(double x0, double x1, double y0, double y1, double z, bool up) {
  if (up) return {{x0, y0, z}, {x1, y0, z}, {x1, y1, z}, {x0, y1, z}};
  return {{x0, y0, z}, {x0, y1, z}, {x1, y1, z}, {x1, y0, z}};
}

// The six outward faces of the box [lo, hi]^3.
std::vector<std::vector<Vec3>> box(double lo, double hi) {
  return {rect(lo, hi, lo, hi, lo, false),  // bottom, facing down
          rect(lo, hi, lo, hi, hi, true),   // top
          {{lo, lo, lo}, {hi, lo, lo}, {hi, lo, hi}, {lo, lo, hi}},
          {{hi, lo, lo}, {hi, hi, lo}, {hi, hi, hi}, {hi, lo, hi}},
          {{hi, hi, lo}, {lo, hi, lo}, {lo, hi, hi}, {hi, hi, hi}},
          {{lo, hi, lo}, {lo, lo, lo}, {lo, lo, hi}, {lo, hi, hi}}};
}

ExactFormFactors clip_at(const Scene& scene, const Mesh& mesh, double tolerance) {
  ExactOptions options;
  options.visibility_clip = true;
  options.tolerance = tolerance;
  options.max_evaluations = 2000000;
  return ExactFormFactors(scene, mesh, options);
}

TEST(ClipSide, TheSideFartherFromTheOccludersConvergesFaster) {
  std::vector<std::vector<Vec3>> polygons = {rect(0.625, 0.75, 0.625, 0.75, 0.0, true),
                                             rect(0.75, 0.875, 0.75, 0.875, 1.0, false)};
  for (const auto& face : box(0.25, 0.75)) polygons.push_back(face);
  const Scene scene = testing::scene_of(polygons);
  const Mesh mesh = build_mesh(scene, {1, 0.0});
  ASSERT_EQ(mesh.size(), 8u);
  ASSERT_TRUE(ExactFormFactors::integrates_from(mesh, 0, 1));  // equal areas: the floor

  // Two independent integrations, over the floor and over the ceiling, tight: they agree to
  // their stated tolerances (equal areas: F_01 = F_10).
  RowCost cost;
  const ExactFormFactors tight = clip_at(scene, mesh, 1e-7);
  const double over_floor = tight.pair_integral(0, 1, cost, false);
  const double over_ceiling = tight.pair_integral(1, 0, cost, false);
  ASSERT_GT(over_floor, 1e-4);
  EXPECT_NEAR(over_floor, over_ceiling, 2e-7 * over_floor);
  EXPECT_EQ(tight.largest_row_excess(), 0.0);  // neither stopped at the cap

  // At a coarse tolerance: pair() turns to the ceiling (the same bits as its one-way
  // integral), and is within the tolerance; the floor's integral is not (measured 5.7e-3 off
  // at 2e-2 before the turn: within its tolerance, but 60x further off than the turned one).
  const double tolerance = 2e-2;
  const ExactFormFactors coarse = clip_at(scene, mesh, tolerance);
  RowCost turned_cost, floor_cost, ceiling_cost;
  const double turned = coarse.pair(0, 1, turned_cost);
  const double floor_only = coarse.pair_integral(0, 1, floor_cost, false);
  const double ceiling_only = coarse.pair_integral(1, 0, ceiling_cost, false);
  EXPECT_EQ(turned, ceiling_only);
  EXPECT_EQ(coarse.pair(1, 0, cost), turned);  // reciprocity, equal areas
  EXPECT_LE(std::abs(turned - over_ceiling), tolerance * over_ceiling);
  EXPECT_LE(std::abs(floor_only - over_ceiling), tolerance * over_ceiling);
  EXPECT_LT(10 * std::abs(turned - over_ceiling), std::abs(floor_only - over_ceiling));
  EXPECT_LE(turned_cost.kernel_evaluations, floor_cost.kernel_evaluations);
  std::printf(
      "F %.10g: over the floor %.3e off (%llu evaluations), turned %.3e off (%llu)\n", over_ceiling,
      floor_only / over_ceiling - 1, static_cast<unsigned long long>(floor_cost.kernel_evaluations),
      turned / over_ceiling - 1, static_cast<unsigned long long>(turned_cost.kernel_evaluations));
}

// Between elements of very different size the pair keeps the smaller side (the larger one's
// narrow penumbra band is then the feature to resolve): the turn is limited to areas within 2x.
TEST(ClipSide, ALargerFarElementIsNotTurnedTo) {
  std::vector<std::vector<Vec3>> polygons = {rect(0.625, 0.75, 0.625, 0.75, 0.0, true),
                                             rect(0.75, 1.0, 0.75, 1.0, 1.0, false)};
  for (const auto& face : box(0.25, 0.75)) polygons.push_back(face);
  const Scene scene = testing::scene_of(polygons);
  const Mesh mesh = build_mesh(scene, {1, 0.0});
  ASSERT_TRUE(ExactFormFactors::integrates_from(mesh, 0, 1));  // the floor is 4x smaller
  const ExactFormFactors method = clip_at(scene, mesh, 2e-2);
  RowCost a, b;
  EXPECT_EQ(method.pair(0, 1, a), method.pair_integral(0, 1, b, false));
  EXPECT_EQ(a.kernel_evaluations, b.kernel_evaluations);
}

}  // namespace
}  // namespace radlab
