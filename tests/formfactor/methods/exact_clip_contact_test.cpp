// `exact --ff-set visibility=clip` on the Cornell box, whose blocks stand on the floor (issue 13
// target 1, issue 11: no hang, honest claims). At the default tolerance (1e-10) the adaptive rule
// cannot converge where the visible part of j changes abruptly (kink lines of shadow edges: error
// ~4^-depth; an occluder standing on i: a jump, ~2^-depth): before the work cap this build did
// not finish in 10 CPU minutes. Asserted here, by evaluation counts (RowCost), not wall time:
//  - every occluded pair stops within max_evaluations (+ one split of 144 points);
//  - every entry and every row sum agrees with a finer integration (five times the cap) within
//    the sum of the two integrations' stated errors: tolerance * F + the remaining error the
//    method records for pairs stopped short of the tolerance (exact.h, "Work cap");
//  - every row sum agrees with an independent estimate, raycast with 1,024 rays a pair (its
//    visibility a ray estimate, not a clipped polygon), within the two methods' stated errors;
//  - pairs did stop short, so the stated error is more than the tolerance (the test exercises
//    the cap, and the row-sum check's stated error covers it).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "formfactor/matrix/diagnostics.h"
#include "formfactor/matrix/matrix_cache.h"
#include "formfactor/methods/exact.h"
#include "formfactor/methods/raycast.h"
#include "scene/mesh.h"
#include "scene/scene_loader.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

struct Integrated {
  std::vector<double> f;       // F_ij, i * n + j, every ordered pair
  std::vector<double> excess;  // the error stated beyond tolerance * F_ij, per ordered pair
  std::vector<double> row_excess;
  uint64_t largest_traced = 0;  // evaluations of the costliest occluded pair
  uint64_t evaluations = 0;
  size_t traced = 0;
};

// Every pair once (over its smaller element, as the symmetric build does), single-threaded so
// each pair's share of the row excess can be read off before and after it.
Integrated integrate(const ExactFormFactors& method, const Mesh& mesh) {
  const size_t n = mesh.size();
  Integrated out;
  out.f.assign(n * n, 0.0);
  out.excess.assign(n * n, 0.0);
  for (size_t a = 0; a < n; ++a)
    for (size_t b = a + 1; b < n; ++b) {
      const bool from_a = ExactFormFactors::integrates_from(mesh, a, b);
      const size_t i = from_a ? a : b, j = from_a ? b : a;
      const double before = method.row_excess(i);
      RowCost cost;
      const double f = method.pair_integral(i, j, cost);
      const double excess = method.row_excess(i) - before;
      out.f[i * n + j] = f;
      out.f[j * n + i] = ExactFormFactors::reciprocal(f, mesh.area[i], mesh.area[j]);
      out.excess[i * n + j] = excess;
      out.excess[j * n + i] = ExactFormFactors::reciprocal(excess, mesh.area[i], mesh.area[j]);
      out.evaluations += cost.kernel_evaluations;
      if (cost.pairs_traced > 0) {
        ++out.traced;
        out.largest_traced = std::max(out.largest_traced, cost.kernel_evaluations);
      }
    }
  for (size_t i = 0; i < n; ++i) out.row_excess.push_back(method.row_excess(i));
  return out;
}

