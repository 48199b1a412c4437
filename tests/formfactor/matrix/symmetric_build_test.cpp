// The symmetric dense build (formfactor/symmetric_build.h) and its use by the command line's
// matrix build (experiments/problem.cpp): one integration per unordered pair of `exact`, the same
// bits as the row-by-row build in either layout and for any thread count, every entry within the
// method's tolerance of the one-way integral over its own row's element.
#include "formfactor/matrix/symmetric_build.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <glm/geometric.hpp>
#include <vector>

#include "experiments/problem/problem.h"
#include "formfactor/matrix/matrix.h"
#include "formfactor/matrix/parallel_row.h"
#include "formfactor/methods/exact.h"
#include "scene/mesh.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

// Axis-aligned rectangle [x0,x1] x [y0,y1] at height z, front facing up (+z) or down.
std::vector<Vec3> rect(double x0, double x1, double y0, double y1, double z, bool up) {
  if (up) return {{x0, y0, z}, {x1, y0, z}, {x1, y1, z}, {x0, y1, z}};
  return {{x0, y0, z}, {x0, y1, z}, {x1, y1, z}, {x1, y0, z}};
}

// Floor and ceiling, a plate between them that shadows part of each from the other (both faces),
// and a smaller raised square: elements of three sizes, so both orientations of pair() occur.
struct Occluded {
  Scene scene = testing::scene_of(
      {rect(0, 1, 0, 1, 0.0, true), rect(0, 1, 0, 1, 1.0, false),
       rect(0.3, 0.9, 0.2, 0.7, 0.45, true), rect(0.3, 0.9, 0.2, 0.7, 0.45, false),
       rect(0.1, 0.4, 0.6, 0.9, 0.2, true)},
      0.5, 1.0);
  Mesh mesh = build_mesh(scene, {2, 0.0});
};

ExactFormFactors clip_method(const Occluded& s, double tolerance) {
  ExactOptions options;
  options.visibility_clip = true;
  options.tolerance = tolerance;
  return ExactFormFactors(s.scene, s.mesh, options);
}

// Bit for bit: the row-by-row build (which calls pair(), oriented the same way), on-the-fly rows
// split over threads, and the symmetric build in both layouts on 1 and 2 threads.
TEST(SymmetricBuild, SameBitsAsRowByRowInEveryLayoutAndThreadCount) {
  const Occluded s;
  const ExactFormFactors method = clip_method(s, 1e-4);
  const size_t n = s.mesh.size();
  BuildReport rows_report;
  const FormFactorMatrix rows = build_matrix(method, n, Precision::kDouble, rows_report);
  for (int threads : {1, 2}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));
    for (Layout layout : {Layout::kDense, Layout::kSparse}) {
      BuildReport report;
      const FormFactorMatrix m =
          build_matrix_symmetric(method, s.mesh, Precision::kDouble, layout, report);
      EXPECT_TRUE(identical_entries(m, rows)) << threads << " threads";
      EXPECT_EQ(m.layout(), layout);
      // The pair classes count both entries, as the row-by-row build counts them.
      EXPECT_EQ(report.cost.pairs_culled, rows_report.cost.pairs_culled);
      EXPECT_EQ(report.cost.pairs_traced, rows_report.cost.pairs_traced);
      EXPECT_EQ(report.cost.pairs_unoccluded, rows_report.cost.pairs_unoccluded);
      // Half the integrals (each pair once instead of twice).
      EXPECT_EQ(2 * report.cost.kernel_evaluations, rows_report.cost.kernel_evaluations);
    }
  }
  std::vector<double> row(n);
  for (size_t i = 0; i < n; ++i) {
    RowCost cost;
    row_in_parallel(method, i, row, cost);
    for (size_t j = 0; j < n; ++j) ASSERT_EQ(row[j], rows.at(i, j)) << i << " " << j;
  }
}

// Against the one-way integral over each entry's own row element (the build before this
// change): both are within `tolerance` relative of the exact F_ij, so they differ by at most
// twice it (plus the 1e-16 absolute floor of the adaptive rule). Reciprocity to a few ulps (one
// division and one multiplication). The plate hides part of the pairs, so the clipped path is
// exercised on both orientations.
TEST(SymmetricBuild, WithinTheToleranceOfOneWayIntegrationAndReciprocal) {
  const Occluded s;
  const double tolerance = 1e-4;
  const ExactFormFactors method = clip_method(s, tolerance);
  BuildReport report;
  const FormFactorMatrix m =
      build_matrix_symmetric(method, s.mesh, Precision::kDouble, Layout::kSparse, report);
  EXPECT_GT(report.cost.pairs_traced, 0u);
  size_t turned = 0;
  for (size_t i = 0; i < s.mesh.size(); ++i)
    for (size_t j = 0; j < s.mesh.size(); ++j) {
      RowCost cost;
      const double one_way = method.pair_integral(i, j, cost), f = m.at(i, j);
      EXPECT_NEAR(f, one_way, 2 * tolerance * std::max(f, one_way) + 1e-15) << i << " " << j;
      const double gi = s.mesh.area[i] * f, gj = s.mesh.area[j] * m.at(j, i);
      EXPECT_NEAR(gi, gj, 4e-16 * gi) << i << " " << j;
      if (f > 0 && !ExactFormFactors::integrates_from(s.mesh, i, j)) ++turned;
    }
  EXPECT_GT(turned, 20u);
}

