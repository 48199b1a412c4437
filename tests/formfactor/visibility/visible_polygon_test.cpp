// Occluded form factors by shadow clipping (formfactor/visibility/visible_polygon.h, `exact` with
// visibility=clip): closed forms where the visible part is a rectangle, full occlusion, the
// unoccluded case, convergence as the tolerance falls, and reciprocity of two independent
// integrations (over i with shadows on j, over j with shadows on i).
#include "formfactor/visibility/visible_polygon.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <glm/geometric.hpp>
#include <numbers>
#include <random>
#include <vector>

#include "core/param_bag.h"
#include "formfactor/integrate/point_polygon.h"
#include "formfactor/matrix/symmetric_build.h"
#include "formfactor/methods/exact.h"
#include "scene/mesh.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

using testing::scene_of;

// Axis-aligned rectangle [x0,x1] x [y0,y1] at height z, front facing up (+z) or down.
std::vector<Vec3> rect(double x0, double x1, double y0, double y1, double z, bool up) {
  if (up) return {{x0, y0, z}, {x1, y0, z}, {x1, y1, z}, {x0, y1, z}};
  return {{x0, y0, z}, {x0, y1, z}, {x1, y1, z}, {x1, y0, z}};
}

// Howell's catalogue B-3: from a differential area to a parallel rectangle a x b at distance c
// whose corner lies above it.
double corner_rectangle(double a, double b, double c) {
  const double X = a / c, Y = b / c;
  return (X / std::sqrt(1 + X * X) * std::atan(Y / std::sqrt(1 + X * X)) +
          Y / std::sqrt(1 + Y * Y) * std::atan(X / std::sqrt(1 + Y * Y))) /
         (2 * std::numbers::pi);
}

// Howell's catalogue C-11: directly opposed parallel rectangles a x b at distance c.
double opposed_rectangles(double a, double b, double c) {
  const double X = a / c, Y = b / c, pi = std::numbers::pi;
  const double s = std::sqrt((1 + X * X) * (1 + Y * Y) / (1 + X * X + Y * Y));
  return 2 / (pi * X * Y) *
         (std::log(s) + X * std::sqrt(1 + Y * Y) * std::atan(X / std::sqrt(1 + Y * Y)) +
          Y * std::sqrt(1 + X * X) * std::atan(Y / std::sqrt(1 + X * X)) - X * std::atan(X) -
          Y * std::atan(Y));
}

ExactFormFactors clip_method(const Scene& scene, const Mesh& mesh, double tolerance) {
  ExactOptions options;
  options.visibility_clip = true;
  options.tolerance = tolerance;
  return ExactFormFactors(scene, mesh, options);
}

// A point under the centre of a square, a smaller square half-way up: the shadow is the square
// doubled, the visible part a square ring, F = F(whole) - F(shadow) by Howell B-3.
TEST(VisibleFormFactor, CentredPlateLeavesASquareRing) {
  const std::vector<Vec3> to = rect(-1, 1, -1, 1, 2.0, false);
  const std::vector<Vec3> plate = rect(-0.25, 0.25, -0.25, 0.25, 1.0, true);
  const Occluder occluders[] = {{plate, Vec3(0, 0, 1)}};
  VisibleScratch scratch;
  bool blocked = false;
  const double f = visible_form_factor(Vec3(0.0), Vec3(0, 0, 1), to, Vec3(0, 0, -1), occluders,
                                       1e-12, scratch, &blocked);
  const double expected = 4 * (corner_rectangle(1, 1, 2) - corner_rectangle(0.5, 0.5, 2));
  EXPECT_TRUE(blocked);
  // The same formula on exact pieces: only rounding separates them.
  EXPECT_NEAR(f, expected, 1e-13);
  // Without occluders: Lambert's formula on the whole square, bit for bit.
  std::vector<Vec3> lambert;
  EXPECT_EQ(visible_form_factor(Vec3(0.0), Vec3(0, 0, 1), to, Vec3(0, 0, -1), {}, 1e-12, scratch),
            point_to_polygon_form_factor(Vec3(0.0), Vec3(0, 0, 1), to, Vec3(0, 0, -1), lambert));
}

