// Form factors against closed forms (Howell's catalogue) and the identities every form-factor
// matrix must satisfy: reciprocity, closure of a closed scene, no negative or non-finite entry.
// The hemicube, shaft culling, the matrix cache and the point-to-polygon kernel have files of
// their own (hemicube_test, shaft_culling_test, matrix_cache_test, point_polygon_test).
//
// Tolerances are derived in the comments next to them, never tuned to the measured error.
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
#include "experiments/problem/problem.h"
#include "formfactor/integrate/point_polygon.h"
#include "formfactor/integrate/polygon_integral.h"
#include "formfactor/integrate/quadrature.h"
#include "formfactor/matrix/diagnostics.h"
#include "formfactor/matrix/matrix.h"
#include "formfactor/matrix/matrix_cache.h"
#include "formfactor/methods/exact.h"
#include "formfactor/methods/hemicube.h"
#include "formfactor/methods/raycast.h"
#include "formfactor/registry.h"
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

TEST(PointToPolygon, DifferentialElementUnderSquareCentre) {
  // Catalogue B-? : dA at height 1 below the centre of a unit square, parallel: 0.239456470.
  std::vector<Vec3> square = square_z(1.0, false);
  for (Vec3& v : square) v -= Vec3(0.5, 0.5, 0.0);
  std::vector<Vec3> scratch;
  double f =
      point_to_polygon_form_factor(Vec3(0.0), Vec3(0, 0, 1), square, Vec3(0, 0, -1), scratch);
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

TEST(PolygonIntegral, ClipToFrontLeavesNoRepeatedCorner) {
  // The unit square cut by the plane x + y = 1 through two of its corners: those corners lie
  // exactly on the plane and the next corner behind it. Cutting there used to add each on-plane
  // corner twice (an intersection at t = 0), and the zero-area fan triangles of the 5-corner
  // result gave 0/0 quadrature weights: NaN form factors in corridor.mgf and office2.mgf.
  std::vector<Vec3> square = square_z(0.0, true);
  const Vec3 normal = glm::normalize(Vec3(-1, -1, 0));
  EXPECT_EQ(clip_to_front(square, Vec3(1, 0, 0), normal, 1e-12), 0.5);
  ASSERT_EQ(square.size(), 3u);
  for (size_t a = 0; a < 3; ++a)
    for (size_t b = a + 1; b < 3; ++b) EXPECT_GT(glm::distance(square[a], square[b]), 0.5);
  // Only a corner within epsilon in front, the rest behind: nothing kept.
  std::vector<Vec3> touching = square_z(0.0, true);
  const Vec3 away = glm::normalize(Vec3(1, 1, 0));
  EXPECT_EQ(clip_to_front(touching, Vec3(1, 1, 0) - 1e-13 * away, away, 1e-12), 0.0);

  // Rules on degenerate cells stay finite, their weights summing to 1.
  for (const std::vector<Vec3>& cell : std::vector<std::vector<Vec3>>{
           {{0, 0, 0}, {1, 0, 0}, {1, 0, 0}},                           // zero-area triangle
           {{0, 0, 0}, {1, 0, 0}, {1, 0, 0}, {0, 0, 0}},                // zero-area quad
           {{0, 0, 0}, {1, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}}}) {  // repeated corner
    std::vector<QuadraturePoint> points;
    element_quadrature(cell, 3, points);
    double total = 0.0;
    for (const QuadraturePoint& q : points) {
      ASSERT_TRUE(std::isfinite(q.weight)) << cell.size() << " corners";
      total += q.weight;
    }
    EXPECT_NEAR(total, 1.0, 1e-14) << cell.size() << " corners";
  }
}

// The strips a thin element starts from (raycast.cpp): a pentagon cut across an axis into 7
// strips of equal width. Their triangles cover it (areas summing to its own) and each lies
// within its strip; one strip gives the fan.
TEST(PolygonIntegral, StripTrianglesCoverThePolygonStripByStrip) {
  const std::vector<Vec3> pentagon = {{0, 0, 0}, {4, 0, 0}, {5, 1, 0}, {3, 2, 0}, {0.5, 1.5, 0}};
  const Vec3 axis = glm::normalize(Vec3(1, 0.2, 0));
  double low = 1e300, high = -1e300;
  for (const Vec3& c : pentagon) {
    low = std::min(low, glm::dot(c, axis));
    high = std::max(high, glm::dot(c, axis));
  }
  const int count = 7;
  const double step = (high - low) / count;
  std::vector<Vec3> triangles;
  append_strip_triangles(pentagon, axis, count, triangles);
  ASSERT_EQ(triangles.size() % 3, 0u);
  double area = 0.0;
  std::vector<int> per_strip(count, 0);
  for (size_t t = 0; t < triangles.size(); t += 3) {
    const std::span<const Vec3> triangle(triangles.data() + t, 3);
    const double a = geometry::area(triangle);
    area += a;
    if (!(a > 1e-12)) continue;
    const Vec3 centre = (triangle[0] + triangle[1] + triangle[2]) / 3.0;
    const int strip = int(std::floor((glm::dot(centre, axis) - low) / step));
    ASSERT_GE(strip, 0);
    ASSERT_LT(strip, count);
    ++per_strip[size_t(strip)];
    for (const Vec3& c : triangle) {
      EXPECT_GE(glm::dot(c, axis), low + strip * step - 1e-12);
      EXPECT_LE(glm::dot(c, axis), low + (strip + 1) * step + 1e-12);
    }
  }
  EXPECT_NEAR(area, geometry::area(pentagon), 1e-12);
  for (int s = 0; s < count; ++s) EXPECT_GT(per_strip[size_t(s)], 0) << "strip " << s;
  triangles.clear();
  append_strip_triangles(pentagon, axis, 1, triangles);
  EXPECT_EQ(triangles.size(), 9u);  // the fan of the pentagon, unchanged
}

TEST(PolygonIntegral, ClippedPentagonMeetsTheTolerance) {
  // A panel standing on the floor square, its plane cutting one corner off: the part of the
  // floor in front of it is a pentagon, whose integrand is log-singular along the panel's foot.
  // The adaptive rule used to compare a pentagon's rule with the rules on its fan of triangles,
  // which are the same points, and so accepted its first estimate (0.7% off here, 28% for a
  // Cornell block face on a floor element). The reference is the reverse direction (the panel,
  // a quad, to the floor) to 1e-10 and reciprocity: no clipped polygon on that side.
  std::vector<Vec3> floor = square_z(0.0, true);
  std::vector<Vec3> panel = {{0.7, 0.1, 0.2}, {0.9, 0.3, 0.2}, {0.9, 0.3, 0.0}, {0.7, 0.1, 0.0}};
  Scene scene = scene_of({floor, panel});
  Mesh mesh = build_mesh(scene, {});
  std::vector<Vec3> kept_part = floor;
  clip_to_front(kept_part, mesh.centroid[1], mesh.normal[1], plane_epsilon(mesh));
  ASSERT_EQ(kept_part.size(), 5u);
  std::vector<Vec3> panel_corners, floor_corners;
  mesh.corners(1, panel_corners);
  mesh.corners(0, floor_corners);
  const double reference =
      polygon_form_factor_adaptive({panel_corners, mesh.normal[1]}, {floor_corners, mesh.normal[0]},
                                   1e-10, 1e-16, 16) *
      mesh.area[1] / mesh.area[0];
  RowCost cost;
  RaycastFormFactors raycast(scene, mesh, {});
  // Per-pair relative tolerance 1e-4, plus 1e-10 for the reference.
  EXPECT_NEAR(raycast.pair(0, 1, cost), reference, 1.0001e-4 * reference);
  ExactFormFactors exact(scene, mesh, {});
  EXPECT_NEAR(exact.pair(0, 1, cost), reference, 1e-8 * reference);
  EXPECT_EQ(cost.rays, 0u);
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
  // Open box: light escapes through the front, so no row sums to more than 1 — but the tall
  // block's back face sees none of the front and sums to exactly 1, so quadrature error (1e-4
  // relative per entry, hence on the sum) and the sampling error of V (4 rays here) may lift it:
  // the method's stated row-sum error covers both (docs/formfactors.md; 1.0015 measured with
  // kernel-weighted rays, which are unbiased but noisier at 4 rays than equal weights).
  EXPECT_LE(d.row_sum_max, 1.0 + stated_row_sum_error(ff));
  EXPECT_GT(d.row_sum_min, 0.0);
}

TEST(RaycastFormFactors, PanelOnTheFloorsDiagonalIsFinite) {
  // End to end, the clipping case above: a wall standing on the floor square's diagonal, through
  // two of its corners. The floor's entry used to be NaN after 25 M kernel evaluations (a NaN
  // never meets the adaptive rule's test, so every cell was refined to max_depth).
  std::vector<Vec3> panel = {{1, 0, 1}, {0, 1, 1}, {0, 1, 0}, {1, 0, 0}};  // faces the origin
  Scene scene = scene_of({square_z(0.0, true), panel});
  Mesh mesh = build_mesh(scene, {});
  RaycastFormFactors ff(scene, mesh, {});
  RowCost cost;
  const double f = ff.pair(0, 1, cost), back = ff.pair(1, 0, cost);
  ASSERT_TRUE(std::isfinite(f));
  EXPECT_GT(f, 0.0);
  // V = 1 (two polygons): reciprocity is the quadrature's, 1e-4 relative each way.
  EXPECT_NEAR(mesh.area[0] * f, mesh.area[1] * back, 2e-4 * mesh.area[0] * f);
  EXPECT_LT(cost.kernel_evaluations, 100000u);
}

TEST(RaycastFormFactors, SliverTouchingAPlaneCostsLittle) {
  // Two elements of office2.mgf (a desk leg's face and a drawer's top) sharing one corner: the
  // triangle lies behind the quad's plane except within 4e-8 m of that corner, so a sliver of
  // 3e-16 m^2 is kept. Newell's area of its cells lost all precision (coordinates ~3.7 m), the
  // adaptive rule never converged and spent 48 M evaluations (14 s) on an entry of 3e-11. The
  // absolute floor now applies to F_ij, not to the sliver's mean, and cells keep their area.
  Scene scene = scene_of(
      {{{3.718328, 0.560307, 0.53}, {3.631596, 0.512061, 0.53}, {3.685421, 0.513754, 0.82}},
       {{3.704215, 0.506914, 0.82},
        {3.817012, 0.582918, 0.83},
        {3.798219, 0.589759, 0.83},
        {3.685421, 0.513754, 0.82}}});
  Mesh mesh = build_mesh(scene, {});
  RaycastFormFactors ff(scene, mesh, {});
  RowCost cost;
  const double f = ff.pair(0, 1, cost);
  ASSERT_TRUE(std::isfinite(f));
  EXPECT_GE(f, 0.0);
  EXPECT_LT(f, 1e-12);  // at most the kept fraction (3e-14) times F_dx <= 1
  EXPECT_LT(cost.kernel_evaluations, 10000u);
}

TEST(RaycastFormFactors, VisibilitySamplesOnlyThePartsTheIntegralCovers) {
  // A shelf (top face at z = 0.5, bottom face at z = 0.45) sticks out of a wall element. The
  // integral for wall -> top covers only the wall above the top's plane, and nothing stands
  // between that part and the top, so V = 1 exactly; likewise wall -> bottom. Rays used to start
  // anywhere on the wall, and those from below the shelf hit it: V = 0.56 (9 of 16 rays), the
  // pair penalised twice (clipped away, then blocked). Reference: the same pair without the
  // other face (no possible occluder, so no rays), computed by the same quadrature.
  std::vector<Vec3> wall = {{0, 0, 0}, {0, 1, 0}, {0, 1, 1}, {0, 0, 1}};  // faces +x
  std::vector<Vec3> top = {{0, 0, 0.5}, {0.5, 0, 0.5}, {0.5, 1, 0.5}, {0, 1, 0.5}};
  std::vector<Vec3> bottom = {{0, 1, 0.45}, {0.5, 1, 0.45}, {0.5, 0, 0.45}, {0, 0, 0.45}};
  Scene shelf = scene_of({wall, top, bottom});
  Mesh mesh = build_mesh(shelf, {});
  RaycastFormFactors ff(shelf, mesh, {});
  RowCost cost;
  for (size_t face : {1, 2}) {
    Scene alone = scene_of({wall, face == 1 ? top : bottom});
    Mesh alone_mesh = build_mesh(alone, {});
    RowCost no_rays;
    const double unoccluded = RaycastFormFactors(alone, alone_mesh, {}).pair(0, 1, no_rays);
    EXPECT_EQ(no_rays.rays, 0u);
    EXPECT_NEAR(ff.pair(0, face, cost), unoccluded, 1e-12 * unoccluded) << "face " << face;
    EXPECT_NEAR(mesh.area[face] * ff.pair(face, 0, cost), unoccluded, 2e-4 * unoccluded);
  }
  EXPECT_GT(cost.rays, 0u);  // the shelf's faces can block each other's pairs: rays were cast
}

TEST(RaycastFormFactors, CornellSubdiv6IsReciprocalToTheQuadratureTolerance) {
  // The main experiments' mesh at default settings. V_ij = V_ji exactly, so A_i F_ij - A_j F_ji
  // is quadrature error alone: at most `tolerance` relative each way, 2e-4 together. It was
  // 0.277 (floor element 17 and short-block element 468: the clipped pentagon above), and 0.0084
  // from the fixed rules (their Bernstein bound without its constant chose order 2 where 3 is
  // needed; polygon_integral.h).
  //   Row sums are not tested against 1 here: the visibility estimate, not the quadrature,
  // decides whether they pass. V is the plain share of unblocked rays, so (i) 16 rays miss small
  // occluded parts (a block standing on part of an element), lifting the row of the tall block's
  // back face, whose true sum is 1, to 1.0034 with the first sampler's random numbers (the
  // largest row is 1.0019 with the current ones); (ii) it is biased where visibility correlates
  // with the kernel (floor element 31 beside the back wall: 1.0016 with 16 rays, 1.0021 with 1024,
  // 0.9997 by Monte Carlo), an error that more rays do not remove.
  Scene scene = make_builtin_scene("cornell");
  validate_scene(scene);
  Mesh mesh = build_mesh(scene, {6, 0.0});
  RaycastFormFactors ff(scene, mesh, {});
  BuildReport report;
  FormFactorMatrix m = build_matrix(ff, mesh.size(), Precision::kDouble, report);
  MatrixDiagnostics d = diagnose(m, mesh.area);
  EXPECT_EQ(d.non_finite_entries, 0u);
  EXPECT_EQ(d.negative_entries, 0u);
  EXPECT_LE(d.reciprocity_defect_relative, 2.0 * RaycastOptions{}.tolerance);
}

// ---------------------------------------------------------------------------------------------
// The catalogue (Howell, "A catalog of radiation heat transfer configuration factors"): unit
// squares. Each value is quoted to 12 significant digits, so 5e-13 absolute is its own rounding.

TEST(RaycastFormFactors, CatalogueWithinTheQuadratureTolerance) {
  // The two squares of every case bound a convex region (no rays, V = 1 exactly), so the only
  // error is the quadrature's, which the method controls per pair to `tolerance` relative.
  for (const CatalogueCase& c : catalogue()) {
    Scene scene = scene_of({c.emitter, c.receiver});
    Mesh mesh = build_mesh(scene, {});
    RaycastFormFactors ff(scene, mesh, {});
    RowCost cost;
    EXPECT_NEAR(ff.pair(0, 1, cost), c.value, RaycastOptions{}.tolerance * c.value) << c.name;
    EXPECT_EQ(cost.rays, 0u);
  }
}

TEST(ExactFormFactors, CatalogueWithin1e8) {
  // Adaptive quadrature to 1e-10 relative per cell; required: 1e-8 relative.
  for (const CatalogueCase& c : catalogue()) {
    Scene scene = scene_of({c.emitter, c.receiver});
    Mesh mesh = build_mesh(scene, {});
    ExactFormFactors ff(scene, mesh, {});
    RowCost cost;
    EXPECT_NEAR(ff.pair(0, 1, cost), c.value, 1e-8 * c.value) << c.name;
    EXPECT_EQ(cost.rays, 0u);
    EXPECT_EQ(cost.pairs_unoccluded, 1u);
  }
}

TEST(ExactFormFactors, CubeClosureAndRowSums) {
  // 4 F_adj + F_opp = 1 on the unit cube (one element a face), and every row of the cube meshed
  // 2 x 2 sums to 1: each of a row's 20 non-zero entries is within 1e-10 relative, so the sum is
  // within ~1e-10; 1e-9 leaves room for rounding.
  Scene scene = make_builtin_scene("cube");
  validate_scene(scene);
  Mesh mesh = build_mesh(scene, {});
  ExactFormFactors ff(scene, mesh, {});
  std::vector<double> row(mesh.size());
  RowCost cost;
  ff.row(0, row, cost);
  EXPECT_NEAR(row[1], kParallelUnitSquaresAt1, 1e-8 * kParallelUnitSquaresAt1);
  for (size_t j = 2; j < 6; ++j)
    EXPECT_NEAR(row[j], kPerpendicularUnitSquares, 1e-8 * kPerpendicularUnitSquares);
  EXPECT_NEAR(4 * row[2] + row[1], 1.0, 1e-9);

  Mesh fine = build_mesh(scene, {2, 0.0});
  ExactFormFactors exact(scene, fine, {});
  BuildReport report;
  FormFactorMatrix m = build_matrix(exact, fine.size(), Precision::kDouble, report);
  MatrixDiagnostics d = diagnose(m, fine.area);
  EXPECT_NEAR(d.row_sum_min, 1.0, 1e-9);
  EXPECT_NEAR(d.row_sum_max, 1.0, 1e-9);
  // Both A_i F_ij and A_j F_ji are within 1e-10 relative of the same number.
  EXPECT_LT(d.reciprocity_defect_relative, 1e-9);
  EXPECT_EQ(report.cost.rays, 0u);
}

TEST(ExactFormFactors, RefusesAScenThatCanOccludeUnlessAskedForRays) {
  Scene scene = make_builtin_scene("cornell");
  validate_scene(scene);
  Mesh mesh = build_mesh(scene, {});
  try {
    ExactFormFactors ff(scene, mesh, {});
    FAIL() << "the Cornell box can occlude";
  } catch (const InputError& e) {
    EXPECT_EQ(e.code(), ExitCode::kInvalidInput);
    const std::string message = e.what();
    EXPECT_NE(message.find("visibility=rays"), std::string::npos) << message;
    EXPECT_NE(message.find("cornell/"), std::string::npos) << message;  // names the polygons
  }
  ExactOptions options;
  options.visibility_rays = true;
  options.rays = 4;
  // This checks the rays path, not accuracy: 1e-10 costs ~2 s here (14 M kernel evaluations;
  // 953 M and ~100 s before the adaptive rule took a global error budget), 1e-6 0.1 s.
  options.tolerance = 1e-6;
  ExactFormFactors ff(scene, mesh, options);
  BuildReport report;
  FormFactorMatrix m = build_matrix(ff, mesh.size(), Precision::kDouble, report);
  MatrixDiagnostics d = diagnose(m, mesh.area);
  EXPECT_GT(report.cost.pairs_traced, 0u);
  EXPECT_GT(report.cost.pairs_unoccluded, 0u);
  EXPECT_EQ(d.negative_entries, 0u);
  // Open box: no row above 1, up to the stated error: quadrature tolerance and, with 4 rays, the
  // sampling error of V (the tall block's back face sees none of the open front: its row sums to
  // exactly 1, and both errors may fall either side).
  EXPECT_LE(d.row_sum_max, 1.0 + stated_row_sum_error(ff));

  // The factory applies the same rule, and rejects rays/seed without visibility=rays.
  ParamBag bag("exact");
  EXPECT_THROW(make_form_factor_method("exact", bag, scene, mesh), InputError);
  ParamBag bad = ParamBag::from_list("rays=8", "exact");
  EXPECT_THROW(make_form_factor_method("exact", bad, scene, mesh), UsageError);
}

TEST(ExactFormFactors, AcceptsANonConvexSceneWhoseShaftsAreEmpty) {
  // Two facing squares and a third far to the side, facing away from them: not a convex
  // enclosure (the squares lie behind the third's plane), yet nothing can occlude anything.
  std::vector<Vec3> away = {{5, 0, 0}, {5, 1, 0}, {5, 1, 1}, {5, 0, 1}};  // faces +x
  Scene scene = scene_of({square_z(0.0, true), square_z(1.0, false), away});
  Mesh mesh = build_mesh(scene, {2, 0.0});
  ExactFormFactors ff(scene, mesh, {});
  BuildReport report;
  FormFactorMatrix m = build_matrix(ff, mesh.size(), Precision::kDouble, report);
  EXPECT_EQ(report.cost.rays, 0u);
  double f = 0.0;
  for (size_t i = 0; i < 4; ++i)
    for (size_t j = 4; j < 8; ++j) f += m.at(i, j) / 4.0;
  EXPECT_NEAR(f, kParallelUnitSquaresAt1, 1e-8 * kParallelUnitSquaresAt1);
}

}  // namespace
}  // namespace radlab