// The command line's dense build (prepare_problem: formfactors, reference, solve cached) takes
// the symmetric path for `exact`: the same matrix as row by row, at half the kernel evaluations.
TEST(SymmetricBuild, TheCommandLinesDenseBuildIntegratesEachPairOnce) {
  ProblemSpec spec;
  spec.scene = "builtin:cornell";
  spec.mesh.subdivisions = 1;
  spec.ff_method = "exact";
  spec.ff_set = {"visibility=clip", "tolerance=1e-3", "symmetrise=false", "precision=double"};
  spec.need_reference = false;
  spec.use_cache = false;
  const auto problem = prepare_problem(spec);
  const auto* exact = dynamic_cast<const ExactFormFactors*>(problem->method.get());
  ASSERT_NE(exact, nullptr);
  BuildReport rows_report;
  const FormFactorMatrix rows =
      build_matrix(*exact, problem->mesh.size(), Precision::kDouble, rows_report);
  EXPECT_TRUE(identical_entries(convert_precision(problem->matrix, Precision::kDouble), rows));
  EXPECT_GT(problem->build.cost.pairs_traced, 0u);
  EXPECT_EQ(2 * problem->build.cost.kernel_evaluations, rows_report.cost.kernel_evaluations);
}

// A polygon turned to face `inside` (its vertex order reversed when its normal points away).
std::vector<Vec3> facing(std::vector<Vec3> polygon, const Vec3& inside) {
  const Vec3 normal = glm::cross(polygon[1] - polygon[0], polygon[2] - polygon[0]);
  if (glm::dot(normal, inside - polygon[0]) < 0.0) std::reverse(polygon.begin(), polygon.end());
  return polygon;
}

// The closed box [0,x] x [0,y] x [0,z], faces inward: elements of three sizes at one element
// size, so pairs of both orientations (and near pairs along the edges) occur.
Scene box(double x, double y, double z) {
  const Vec3 centre(x / 2, y / 2, z / 2);
  auto at = [&](double a, double b, double c) { return Vec3(a, b, c); };
  return testing::scene_of({facing({at(0, 0, 0), at(x, 0, 0), at(x, y, 0), at(0, y, 0)}, centre),
                            facing({at(0, 0, z), at(x, 0, z), at(x, y, z), at(0, y, z)}, centre),
                            facing({at(0, 0, 0), at(0, y, 0), at(0, y, z), at(0, 0, z)}, centre),
                            facing({at(x, 0, 0), at(x, y, 0), at(x, y, z), at(x, 0, z)}, centre),
                            facing({at(0, 0, 0), at(x, 0, 0), at(x, 0, z), at(0, 0, z)}, centre),
                            facing({at(0, y, 0), at(x, y, 0), at(x, y, z), at(0, y, z)}, centre)});
}

// A closed triangular prism, faces inward: triangular elements on its ends.
Scene prism() {
  const Vec3 a(0, 0, 0), b(1, 0, 0), c(0.3, 0.8, 0), up(0, 0, 0.5);
  const Vec3 centre = (a + b + c) / 3.0 + up / 2.0;
  return testing::scene_of({facing({a, b, c}, centre), facing({a + up, b + up, c + up}, centre),
                            facing({a, b, b + up, a + up}, centre),
                            facing({b, c, c + up, b + up}, centre),
                            facing({c, a, a + up, c + up}, centre)});
}

// Unoccluded scenes (nothing can occlude: ExactFormFactors::upper_row's batches, not the
// per-pair path the clipped tests above take): the same bits and costs as row by row, with
// elements of several sizes (both orientations) and shapes (quads and triangles).
TEST(SymmetricBuild, UnoccludedBatchesGiveTheSameBitsAsRowByRow) {
  for (const Scene& scene : {box(1.0, 0.6, 0.35), prism()}) {
    const Mesh mesh = build_mesh(scene, {1, 0.15});
    const size_t n = mesh.size();
    ExactOptions options;
    options.tolerance = 1e-3;
    const ExactFormFactors method(scene, mesh, options);
    BuildReport rows_report, report;
    const FormFactorMatrix rows = build_matrix(method, n, Precision::kDouble, rows_report);
    const FormFactorMatrix m =
        build_matrix_symmetric(method, mesh, Precision::kDouble, Layout::kSparse, report);
    EXPECT_TRUE(identical_entries(m, rows));
    EXPECT_EQ(report.cost.pairs_culled, rows_report.cost.pairs_culled);
    EXPECT_EQ(report.cost.pairs_unoccluded, rows_report.cost.pairs_unoccluded);
    EXPECT_EQ(2 * report.cost.kernel_evaluations, rows_report.cost.kernel_evaluations);
    size_t turned = 0;
    for (size_t i = 0; i < n; ++i)
      for (size_t j = i + 1; j < n; ++j)
        if (m.at(i, j) > 0 && !ExactFormFactors::integrates_from(mesh, i, j)) ++turned;
    EXPECT_GT(turned, 20u);
  }
}

}  // namespace
}  // namespace radlab