// Occluders that miss the cone, or stand in x's plane, cast nothing; one covering everything
// leaves 0; two overlapping ones are not subtracted twice.
TEST(VisibleFormFactor, MissesFullCoverAndOverlaps) {
  const std::vector<Vec3> to = rect(-1, 1, -1, 1, 2.0, false);
  const Vec3 x(0.0), n(0, 0, 1), down(0, 0, -1);
  VisibleScratch scratch;
  std::vector<Vec3> lambert;
  const double whole = point_to_polygon_form_factor(x, n, to, down, lambert);
  const std::vector<Vec3> aside = rect(3, 4, 3, 4, 1.0, true);
  const std::vector<Vec3> standing = {{-5, 0, 0}, {5, 0, 0}, {5, 0, 1.5}, {-5, 0, 1.5}};
  const Occluder miss[] = {{aside, Vec3(0, 0, 1)}, {standing, Vec3(0, -1, 0)}};
  bool blocked = true;
  EXPECT_EQ(visible_form_factor(x, n, to, down, miss, 1e-12, scratch, &blocked), whole);
  EXPECT_FALSE(blocked);
  const std::vector<Vec3> big = rect(-2, 2, -2, 2, 1.0, true);
  const Occluder cover[] = {{big, Vec3(0, 0, 1)}};
  EXPECT_EQ(visible_form_factor(x, n, to, down, cover, 1e-12, scratch), 0.0);
  // Two plates whose shadows are [-0.5,0.5]^2 and [0,1] x [-0.5,0.5]: the union is
  // [-0.5,1] x [-0.5,0.5], four corner rectangles' worth by B-3.
  const std::vector<Vec3> a = rect(-0.25, 0.25, -0.25, 0.25, 1.0, true);
  const std::vector<Vec3> b = rect(0.0, 0.5, -0.25, 0.25, 1.0, false);
  const Occluder two[] = {{a, Vec3(0, 0, 1)}, {b, Vec3(0, 0, -1)}};
  const double shadow = 2 * (corner_rectangle(0.5, 0.5, 2) + corner_rectangle(1.0, 0.5, 2));
  EXPECT_NEAR(visible_form_factor(x, n, to, down, two, 1e-12, scratch), whole - shadow, 1e-13);
}

