// Visibility sampling (sampling.h) and the visibility fraction's shortcuts (visibility.h): the
// shortcuts change the cost, never V.
#include "formfactor/visibility/visibility.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <glm/geometric.hpp>
#include <iostream>
#include <limits>
#include <random>
#include <vector>

#include "formfactor/matrix/matrix.h"
#include "formfactor/methods/raycast.h"
#include "formfactor/visibility/sampling.h"
#include "scene/builtin/builtin_scenes.h"
#include "scene/validate.h"

namespace radlab {
namespace {

// Whether p lies in the convex planar polygon c (within tol, in its plane).
bool inside(const std::vector<Vec3>& c, const Vec3& p, double tol) {
  const Vec3 n = glm::normalize(glm::cross(c[1] - c[0], c[2] - c[0]));
  if (std::abs(glm::dot(p - c[0], n)) > tol) return false;
  for (size_t k = 0; k < c.size(); ++k) {
    const Vec3& a = c[k];
    const Vec3& b = c[(k + 1) % c.size()];
    if (glm::dot(glm::cross(b - a, p - a), n) < -tol) return false;
  }
  return true;
}

// The batched float points equal the double ones to float precision, lie on the element, and
// every stratum of a quad gets one point, for a quad, a triangle and a pentagon.
TEST(StratifiedSampler, FloatBatchMatchesThePointsAndStaysOnTheElement) {
  const std::vector<std::vector<Vec3>> shapes = {
      {Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(2.5, 1, 0), Vec3(0, 1.5, 0)},
      {Vec3(1, 0, 1), Vec3(3, 0, 1), Vec3(1, 2, 1)},
      {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1.5, 0.8, 0), Vec3(0.5, 1.4, 0), Vec3(-0.4, 0.7, 0)}};
  for (const auto& shape : shapes) {
    const int m = 4;
    const StratifiedSampler sampler(shape, m);
    std::vector<uint32_t> strata(16), bits(16);
    for (uint32_t k = 0; k < 16; ++k) strata[k] = k, bits[k] = uint32_t(mix64(k) >> 7);
    std::vector<float> x(16), y(16), z(16);
    sampler.points(strata.data(), bits.data(), 16, x.data(), y.data(), z.data());
    for (uint32_t k = 0; k < 16; ++k) {
      const Vec3 exact = sampler.point(int(k % 4), int(k / 4), bits[k]);
      EXPECT_NEAR(x[k], exact.x, 1e-6) << shape.size() << " " << k;
      EXPECT_NEAR(y[k], exact.y, 1e-6) << shape.size() << " " << k;
      EXPECT_NEAR(z[k], exact.z, 1e-6) << shape.size() << " " << k;
      EXPECT_TRUE(inside(shape, Vec3(x[k], y[k], z[k]), 1e-6)) << shape.size() << " " << k;
    }
  }
  // On a parallelogram the bilinear map is affine: point k lies in cell (k mod 4, k / 4).
  const std::vector<Vec3> square = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0)};
  const StratifiedSampler sampler(square, 4);
  for (uint32_t k = 0; k < 16; ++k) {
    const Vec3 p = sampler.point(int(k % 4), int(k / 4), uint32_t(mix64(k + 99)));
    EXPECT_EQ(int(std::floor(p.x * 4)), int(k % 4));
    EXPECT_EQ(int(std::floor(p.y * 4)), int(k / 4));
  }
}

