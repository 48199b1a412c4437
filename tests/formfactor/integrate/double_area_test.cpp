// `exact`'s fixed Gauss rules on separated unoccluded pairs (exact.cpp, ExactFormFactors::
// unoccluded; the double-area rule of double_area.h, then Lambert's formula on a single-area
// rule): the order the Bernstein bound asks for, accepted only when one order lower agrees
// within the tolerance. Every pair of a closed box must stay within its tolerance of an
// independent value (the adaptive rule alone at 1e-13), at a fraction of the adaptive rule's
// evaluations (issue 13 target 2: the per-pair cost of the 6,144-element box).
#include "formfactor/integrate/double_area.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "formfactor/integrate/polygon_integral.h"
#include "formfactor/methods/exact.h"
#include "formfactor/methods/raycast.h"
#include "formfactor/visibility/visibility.h"
#include "scene/mesh.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

// The unit box seen from inside: six faces, normals inward.
Scene unit_box() {
  const Vec3 c[8] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                     {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
  auto q = [&](int a, int b, int d, int e) { return std::vector<Vec3>{c[a], c[b], c[d], c[e]}; };
  return testing::scene_of(
      {q(0, 1, 2, 3), q(4, 7, 6, 5), q(0, 4, 5, 1), q(3, 2, 6, 7), q(0, 3, 7, 4), q(1, 5, 6, 2)},
      0.5, 1.0);
}

// Howell's catalogue C-11: directly opposed parallel unit squares 4 apart. The double-area
// product rule converges geometrically (the kernel is analytic over both squares): order 4 to
// 1e-7 relative (the Bernstein bound with a = 1 + 2 gap/diameter ~ 6.7 gives ~1e-9), each order
// better than the one before.
TEST(DoubleArea, OpposedSquaresConvergeToHowell) {
  const double c = 4.0, X = 1.0 / c, pi = std::numbers::pi;
  const double s = std::sqrt((1 + X * X) * (1 + X * X) / (1 + X * X + X * X));
  const double exact =
      2 / (pi * X * X) *
      (std::log(s) + 2 * X * std::sqrt(1 + X * X) * std::atan(X / std::sqrt(1 + X * X)) -
       2 * X * std::atan(X));
  const Scene scene = testing::scene_of(
      {{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}}, {{0, 0, c}, {0, 1, c}, {1, 1, c}, {1, 0, c}}},
      0.5, 1.0);
  const Mesh mesh = build_mesh(scene, {1, 0.0});
  const ElementRules rules(mesh);
  double previous = 1.0;
  for (int order = 1; order <= ElementRules::kMaxOrder; ++order) {
    const double f = double_area_form_factor(rules.rule(0, order), mesh.normal[0],
                                             rules.rule(1, order), mesh.normal[1], mesh.area[1]);
    const double error = std::abs(f - exact) / exact;
    EXPECT_LT(error, previous) << order;
    previous = error;
  }
  EXPECT_LT(previous, 1e-7);
}

TEST(ExactFixedRule, EveryPairOfABoxWithinItsToleranceAtFewEvaluations) {
  const Scene scene = unit_box();
  const Mesh mesh = build_mesh(scene, {3, 0.0});  // 54 elements
  const size_t n = mesh.size();
  // The reference: the adaptive rule alone at 1e-12 (no part of i lies behind j's plane in a
  // box, so the whole of i is integrated).
  std::vector<Vec3> from, to;
  std::vector<double> reference(n * n, 0.0);
  for (size_t i = 0; i < n; ++i)
    for (size_t j = 0; j < n; ++j) {
      if (i == j || !pair_faces(mesh, i, j, plane_epsilon(mesh))) continue;
      mesh.corners(i, from);
      mesh.corners(j, to);
      reference[i * n + j] = polygon_form_factor_adaptive({from, mesh.normal[i]},
                                                          {to, mesh.normal[j]}, 1e-12, 1e-18, 24);
    }
  for (double tolerance : {1e-2, 1e-4, 1e-6}) {
    ExactOptions options;
    options.tolerance = tolerance;
    const ExactFormFactors method(scene, mesh, options);
    RowCost cost;
    long long adaptive = 0;
    double worst = 0.0;
    for (size_t i = 0; i < n; ++i)
      for (size_t j = 0; j < n; ++j) {
        const double f = method.pair_integral(i, j, cost), ref = reference[i * n + j];
        ASSERT_EQ(f == 0.0, ref == 0.0) << i << " " << j;
        if (ref == 0.0) continue;
        worst = std::max(worst, std::abs(f - ref) / ref);
        EXPECT_NEAR(f, ref, tolerance * ref) << i << " " << j << " at " << tolerance;
        // What the adaptive rule alone spends at this tolerance (the method before).
        mesh.corners(i, from);
        mesh.corners(j, to);
        polygon_form_factor_adaptive({from, mesh.normal[i]}, {to, mesh.normal[j]}, tolerance, 1e-16,
                                     16, &adaptive);
      }
    std::printf("tolerance %g: worst relative error %.2e, evaluations %llu (adaptive alone %lld)\n",
                tolerance, worst, static_cast<unsigned long long>(cost.kernel_evaluations),
                adaptive);
    // Most pairs of a 3 x 3 box are separated: well under the adaptive rule's evaluations.
    EXPECT_LT(double(cost.kernel_evaluations), 0.7 * double(adaptive)) << tolerance;
  }
}

}  // namespace
}  // namespace radlab