// A shadow that overhangs P_j: a plate well below x (projected whole, the 2D subtraction cutting
// its shadow to P_j) and one near x's height (cut by the cone from x first) cast the same shadow,
// [0,3] x [-3,3], hiding the half x > 0 of P_j: the rest is two corner rectangles by B-3. And a
// plate reaching x's height beside the cone's top (cut once, at 0.9 of x's height).
TEST(VisibleFormFactor, WholeAndConeClippedShadowsAgree) {
  const std::vector<Vec3> to = rect(-1, 1, -1, 1, 2.0, false);
  const Vec3 x(0.0), n(0, 0, 1), down(0, 0, -1);
  const double expected = 2 * corner_rectangle(1, 1, 2);
  VisibleScratch scratch;
  // Shadow scale 2 / z for a plate at height z: z = 1 lies at half x's height above P_j, z = 0.1
  // at 0.95 of it.
  const std::vector<Vec3> low = rect(0, 1.5, -1.5, 1.5, 1.0, true);
  const std::vector<Vec3> high = rect(0, 0.15, -0.15, 0.15, 0.1, true);
  const Occluder whole[] = {{low, Vec3(0, 0, 1)}};
  const Occluder coned[] = {{high, Vec3(0, 0, 1)}};
  bool blocked_whole = false, blocked_coned = false;
  const double f_whole = visible_form_factor(x, n, to, down, whole, 1e-12, scratch, &blocked_whole);
  const double f_coned = visible_form_factor(x, n, to, down, coned, 1e-12, scratch, &blocked_coned);
  EXPECT_TRUE(blocked_whole);
  EXPECT_TRUE(blocked_coned);
  EXPECT_NEAR(f_whole, expected, 1e-13);
  EXPECT_NEAR(f_coned, expected, 1e-13);
  EXPECT_NEAR(f_whole, f_coned, 1e-15);
  // A tilted plate reaching 0.95 of x's height, but there at x >= 0.57 while the cone's
  // cross-section at that height is |x|, |y| <= 0.1: cut at 0.9 of x's height and projected whole.
  // The same plate cut at z = 0.25 (wholly well below x) casts the same shadow: the part between
  // lies outside the cone (|x| <= z / 2 there, the plate at x >= 0.55).
  const Vec3 tilt = glm::normalize(Vec3(0.9, 0, 0.3));
  const std::vector<Vec3> reaching = {
      {0.6, -0.4, 0.1}, {0.6, 0.4, 0.1}, {0.3, 0.4, 1.0}, {0.3, -0.4, 1.0}};
  const std::vector<Vec3> cut = {
      {0.55, -0.4, 0.25}, {0.55, 0.4, 0.25}, {0.3, 0.4, 1.0}, {0.3, -0.4, 1.0}};
  const Occluder reaching_one[] = {{reaching, tilt}};
  const Occluder cut_one[] = {{cut, tilt}};
  bool blocked_reaching = false, blocked_cut = false;
  const double f_reaching =
      visible_form_factor(x, n, to, down, reaching_one, 1e-12, scratch, &blocked_reaching);
  const double f_cut = visible_form_factor(x, n, to, down, cut_one, 1e-12, scratch, &blocked_cut);
  EXPECT_TRUE(blocked_reaching);
  EXPECT_TRUE(blocked_cut);
  EXPECT_LT(f_cut, 0.9 * point_to_polygon_form_factor(x, n, to, down, scratch.lambert));
  EXPECT_NEAR(f_reaching, f_cut, 1e-15);
}

// A whole shadow whose box overlaps P_j's but which misses P_j (a rotated quad beyond its corner
// (1,1), some of its edges cutting P_j's box): nothing cast, Lambert's value on P_j to the bit.
TEST(VisibleFormFactor, WholeShadowBesidePJCastsNothing) {
  const std::vector<Vec3> to = rect(-1, 1, -1, 1, 2.0, false);
  const Vec3 x(0.0), n(0, 0, 1), down(0, 0, -1);
  // Shadow (0.9,1.5), (1.5,0.9), (1.6,1.0), (1.0,1.6): x + y > 2 everywhere, P_j's x + y <= 2.
  const std::vector<Vec3> plate = {{0.45, 0.75, 1}, {0.75, 0.45, 1}, {0.8, 0.5, 1}, {0.5, 0.8, 1}};
  const Occluder occluders[] = {{plate, Vec3(0, 0, 1)}};
  VisibleScratch scratch;
  std::vector<Vec3> lambert;
  bool blocked = true, hidden = true;
  EXPECT_EQ(visible_form_factor(x, n, to, down, occluders, 1e-12, scratch, &blocked, &hidden),
            point_to_polygon_form_factor(x, n, to, down, lambert));
  EXPECT_FALSE(blocked);
  EXPECT_FALSE(hidden);
}

