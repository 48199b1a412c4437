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
#include <cstdio>
#include <vector>

#include "formfactor/methods/exact.h"
#include "formfactor/visibility/visible_polygon.h"
#include "scene/geometry.h"
#include "scene/mesh.h"
#include "scene/scene_loader.h"
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

// The floor element [0.625, 0.75]^2 (under the box's edge), a ceiling square [0.75, far]^2 at
// height 1 and the box [0.25, 0.75]^3: elements 0 and 1 at one element a polygon.
Scene under_box_edge(double far) {
  std::vector<std::vector<Vec3>> polygons = {rect(0.625, 0.75, 0.625, 0.75, 0.0, true),
                                             rect(0.75, far, 0.75, far, 1.0, false)};
  for (const auto& face : box(0.25, 0.75)) polygons.push_back(face);
  return testing::scene_of(polygons);
}

ExactFormFactors clip_at(const Scene& scene, const Mesh& mesh, double tolerance) {
  ExactOptions options;
  options.visibility_clip = true;
  options.tolerance = tolerance;
  options.max_evaluations = 2000000;
  return ExactFormFactors(scene, mesh, options);
}

TEST(ClipSide, TheSideFartherFromTheOccludersConvergesFaster) {
  const Scene scene = under_box_edge(0.875);
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
  const Scene scene = under_box_edge(1.0);
  const Mesh mesh = build_mesh(scene, {1, 0.0});
  ASSERT_TRUE(ExactFormFactors::integrates_from(mesh, 0, 1));  // the floor is 4x smaller
  const ExactFormFactors method = clip_at(scene, mesh, 2e-2);
  RowCost a, b;
  EXPECT_EQ(method.pair(0, 1, a), method.pair_integral(0, 1, b, false));
  EXPECT_EQ(a.kernel_evaluations, b.kernel_evaluations);
}

// A zero the corner test does not prove is checked from the other side. On the Cornell box at
// 4 x 4, element 100 sees a sliver of element 119 past the blocks from 1.8% of its area (a
// 400 x 400 grid over 100 finds 2,889 points that see it): all of the rule's 189 points over
// 100 saw nothing, so its integral was 0, stated as converged. The pair is not turned (its
// nearest occluder is not nearer 100), so 119 is probed with 36 points, some see 100, and its
// integral is taken.
TEST(ClipSide, AnUnprovenZeroIsCheckedFromTheOtherSide) {
  const LoadedScene loaded = load_scene("builtin:cornell", false);
  const Mesh mesh = build_mesh(loaded.scene, {4, 0.0});
  const size_t a = 100, b = 119;
  ASSERT_GT(mesh.size(), b);
  ASSERT_TRUE(ExactFormFactors::integrates_from(mesh, a, b));
  const ExactFormFactors method = clip_at(loaded.scene, mesh, 1e-3);
  RowCost cost;
  const double f = method.pair(a, b, cost);
  const double over_a = method.pair_integral(a, b, cost, false);

  // Brute force over a: the mean of the integrand on a 400 x 400 grid of a's parameter square
  // (a is a parallelogram, so the grid's points carry equal weight), every polygon but a's and
  // b's own an occluder.
  std::vector<Vec3> ca, cb;
  mesh.corners(a, ca);
  mesh.corners(b, cb);
  ASSERT_EQ(ca.size(), 4u);
  std::vector<Occluder> occluders;
  for (size_t p = 0; p < loaded.scene.polygons.size(); ++p) {
    if (p == mesh.polygon[a] || p == mesh.polygon[b]) continue;
    const auto& v = loaded.scene.polygons[p].vertices;
    occluders.push_back({v, geometry::unit_normal(v)});
  }
  VisibleScratch scratch;
  const int n = 400;
  double sum = 0.0;
  size_t seeing = 0;
  for (int u = 0; u < n; ++u)
    for (int v = 0; v < n; ++v) {
      const double s = (u + 0.5) / n, t = (v + 0.5) / n;
      const Vec3 x =
          (1 - s) * (1 - t) * ca[0] + s * (1 - t) * ca[1] + s * t * ca[2] + (1 - s) * t * ca[3];
      const double g =
          visible_form_factor(x, mesh.normal[a], cb, mesh.normal[b], occluders, 1e-9, scratch);
      sum += g;
      seeing += g > 0.0 ? 1 : 0;
    }
  const double brute = sum / (n * n);
  std::printf(
      "F_%zu,%zu: brute force %.6e (%zu of %d points see %zu), pair() %.6e, the rule "
      "over %zu alone %.6e\n",
      a, b, brute, seeing, n * n, b, f, a, over_a);
  ASSERT_GT(brute, 1e-6);
  // The grid's own error here is well under 1% (at 200 x 200 it gave 0.4% less).
  EXPECT_NEAR(f, brute, 0.02 * brute);
}

}  // namespace
}  // namespace radlab