// sample_solid_angles repeats SolidAngleSampler lane by lane: the same bits on every path (in
// front, behind, in the plane, near a corner, tiny fan triangles, every lane count), on every
// instruction sets this processor has (each a separate vectorisation of the same body). Any
// reordering of its arithmetic shows here.
TEST(SolidAngleBatch, SameBitsAsTheSamplerOnEveryPath) {
  std::vector<std::vector<Vec3>> shapes = {
      {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0)},
      {Vec3(0, 0, 0), Vec3(2, 0, 0.1), Vec3(2.5, 1, 0.2), Vec3(0, 1.5, 0.1)},
      {Vec3(1, 0, 1), Vec3(3, 0, 1), Vec3(1, 2, 1)},
      {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1.5, 0.8, 0), Vec3(0.5, 1.4, 0), Vec3(-0.4, 0.7, 0)},
      {Vec3(0, 0, 0), Vec3(1e-7, 0, 0), Vec3(1e-7, 1, 0), Vec3(0, 1, 0)}};  // a sliver
  std::vector<Vec3> disc;                                                   // a 15-gon
  for (int k = 0; k < 15; ++k) disc.emplace_back(std::cos(k * 0.4189), std::sin(k * 0.4189), 0.0);
  shapes.push_back(disc);
  std::mt19937_64 random(5);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  size_t in_front = 0, away = 0, runs[3] = {0, 0, 0};
  for (const auto& shape : shapes) {
    const Vec3 normal = glm::normalize(glm::cross(shape[1] - shape[0], shape[2] - shape[0]));
    for (int trial = 0; trial < 300; ++trial) {
      SolidAngleLanes lanes;
      const int count = 1 + int(unit(random) * 16.0) % 16;
      for (int k = 0; k < count; ++k) {
        // Above a point of the polygon's box at heights from 1e-7 to 10; some behind, some in
        // the plane, some next to a corner.
        const Vec3 base = shape[size_t(unit(random) * double(shape.size())) % shape.size()];
        const double kind = unit(random);
        const double height = kind < 0.1    ? -0.5
                              : kind < 0.15 ? 0.0
                                            : std::pow(10.0, -7.0 + 8.0 * unit(random));
        const Vec3 spread = kind > 0.9 ? Vec3(1e-9) : Vec3(unit(random), unit(random), 0.0) - 0.5;
        const Vec3 x = base + spread + height * normal;
        lanes.x[0][k] = x.x, lanes.x[1][k] = x.y, lanes.x[2][k] = x.z;
        lanes.u[k] = trial % 7 == 0 ? 0.0 : unit(random);
        lanes.v[k] = trial % 11 == 0 ? 0.9999999999 : unit(random);
      }
      for (SamplerIsa isa : {SamplerIsa::baseline, SamplerIsa::avx2, SamplerIsa::avx512}) {
        SolidAngleLanes out = lanes;
        if (!sample_solid_angles_on(isa, shape, normal, count, out)) continue;
        ++runs[int(isa)];
        for (int k = 0; k < count; ++k) {
          const Vec3 x(lanes.x[0][k], lanes.x[1][k], lanes.x[2][k]);
          const SolidAngleSampler sampler(x, shape, normal);
          const Vec3 y = sampler.point(lanes.u[k], lanes.v[k]);
          const double expected[4] = {y.x, y.y, y.z, sampler.solid_angle()};
          const double got[4] = {out.y[0][k], out.y[1][k], out.y[2][k], out.omega[k]};
          ASSERT_EQ(std::memcmp(expected, got, sizeof(got)), 0)
              << "instruction set " << int(isa) << ", " << shape.size() << " corners, trial "
              << trial << " lane " << k << ": (" << got[0] << ", " << got[1] << ", " << got[2]
              << ", " << got[3] << ") against (" << y.x << ", " << y.y << ", " << y.z << ", "
              << expected[3] << ")";
          (sampler.solid_angle() > 0.0 ? in_front : away) += 1;
        }
      }
    }
  }
  EXPECT_GT(in_front, 3000u);
  EXPECT_GT(away, 300u);
  EXPECT_GT(runs[int(SamplerIsa::baseline)], 0u);
  if (runs[int(SamplerIsa::avx512)] == 0)
    std::cout << "AVX-512 not on this processor: not tested\n";
}

// The own-polygon filter is left off only where no hit on i's or j's polygon can occur: V is the
// same as with the filter on every pair. On the Cornell box rays between touching elements (the
// floor and the walls along their shared edges, the blocks on the floor) do hit their own
// polygons by rounding: without any filter V changes for 1,686 pairs at --subdiv 6 (this is what
// makes the first check able to fail), and the automatic rule keeps the filter for those pairs.
TEST(VisibilityOwnPolygonFilter, AutomaticRuleGivesTheSameVAsAlwaysFiltering) {
  Scene scene = make_builtin_scene("cornell");
  validate_scene(scene);
  const Mesh mesh = build_mesh(scene, {6, 0.0});
  const double eps = plane_epsilon(mesh);
  Visibility automatic(scene, mesh, 16, 3, /*shaft_culling=*/false);
  Visibility always(scene, mesh, 16, 3, false);
  always.set_own_polygon_filter(Visibility::OwnPolygonFilter::always);
  Visibility never(scene, mesh, 16, 3, false);
  never.set_own_polygon_filter(Visibility::OwnPolygonFilter::never);
  RowCost cost;
  size_t pairs = 0, differ_without_filter = 0, filters = 0;
  for (size_t i = 0; i < mesh.size(); ++i)
    for (size_t j = i + 1; j < mesh.size(); ++j) {
      if (!pair_faces(mesh, i, j, eps)) continue;
      ++pairs;
      const double v = always.fraction(i, j, cost);
      ASSERT_EQ(automatic.fraction(i, j, cost), v) << i << " " << j;
      differ_without_filter += never.fraction(i, j, cost) != v ? 1 : 0;
      filters += size_t(automatic.own_polygons_filtered(i, j));
    }
  EXPECT_GT(pairs, 10000u);
  EXPECT_GT(differ_without_filter, 0u);
  // The rule decides both ways: most pairs need no filter, some (near touching ones) do.
  EXPECT_GT(filters, 0u);
  EXPECT_LT(filters, pairs / 2);
}