// Random convex P_j (3 to 7 corners, and 40: Lambert's scalar path) in tilted planes, random
// points, random quads between them (well below the points or reaching their height): the
// VisibleTarget overload gives the span overload's bits and flags, and without occluders both
// give point_to_polygon_form_factor's bits (visible_polygon.cpp evaluates Lambert's formula
// itself, two edges at a time; points whose tangent plane cuts P_j included).
TEST(VisibleFormFactor, PreparedTargetAndLambertGiveTheSameBits) {
  std::mt19937_64 random(12345);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  auto uniform = [&](double lo, double hi) { return lo + (hi - lo) * unit(random); };
  auto basis = [](const Vec3& normal, Vec3& u, Vec3& v) {
    u = glm::normalize(
        glm::cross(normal, std::abs(normal.x) < 0.9 ? Vec3(1, 0, 0) : Vec3(0, 1, 0)));
    v = glm::cross(normal, u);
  };
  VisibleScratch scratch, other;
  VisibleTarget target;
  std::vector<Vec3> lambert;
  int blocked_count = 0, hidden_count = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    const size_t m = trial % 50 == 0 ? 40 : 3 + size_t(trial) % 5;
    const Vec3 to_normal = glm::normalize(Vec3(uniform(-0.4, 0.4), uniform(-0.4, 0.4), -1.0));
    Vec3 u, v;
    basis(to_normal, u, v);  // u x v = to_normal: counter-clockwise about it
    const Vec3 centre(uniform(-0.5, 0.5), uniform(-0.5, 0.5), 2.0);
    const double radius = uniform(0.3, 1.0), turn = uniform(0.0, 6.0);
    std::vector<Vec3> to;
    for (size_t k = 0; k < m; ++k) {
      const double angle = turn + 2 * std::numbers::pi * double(k) / double(m);
      to.push_back(centre + radius * (std::cos(angle) * u + std::sin(angle) * v));
    }
    const Vec3 x(uniform(-1.5, 1.5), uniform(-1.5, 1.5), uniform(0.0, 0.5));
    const Vec3 n = glm::normalize(Vec3(uniform(-0.5, 0.5), uniform(-0.5, 0.5), 1.0));
    std::vector<std::vector<Vec3>> quads(1 + size_t(trial) % 3);
    std::vector<Occluder> occluders;
    for (std::vector<Vec3>& quad : quads) {
      const Vec3 normal = glm::normalize(Vec3(uniform(-1, 1), uniform(-1, 1), uniform(-1, 1)));
      Vec3 a, b;
      basis(normal, a, b);
      const Vec3 c(uniform(-1, 1), uniform(-1, 1), uniform(0.2, 1.9));
      const double h = uniform(0.05, 0.6);
      quad = {c - h * a - h * b, c + h * a - h * b, c + h * a + h * b, c - h * a + h * b};
      occluders.push_back({quad, normal});
    }
    target.set(to, to_normal);
    bool blocked = false, hidden = false, prepared_blocked = true, prepared_hidden = true;
    const double f =
        visible_form_factor(x, n, to, to_normal, occluders, 1e-9, scratch, &blocked, &hidden);
    const double g = visible_form_factor(x, n, target, occluders, 1e-9, other, &prepared_blocked,
                                         &prepared_hidden);
    ASSERT_EQ(std::bit_cast<uint64_t>(f), std::bit_cast<uint64_t>(g)) << "trial " << trial;
    ASSERT_EQ(blocked, prepared_blocked) << "trial " << trial;
    ASSERT_EQ(hidden, prepared_hidden) << "trial " << trial;
    blocked_count += blocked;
    hidden_count += hidden;
    const double plain = point_to_polygon_form_factor(x, n, to, to_normal, lambert);
    ASSERT_EQ(std::bit_cast<uint64_t>(plain),
              std::bit_cast<uint64_t>(visible_form_factor(x, n, to, to_normal, {}, 1e-9, scratch)))
        << "trial " << trial;
    ASSERT_EQ(std::bit_cast<uint64_t>(plain),
              std::bit_cast<uint64_t>(visible_form_factor(x, n, target, {}, 1e-9, scratch)))
        << "trial " << trial;
  }
  // The draws exercise shadows and full cover, not only misses.
  EXPECT_GT(blocked_count, 300);
  EXPECT_GT(hidden_count, 10);
}

// Two parallel squares 1 apart; a strip 1e-7 below the upper square hides its half y > 0.5
// from every point of the lower rectangle [0,1] x [0,0.5]: the visible part is the rectangle
// directly opposed to it, Howell C-11. The strip's shadow edge moves by at most 0.5e-7 from
// y = 0.5 over the lower rectangle, changing F by < 1e-7; the tolerance 1e-9 adds 1e-10.
TEST(ExactClip, StripHidingHalfTheSquareGivesOpposedRectangles) {
  const Scene scene = scene_of({rect(0, 1, 0, 0.5, 0.0, true), rect(0, 1, 0, 1, 1.0, false),
                                rect(-1, 2, 0.5, 1.5, 1.0 - 1e-7, false)});
  const Mesh mesh = build_mesh(scene, {1, 0.0});
  const ExactFormFactors method = clip_method(scene, mesh, 1e-9);
  RowCost cost;
  const double expected = opposed_rectangles(1.0, 0.5, 1.0);
  EXPECT_NEAR(method.pair(0, 1, cost), expected, 1e-6 * expected);
  EXPECT_EQ(cost.pairs_traced, 1u);
  EXPECT_EQ(cost.rays, 0u);
  // Reciprocity, integrated over the upper square with the strip's shadow on the lower one.
  const double back = method.pair(1, 0, cost);
  EXPECT_NEAR(back * 1.0, expected * 0.5, 1e-6 * expected);
}