TEST(ClipContact, CornellFinishesWithinTheCapAndStatesItsError) {
  const LoadedScene loaded = load_scene("builtin:cornell", false);
  const Mesh mesh = build_mesh(loaded.scene, {});
  const size_t n = mesh.size();
  ExactOptions options;  // the defaults: tolerance 1e-10, max_evaluations 20000
  options.visibility_clip = true;
  const ExactFormFactors capped(loaded.scene, mesh, options);
  options.max_evaluations *= 5;
  const ExactFormFactors finer(loaded.scene, mesh, options);
  const Integrated a = integrate(capped, mesh);
  const Integrated b = integrate(finer, mesh);

  // The budget: the cap is checked before each split, which prepares 4 cells, each with its 4
  // children's 3x3 rules (144 evaluations).
  ASSERT_GT(a.traced, 0u);  // the blocks occlude
  EXPECT_LE(a.largest_traced, uint64_t(ExactOptions{}.max_evaluations + 144));
  // The whole build: 204 occluded pairs at the cap at most, the unoccluded ones far cheaper.
  EXPECT_LE(a.evaluations, uint64_t(a.traced) * uint64_t(ExactOptions{}.max_evaluations + 144) +
                               uint64_t(1000000));
  // Pairs stopped short of 1e-10 (else this test would not exercise the cap), and the method
  // says so in its stated row-sum error.
  EXPECT_GT(capped.pairs_capped(), 0u);
  EXPECT_GT(capped.largest_row_excess(), 0.0);
  EXPECT_EQ(stated_row_sum_error(capped), options.tolerance + 1e-7 + capped.largest_row_excess());
  // The finer integration is closer to the tolerance (its cap is 5x).
  EXPECT_LT(finer.largest_row_excess(), capped.largest_row_excess());

  // Each entry: the two integrations differ by at most the sum of their stated errors. (A
  // stated error that is only a guess would fail here: the difference is measured.)
  const double tol = options.tolerance;
  size_t compared = 0;
  for (size_t i = 0; i < n; ++i) {
    double sum_a = 0.0, sum_b = 0.0;
    for (size_t j = 0; j < n; ++j) {
      const size_t k = i * n + j;
      const double fa = a.f[k], fb = b.f[k];
      sum_a += fa;
      sum_b += fb;
      const double stated = tol * (fa + fb) + a.excess[k] + b.excess[k];
      EXPECT_LE(std::abs(fa - fb), stated + 1e-15) << "pair " << i << ", " << j;
      compared += a.excess[k] > 0.0 ? 1 : 0;
    }
    // Each row sum within the rows' stated errors (the row-sum check's allowance).
    EXPECT_LE(std::abs(sum_a - sum_b), 2 * tol + a.row_excess[i] + b.row_excess[i] + 1e-15)
        << "row " << i;
  }
  EXPECT_GT(compared, 0u);

  // Independent: raycast's rows (quadrature tolerance 1e-6, visibility by 1,024 rays a pair).
  // Its stated row error is tolerance + kRowSamplingSigmas standard errors of the row's
  // sampling (diagnostics.h), the clip rows' tolerance + their recorded excess.
  RaycastOptions ray_options;
  ray_options.tolerance = 1e-7;
  ray_options.rays = 1024;
  const RaycastFormFactors raycast(loaded.scene, mesh, ray_options);
  std::vector<double> row(n);
  for (size_t i = 0; i < n; ++i) {
    RowCost cost;
    raycast.row(i, row, cost);
    double sum_ray = 0.0, sum_clip = 0.0;
    for (size_t j = 0; j < n; ++j) sum_ray += row[j], sum_clip += a.f[i * n + j];
    const double stated = ray_options.tolerance +
                          kRowSamplingSigmas * raycast.row_sampling_error(i) + tol +
                          a.row_excess[i];
    EXPECT_LE(std::abs(sum_clip - sum_ray), stated) << "row " << i;
  }
}

// The row-by-row path (on-the-fly rows: each pair computed from both of its rows) records each
// pair's excess once, so the stated error does not grow with recomputation.
TEST(ClipContact, RecomputedRowsDoNotInflateTheStatedError) {
  const LoadedScene loaded = load_scene("builtin:cornell", false);
  const Mesh mesh = build_mesh(loaded.scene, {});
  ExactOptions options;
  options.visibility_clip = true;
  options.max_evaluations = 2000;  // a small cap: cheap, and many pairs stop short
  const ExactFormFactors method(loaded.scene, mesh, options);
  std::vector<double> row(mesh.size());
  RowCost cost;
  for (size_t i = 0; i < mesh.size(); ++i) method.row(i, row, cost);
  const double once = method.largest_row_excess();
  const size_t pairs = method.pairs_capped();
  EXPECT_GT(pairs, 0u);
  for (size_t i = 0; i < mesh.size(); ++i) method.row(i, row, cost);
  EXPECT_EQ(method.largest_row_excess(), once);
  EXPECT_EQ(method.pairs_capped(), pairs);

  // Kept beside a cached matrix and restored with it (a loaded matrix states the same error);
  // a file of the wrong size is refused, so the caller rebuilds instead of understating. The
  // side file is bound to its matrix file's header (matrix_cache.h): a real cache file, whose
  // values do not matter here.
  testing::TempDir dir;
  const MatrixCache cache(dir.path());
  const MatrixCacheKey key =
      matrix_cache_key(mesh, "exact", method.parameters(), Precision::kDouble);
  ASSERT_TRUE(cache.store(key, FormFactorMatrix(mesh.size(), Precision::kDouble), BuildReport{}));
  const std::string file = cache.path(key).string();
  save_row_excess(method, file);
  const ExactFormFactors restored(loaded.scene, mesh, options);
  EXPECT_EQ(restored.largest_row_excess(), 0.0);
  EXPECT_FALSE(load_row_excess(restored, file, mesh.size() + 1));
  EXPECT_FALSE(load_row_excess(restored, dir.file("missing.ffm"), mesh.size()));
  ASSERT_TRUE(load_row_excess(restored, file, mesh.size()));
  EXPECT_EQ(restored.row_excesses(), method.row_excesses());
  EXPECT_EQ(restored.pairs_capped(), pairs);
  EXPECT_EQ(stated_row_sum_error(restored), stated_row_sum_error(method));
}

}  // namespace
}  // namespace radlab