// Counts other than 4^n take the general paths (a square count not a power of two: an affine
// permutation with a multiplier prime to R; a non-square count: chosen cells and a shuffle): V
// stays in [0,1], symmetric, and equal to 1 for a pair nothing blocks.
TEST(VisibilityOwnPolygonFilter, EveryRayCountIsSymmetricAndBounded) {
  Scene scene = make_builtin_scene("cornell");
  validate_scene(scene);
  const Mesh mesh = build_mesh(scene, {3, 0.0});
  const double eps = plane_epsilon(mesh);
  for (int rays : {9, 10, 16, 36, 64}) {
    Visibility visibility(scene, mesh, rays, 1, false);
    RowCost cost;
    for (size_t i = 0; i < mesh.size(); i += 5)
      for (size_t j = 0; j < mesh.size(); j += 3) {
        if (i == j || !pair_faces(mesh, i, j, eps)) continue;
        const double v = visibility.fraction(i, j, cost);
        ASSERT_GE(v, 0.0);
        ASSERT_LE(v, 1.0);
        ASSERT_EQ(v, visibility.fraction(j, i, cost)) << rays << " " << i << " " << j;
        // V is a kernel-weighted share kept in steps of 2^-14 (visibility.h).
        ASSERT_EQ(std::round(v * 16384), v * 16384) << rays;
      }
  }
}

// A pair's standard error is kept in the pair memo's 16 bits (Visibility::sigma_code). The value
// a row gets must be the memo's value, whichever row computes the pair: rounded up (a bound, never
// below the estimate), at most one step of 2^-16 above it, at most 1, and unchanged by another
// trip through the memo. Before the fix a sigma of 1 (or NaN) reached the first row as 1 but the
// memo capped it to 65535/65536 for the second.
TEST(VisibilitySigmaCode, BothRowsOfAPairGetTheSameRoundedUpValue) {
  const double step = 1.0 / 65536.0;
  const double sigmas[] = {0.0,
                           1e-12,
                           step,
                           0.1,
                           0.5,
                           1.0 - 2 * step,
                           1.0 - 1.5 * step,
                           1.0 - step,
                           1.0 - 0.5 * step,
                           1.0,
                           1.5,
                           std::numeric_limits<double>::quiet_NaN()};
  for (double sigma : sigmas) {
    const double first = Visibility::sigma_of_code(Visibility::sigma_code(sigma));
    const double second = Visibility::sigma_of_code(Visibility::sigma_code(first));
    EXPECT_EQ(first, second) << sigma;
    EXPECT_LE(first, 1.0) << sigma;
    if (std::isnan(sigma) || sigma >= 1.0) {
      EXPECT_EQ(first, 1.0) << sigma;  // the bound: V in [0,1]; NaN knows nothing
    } else {
      EXPECT_GE(first, sigma);
      EXPECT_LT(first - sigma, 2 * step) << sigma;  // one step, or two into the code for 1
    }
  }
}

// With the pair memo on, the row that reuses a pair gets the first row's sigma bit for bit, and
// both are what a Visibility without the memo (a block of rows) gives.
TEST(VisibilitySigmaCode, MemoisedPairsGiveBothRowsTheUnmemoisedSigma) {
  Scene scene = make_builtin_scene("cornell");
  validate_scene(scene);
  const Mesh mesh = build_mesh(scene, {3, 0.0});
  const double eps = plane_epsilon(mesh);
  const Visibility memo(scene, mesh, 16, 1, true), plain(scene, mesh, 16, 1, true);
  memo.remember_pairs(true);
  RowCost cost;
  size_t traced = 0;
  for (size_t i = 0; i < mesh.size(); i += 5)
    for (size_t j = 0; j < mesh.size(); j += 3) {
      if (i == j || !pair_faces(mesh, i, j, eps)) continue;
      double first = -1, second = -1, alone = -1;
      memo.fraction(i, j, cost, &first);
      memo.fraction(j, i, cost, &second);
      plain.fraction(j, i, cost, &alone);
      ASSERT_EQ(first, second) << i << " " << j;
      ASSERT_EQ(first, alone) << i << " " << j;
      traced += first > 0.0 ? 1 : 0;
    }
  EXPECT_GT(traced, 0u);  // the box blocks some pairs: sigmas other than 0 were compared
}

// A build of every row keeps V_ij for V_ji (Visibility::remember_pairs): the same matrix, bit for
// bit, as row by row, the same pair counts, and exactly half the rays (each unordered pair traced
// once instead of once per row).
TEST(VisibilityRememberPairs, DenseBuildTracesEachPairOnceWithTheSameMatrix) {
  Scene scene = make_builtin_scene("cornell");
  validate_scene(scene);
  const Mesh mesh = build_mesh(scene, {5, 0.0});
  const RaycastFormFactors ff(scene, mesh, {});
  BuildReport report;
  const FormFactorMatrix built = build_matrix(ff, mesh.size(), Precision::kDouble, report);
  RowCost row_by_row;
  std::vector<double> row(mesh.size());
  for (size_t i = 0; i < mesh.size(); ++i) {
    ff.row(i, row, row_by_row);
    for (size_t j = 0; j < mesh.size(); ++j) ASSERT_EQ(built.at(i, j), row[j]) << i << " " << j;
  }
  EXPECT_GT(row_by_row.rays, 0u);
  EXPECT_EQ(2 * report.cost.rays, row_by_row.rays);
  EXPECT_EQ(report.cost.pairs_traced, row_by_row.pairs_traced);
  EXPECT_EQ(report.cost.pairs_unoccluded, row_by_row.pairs_unoccluded);
}

}  // namespace
}  // namespace radlab