// A plate larger than both squares between them: F = 0 exactly, and cheaply.
TEST(ExactClip, FullyOccludedPairIsZeroAndCheap) {
  const Scene scene = scene_of(
      {rect(0, 1, 0, 1, 0.0, true), rect(0, 1, 0, 1, 1.0, false), rect(-1, 2, -1, 2, 0.5, true)});
  const Mesh mesh = build_mesh(scene, {1, 0.0});
  const ExactFormFactors method = clip_method(scene, mesh, 1e-10);
  RowCost cost;
  EXPECT_EQ(method.pair(0, 1, cost), 0.0);
  EXPECT_EQ(method.pair(1, 0, cost), 0.0);
  // The plate hides j from every corner of i (the umbra test): no quadrature at all.
  EXPECT_LE(cost.kernel_evaluations, 2u * 4);
}

// Unoccluded pairs equal the unoccluded method to the tolerance, and only the pairs the plate
// really blocks are reduced. Floor and ceiling 4 x 4, a
// small plate half-way: the segments of a pair cross z = 0.5 in the average of the two
// elements' rectangles, so the plate blocks exactly the pairs whose average overlaps it.
TEST(ExactClip, UnoccludedPairsEqualTheUnoccludedMethod) {
  const std::vector<Vec3> floor = rect(0, 1, 0, 1, 0.0, true), ceiling = rect(0, 1, 0, 1, 1, false);
  const Scene open = scene_of({floor, ceiling});
  const Mesh open_mesh = build_mesh(open, {4, 0.0});
  ExactOptions plain;
  plain.tolerance = 1e-10;
  const ExactFormFactors reference(open, open_mesh, plain);
  const double p0 = 0.3, p1 = 0.45;
  const Scene with_plate = scene_of({floor, ceiling, rect(p0, p1, p0, p1, 0.5, true)});
  const Mesh mesh = build_mesh(with_plate, {4, 0.0});
  const ExactFormFactors clipped = clip_method(with_plate, mesh, 1e-6);
  size_t blocked = 0;
  for (size_t i = 0; i < 16; ++i)
    for (size_t j = 16; j < 32; ++j) {
      RowCost a, b;
      const double expected = reference.pair(i, j, a);
      const double f = clipped.pair(i, j, b);
      // The pair's cross-section at z = 0.5: the average of the two elements' boxes.
      const Vec3 lo = 0.5 * (mesh.centroid[i] + mesh.centroid[j]) - Vec3(0.125, 0.125, 0);
      const Vec3 hi = lo + Vec3(0.25, 0.25, 0);
      const bool meets = lo.x < p1 && hi.x > p0 && lo.y < p1 && hi.y > p0;
      if (meets) {
        EXPECT_LT(f, expected * (1 - 1e-6)) << i << " " << j;
        ++blocked;
      } else {
        // Both within their tolerance of the exact value (1e-6 and 1e-10 relative).
        EXPECT_NEAR(f, expected, 2e-6 * expected) << i << " " << j;
      }
    }
  EXPECT_GT(blocked, 0u);
}

