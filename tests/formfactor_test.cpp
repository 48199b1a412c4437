// Form factors against closed forms (Howell's catalogue) and the identities every form-factor
// matrix must satisfy: reciprocity, closure of a closed scene, no negative or non-finite entry.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "formfactor/diagnostics.h"
#include "formfactor/matrix.h"
#include "formfactor/point_polygon.h"
#include "formfactor/polygon_integral.h"
#include "formfactor/raycast.h"
#include "scene/builtin_scenes.h"
#include "scene/validate.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

using testing::scene_of;
using testing::square_z;

// Howell's catalogue C-11: parallel unit squares facing each other at distance 1.
constexpr double kParallelUnitSquaresAt1 = 0.199824895698;
// C-14 with a common edge at 90 degrees: unit squares.
constexpr double kPerpendicularUnitSquares = 0.200043776075;

std::vector<Vec3> square_x0() {  // x = 0 plane, y,z in [0,1], facing +x
  return {{0, 0, 0}, {0, 1, 0}, {0, 1, 1}, {0, 0, 1}};
}

double raycast_pair(const Scene& scene, RaycastOptions options = {}) {
  Mesh mesh = build_mesh(scene, {});
  RaycastFormFactors ff(scene, mesh, options);
  RowCost cost;
  return ff.pair(0, 1, cost);
}

TEST(PointToPolygon, DifferentialElementUnderSquareCentre) {
  // Catalogue B-? : dA at height 1 below the centre of a unit square, parallel: 0.239456470.
  std::vector<Vec3> square = square_z(1.0, false);
  for (Vec3& v : square) v -= Vec3(0.5, 0.5, 0.0);
  std::vector<Vec3> scratch;
  double f = point_to_polygon_form_factor(Vec3(0.0), Vec3(0, 0, 1), square, Vec3(0, 0, -1), scratch);
  EXPECT_NEAR(f, 0.239456470, 1e-9);
}

TEST(PointToPolygon, BackFacingIsZero) {
  std::vector<Vec3> scratch;
  std::vector<Vec3> square = square_z(1.0, true);  // faces away from a point below it
  EXPECT_EQ(point_to_polygon_form_factor(Vec3(0.5, 0.5, 0), Vec3(0, 0, 1), square, Vec3(0, 0, 1),
                                         scratch),
            0.0);
}

TEST(PointToPolygon, HalfSpaceClippingGivesHalfOfHemisphere) {
  // A huge wall standing on the tangent plane through x, crossing below it: only the part above
  // the plane counts. A square of half-size L centred on x's position at distance d -> as L grows,
  // F tends to 1/2 (the wall fills half the hemisphere as seen with cosine weighting).
  const double L = 1e6;
  std::vector<Vec3> wall = {{1e-3, -L, -L}, {1e-3, -L, L}, {1e-3, L, L}, {1e-3, L, -L}};
  std::vector<Vec3> scratch;
  double f = point_to_polygon_form_factor(Vec3(0.0), Vec3(0, 0, 1), wall, Vec3(-1, 0, 0), scratch);
  EXPECT_NEAR(f, 0.5, 1e-6);
}

TEST(RaycastFormFactors, ParallelUnitSquaresDefaultSettings) {
  Scene scene = scene_of({square_z(0.0, true), square_z(1.0, false)});
  EXPECT_NEAR(raycast_pair(scene), kParallelUnitSquaresAt1, 1e-3 * kParallelUnitSquaresAt1);
}

TEST(RaycastFormFactors, PerpendicularUnitSquaresDefaultSettings) {
  Scene scene = scene_of({square_z(0.0, true), square_x0()});
  EXPECT_NEAR(raycast_pair(scene), kPerpendicularUnitSquares, 1e-3 * kPerpendicularUnitSquares);
}

TEST(RaycastFormFactors, TightToleranceReaches1e5) {
  RaycastOptions options;
  options.tolerance = 1e-7;
  Scene parallel = scene_of({square_z(0.0, true), square_z(1.0, false)});
  Scene perpendicular = scene_of({square_z(0.0, true), square_x0()});
  EXPECT_NEAR(raycast_pair(parallel, options), kParallelUnitSquaresAt1,
              1e-5 * kParallelUnitSquaresAt1);
  EXPECT_NEAR(raycast_pair(perpendicular, options), kPerpendicularUnitSquares,
              1e-5 * kPerpendicularUnitSquares);
}