namespace radlab {
namespace {

// A unit floor square with a box [0.3,0.7]^2 x [0,0.4] (five faces, no bottom) standing on it,
// under a larger ceiling square at height 1: the floor is integrated (the smaller element), and
// its points under the box see nothing, those beside it see past it — a jump along the box's
// footprint, where the adaptive rule's error falls only as 2^-depth. Integrated whole, the pair
// stopped at the cap (20,061 evaluations) even at tolerance 1e-3, stating 1.1e-3 beyond it; split
// along the box's side planes (exact.cpp, split_on_contacts) it reaches 1e-4 in 2,853.
TEST(ClipContact, BoxStandingOnTheIntegratedElementConverges) {
  const double a = 0.3, b = 0.7, h = 0.4;
  const std::vector<std::vector<Vec3>> polygons = {
      {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}},      // floor, up
      {{-1, -1, 1}, {-1, 2, 1}, {2, 2, 1}, {2, -1, 1}},  // ceiling, down
      {{a, a, h}, {b, a, h}, {b, b, h}, {a, b, h}},      // box top, up
      {{a, a, 0}, {b, a, 0}, {b, a, h}, {a, a, h}},      // sides, outward
      {{b, a, 0}, {b, b, 0}, {b, b, h}, {b, a, h}},
      {{b, b, 0}, {a, b, 0}, {a, b, h}, {b, b, h}},
      {{a, b, 0}, {a, a, 0}, {a, a, h}, {a, b, h}}};
  const Scene scene = testing::scene_of(polygons);
  const Mesh mesh = build_mesh(scene, {});
  ASSERT_TRUE(ExactFormFactors::integrates_from(mesh, 0, 1));
  ExactOptions options;
  options.visibility_clip = true;
  auto integrate_at = [&](double tolerance, uint64_t* evaluations, double* excess) {
    options.tolerance = tolerance;
    const ExactFormFactors method(scene, mesh, options);
    RowCost cost;
    const double f = method.pair_integral(0, 1, cost);
    *evaluations = cost.kernel_evaluations;
    *excess = method.row_excess(0);
    return f;
  };
  uint64_t evaluations = 0, fine_evaluations = 0;
  double excess = 0.0, fine_excess = 0.0;
  const double f = integrate_at(1e-4, &evaluations, &excess);
  const double fine = integrate_at(1e-6, &fine_evaluations, &fine_excess);
  // Converged: nothing stated beyond the tolerance, at a quarter of the cap. (Measured 2,853;
  // the bound leaves room for changes to the rule, not for a pair that never converges.)
  EXPECT_EQ(excess, 0.0);
  EXPECT_LE(evaluations, uint64_t(ExactOptions{}.max_evaluations / 4));
  // Within the stated errors of a run at 1e-6 (its own error: 1e-6 * F + what it states).
  EXPECT_NEAR(f, fine, 1e-4 * f + 1e-6 * fine + fine_excess);
  // Independent: raycast's row 0 (the ceiling and the box faces, which are all the floor sees)
  // with 4,096 rays a pair, within its tolerance + 5 standard errors of the row's sampling.
  options.tolerance = 1e-4;
  const ExactFormFactors clip(scene, mesh, options);
  RaycastOptions ray_options;
  ray_options.tolerance = 1e-6;
  ray_options.rays = 4096;
  const RaycastFormFactors raycast(scene, mesh, ray_options);
  std::vector<double> row(mesh.size());
  RowCost cost;
  raycast.row(0, row, cost);
  double sum_ray = 0.0, sum_clip = 0.0;
  for (size_t j = 0; j < mesh.size(); ++j) sum_ray += row[j], sum_clip += clip.pair(0, j, cost);
  EXPECT_NEAR(sum_clip, sum_ray,
              ray_options.tolerance + kRowSamplingSigmas * raycast.row_sampling_error(0) + 1e-4);
}

}  // namespace
}  // namespace radlab