// A plate half-way between two unit squares, off centre so the pair is partly occluded: the
// error against a tight result falls with the tolerance and stays within the stated budget
// (tolerance x F), and the two independent integrations satisfy reciprocity to it.
TEST(ExactClip, ConvergesAsToleranceFallsAndIsReciprocal) {
  const Scene scene = scene_of({rect(0, 1, 0, 1, 0.0, true), rect(0, 1, 0, 1, 1.0, false),
                                rect(0.3, 0.9, 0.2, 0.7, 0.45, true)});
  const Mesh mesh = build_mesh(scene, {1, 0.0});
  RowCost cost;
  const double unoccluded = opposed_rectangles(1, 1, 1);
  const double tight = clip_method(scene, mesh, 1e-8).pair(0, 1, cost);
  ASSERT_GT(tight, 0.2 * unoccluded);
  ASSERT_LT(tight, 0.9 * unoccluded);
  double previous = 1.0;
  for (double tolerance : {1e-2, 1e-4, 1e-6}) {
    const ExactFormFactors method = clip_method(scene, mesh, tolerance);
    const double f = method.pair(0, 1, cost);
    const double error = std::abs(f - tight);
    EXPECT_LE(error, tolerance * tight) << tolerance;
    EXPECT_LE(error, previous) << tolerance;
    previous = std::max(error, 1e-15);
    // Equal areas: F_01 = F_10. Two independent integrations, over 0 and over 1 (pair() takes
    // one of them for both entries), each within its stated error of the exact value: the
    // tolerance, plus what it records beyond it when the work cap stops it (at 1e-6 both do:
    // they need ~140,000 evaluations, the default cap is 20,000).
    const double over_0 = method.pair_integral(0, 1, cost, false);
    const double over_1 = method.pair_integral(1, 0, cost, false);
    EXPECT_TRUE(f == over_0 || f == over_1) << tolerance;
    EXPECT_NEAR(over_0, over_1, 2 * tolerance * tight + method.row_excess(0)) << tolerance;
  }
}

// The symmetric builder: one integration per unordered pair, the other entry by reciprocity.
// Against two one-way integrations (build_matrix), every entry within the tolerance of the
// pair (each side is within 1e-6 relative of the exact value, so they differ by < 2e-6);
// reciprocity to rounding (one multiplication and one division: a few ulps).
TEST(SymmetricBuild, EqualsTwoOneWayIntegrationsAndIsReciprocal) {
  const Scene scene = scene_of({rect(0, 1, 0, 1, 0.0, true), rect(0, 1, 0, 1, 1.0, false),
                                rect(0.3, 0.9, 0.2, 0.7, 0.45, true), rect(0, 1, 0, 1, 0.3, false)},
                               0.5, 1.0);
  // Floor, ceiling, a plate and a lower square, each 2 x 2 (the plate's elements are smaller).
  Mesh mesh = build_mesh(scene, {2, 0.0});
  const ExactFormFactors method = clip_method(scene, mesh, 1e-6);
  BuildReport one_way, symmetric;
  const FormFactorMatrix full = build_matrix(method, mesh.size(), Precision::kDouble, one_way);
  const FormFactorMatrix half =
      build_matrix_symmetric(method, mesh, Precision::kDouble, Layout::kDense, symmetric);
  size_t nonzero = 0;
  for (size_t i = 0; i < mesh.size(); ++i)
    for (size_t j = 0; j < mesh.size(); ++j) {
      const double f = full.at(i, j), g = half.at(i, j);
      EXPECT_NEAR(g, f, 2e-6 * std::max(f, g) + 1e-15) << i << " " << j;
      EXPECT_NEAR(mesh.area[i] * g, mesh.area[j] * half.at(j, i), 1e-15 * mesh.area[i] * g + 1e-300)
          << i << " " << j;
      nonzero += f > 0.0 ? 1 : 0;
    }
  EXPECT_GT(nonzero, 20u);
  // Half the integrals: each unordered pair once.
  EXPECT_LT(double(symmetric.cost.kernel_evaluations),
            0.6 * double(one_way.cost.kernel_evaluations));
  std::printf("evaluations: one-way %llu, symmetric %llu\n",
              static_cast<unsigned long long>(one_way.cost.kernel_evaluations),
              static_cast<unsigned long long>(symmetric.cost.kernel_evaluations));
}

}  // namespace
}  // namespace radlab