TEST(PolygonIntegral, SharedEdgeSingularityConverges) {
  // The integrand's derivative is log-singular along the shared edge; adaptive subdivision must
  // still converge, the error shrinking as the tolerance does.
  std::vector<Vec3> a = square_z(0.0, true), b = square_x0();
  PolygonRef from{a, Vec3(0, 0, 1)}, to{b, Vec3(1, 0, 0)};
  double previous_error = 1.0;
  for (double tol : {1e-3, 1e-5, 1e-7}) {
    double f = polygon_form_factor_adaptive(from, to, tol, 1e-15, 14);
    double error = std::abs(f - kPerpendicularUnitSquares) / kPerpendicularUnitSquares;
    EXPECT_LT(error, 10 * tol) << "tolerance " << tol;
    EXPECT_LE(error, previous_error * 1.01);
    previous_error = error;
  }
}

TEST(RaycastFormFactors, ClosedCubeRowsSumToOneAndAreReciprocal) {
  Scene scene = make_builtin_scene("cube");
  validate_scene(scene);
  for (int k : {1, 3}) {
    Mesh mesh = build_mesh(scene, {k, 0.0});
    RaycastFormFactors ff(scene, mesh, {});
    EXPECT_FALSE(ff.casts_rays());
    BuildReport report;
    FormFactorMatrix m = build_matrix(ff, mesh.size(), Precision::kDouble, report);
    MatrixDiagnostics d = diagnose(m, mesh.area);
    EXPECT_EQ(report.cost.rays, 0u);
    EXPECT_EQ(d.negative_entries, 0u);
    EXPECT_EQ(d.non_finite_entries, 0u);
    // Per-pair relative quadrature tolerance 1e-4 bounds the row-sum error by the same.
    EXPECT_NEAR(d.row_sum_min, 1.0, 1e-4) << "subdivision " << k;
    EXPECT_NEAR(d.row_sum_max, 1.0, 1e-4) << "subdivision " << k;
    EXPECT_LT(d.reciprocity_defect_relative, 2e-4);
  }
}

TEST(RaycastFormFactors, CubeClosureIdentity) {
  // 4 F_adj + F_opp = 1 on a unit cube, one element per face.
  Scene scene = make_builtin_scene("cube");
  validate_scene(scene);
  Mesh mesh = build_mesh(scene, {});
  RaycastFormFactors ff(scene, mesh, {});
  std::vector<double> row(mesh.size());
  RowCost cost;
  ff.row(0, row, cost);  // the floor
  EXPECT_EQ(row[0], 0.0);
  EXPECT_NEAR(row[1], kParallelUnitSquaresAt1, 1e-4);
  for (size_t j = 2; j < 6; ++j) EXPECT_NEAR(row[j], kPerpendicularUnitSquares, 1e-4);
  EXPECT_EQ(cost.pairs_culled, 0u);
}

TEST(RaycastFormFactors, CornellBoxCastsRaysAndStaysHealthy) {
  Scene scene = make_builtin_scene("cornell");
  validate_scene(scene);
  Mesh mesh = build_mesh(scene, {2, 0.0});
  RaycastOptions options;
  options.rays = 4;
  RaycastFormFactors ff(scene, mesh, options);
  EXPECT_TRUE(ff.casts_rays());
  BuildReport report;
  FormFactorMatrix m = build_matrix(ff, mesh.size(), Precision::kFloat, report);
  MatrixDiagnostics d = diagnose(m, mesh.area);
  EXPECT_GT(report.cost.rays, 0u);
  EXPECT_GT(report.cost.pairs_culled, 0u);
  EXPECT_EQ(d.negative_entries, 0u);
  EXPECT_EQ(d.non_finite_entries, 0u);
  // Open box: light escapes through the front, so every row sums to less than 1.
  EXPECT_LT(d.row_sum_max, 1.0);
  EXPECT_GT(d.row_sum_min, 0.0);
}

}  // namespace
}  // namespace radlab
