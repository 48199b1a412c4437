// Visibility of close pairs (issue 16, what the kernel-weighted estimate left): the solid-angle
// sampler against Lambert's closed form, and the importance-sampled visibility of a small
// element close to a large one against a closed form of its visible part.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <glm/geometric.hpp>

#include "formfactor/integrate/point_polygon.h"
#include "formfactor/matrix/matrix.h"
#include "formfactor/matrix/matrix_cache.h"
#include "formfactor/methods/raycast.h"
#include "formfactor/visibility/sampling.h"
#include "scene/mesh.h"
#include "scene/scene_loader.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

using testing::scene_of;

// Mean of cos_x over directions drawn uniformly in the solid angle, times Omega, is the integral
// of cos_x over the solid angle: pi times the point-to-polygon form factor (Lambert, exact). An
// area-uniform sampler, or a solid-angle one with the wrong density, is off by tens of percent
// here (the polygon is close: the kernel varies 30x over it). The midpoints of an m x m grid:
// where u crosses from one fan triangle to the next the integrand jumps, off the grid lines, so
// the rule is first order in 1/m (the square from x = (0.3, 0.2, 0.1): 1.5e-2 at m = 16, 1.6e-3
// at 256, 6e-5 at 1024); at m = 512, 1e-3.
TEST(SolidAngleSampler, ReproducesLambertsFormula) {
  const std::vector<std::vector<Vec3>> polygons = {
      {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}},                  // unit square
      {{0, 0, 0}, {2, 0, 0}, {2.5, 1, 0}, {1, 2, 0}, {-0.5, 1, 0}},  // pentagon
      {{0, 0, 0}, {3, 0, 0}, {0, 0.01, 0}}};                         // a sliver
  const Vec3 normal(0, 0, 1);
  std::vector<Vec3> scratch;
  for (const auto& polygon : polygons)
    for (const Vec3 x : {Vec3(0.3, 0.2, 0.1), Vec3(-0.4, 0.5, 0.05), Vec3(0.5, 0.5, 2.0)}) {
      const Vec3 n_x = glm::normalize(Vec3(0.2, -0.1, -1.0));  // tilted, facing the polygon
      const SolidAngleSampler sampler(x, polygon, normal);
      ASSERT_GT(sampler.solid_angle(), 0.0);
      const int m = 512;
      double sum = 0.0;
      for (int a = 0; a < m; ++a)
        for (int b = 0; b < m; ++b) {
          const Vec3 y = sampler.point((a + 0.5) / m, (b + 0.5) / m);
          EXPECT_NEAR(y.z, 0.0, 1e-12);
          sum += std::max(0.0, glm::dot(n_x, glm::normalize(y - x)));
        }
      const double estimate = sampler.solid_angle() * sum / (m * m) / M_PI;
      const double exact = point_to_polygon_form_factor(x, n_x, polygon, normal, scratch);
      EXPECT_NEAR(estimate / exact, 1.0, 1e-3) << x.x << " " << x.y << " " << x.z;
    }
}

// The solid angle of a polygon seen from behind or from its plane is 0 (it sees nothing).
TEST(SolidAngleSampler, BackAndPlaneSeeNothing) {
  const std::vector<Vec3> square = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  EXPECT_EQ(SolidAngleSampler(Vec3(0.5, 0.5, -1), square, Vec3(0, 0, 1)).solid_angle(), 0.0);
  EXPECT_EQ(SolidAngleSampler(Vec3(2, 0.5, 0), square, Vec3(0, 0, 1)).solid_angle(), 0.0);
  // A hemisphere's worth: a huge square just below x subtends nearly 2 pi.
  const std::vector<Vec3> huge = {{-1e4, -1e4, 0}, {1e4, -1e4, 0}, {1e4, 1e4, 0}, {-1e4, 1e4, 0}};
  EXPECT_NEAR(SolidAngleSampler(Vec3(0, 0, 1), huge, Vec3(0, 0, 1)).solid_angle(), 2 * M_PI, 1e-3);
}

// A 10 cm square 0.2 m above the middle of a 10 m floor, facing it, with a cover lying 0.1 mm
// above the floor's right half: the square sees the left half only, so F_ij is the unoccluded
// form factor to the left half (computed on a scene of the two alone; the 0.1 mm parallax at the
// cover's edge changes it by about 1e-4 relative). The kernel varies by 10^4 over the floor and
// is concentrated in 0.1% of its area: uniform points on the floor put almost no rays where it
// matters, and at 4,096 rays F over seeds 0-7 was 0.416-0.559 (truth 0.499, rms error 0.055).
// Importance sampling in solid angle from the square's points weighs each ray by Omega cos_x,
// within [0, 2 pi]: the standard error of a visible fraction of 1/2 is then about
// sqrt(0.25 E[w^2] / E[w]^2 / 4096) ~ 0.009 (measured: 0.481-0.507, rms 0.008). Allowed: 0.03
// per seed (3.5 sigma) and an rms of 0.015 over the eight.
TEST(CloseVisibility, SmallElementAboveAHalfCoveredFloor) {
  const std::vector<Vec3> square = {
      {4.95, 4.95, 0.2}, {4.95, 5.05, 0.2}, {5.05, 5.05, 0.2}, {5.05, 4.95, 0.2}};  // faces down
  const std::vector<Vec3> floor = {{0, 0, 0}, {10, 0, 0}, {10, 10, 0}, {0, 10, 0}};
  const std::vector<Vec3> cover = {{5, 0, 1e-4}, {10, 0, 1e-4}, {10, 10, 1e-4}, {5, 10, 1e-4}};
  const std::vector<Vec3> left = {{0, 0, 0}, {5, 0, 0}, {5, 10, 0}, {0, 10, 0}};
  const Scene alone = scene_of({square, left});
  const Mesh alone_mesh = build_mesh(alone, {});
  const double truth = RaycastFormFactors(alone, alone_mesh, {}).unoccluded_pair(0, 1);
  ASSERT_NEAR(truth, 0.5, 0.01);  // nearly a half plane seen from close by
  const Scene scene = scene_of({square, floor, cover});
  const Mesh mesh = build_mesh(scene, {});
  double squares = 0.0;
  for (uint64_t seed = 0; seed < 8; ++seed) {
    RaycastOptions options;
    options.seed = seed;
    const RaycastFormFactors ff(scene, mesh, options);
    RowCost cost;
    const double f = ff.pair(0, 1, cost);
    EXPECT_NEAR(f, truth, 0.03) << "seed " << seed;
    squares += (f - truth) * (f - truth);
    EXPECT_EQ(cost.rays, 4096u);
    // V is symmetric: the floor's row sees the same fraction.
    RowCost back;
    EXPECT_NEAR(ff.pair(1, 0, back) * mesh.area[1], ff.pair(0, 1, cost) * mesh.area[0],
                1e-4 * mesh.area[0]);
  }
  EXPECT_LT(std::sqrt(squares / 8), 0.015);
}

// Howell's catalogue C-14: from a rectangle of width w to a perpendicular one of height h that
// shares its edge of length l (H = h / l, W = w / l).
double perpendicular_with_common_edge(double l, double w, double h) {
  const double H = h / l, W = w / l, H2 = H * H, W2 = W * W, S = std::sqrt(H2 + W2);
  const double log_term = std::log((1 + W2) * (1 + H2) / (1 + W2 + H2)) +
                          W2 * std::log(W2 * (1 + W2 + H2) / ((1 + W2) * (W2 + H2))) +
                          H2 * std::log(H2 * (1 + H2 + W2) / ((1 + H2) * (H2 + W2)));
  return (W * std::atan(1 / W) + H * std::atan(1 / H) - S * std::atan(1 / S) + 0.25 * log_term) /
         (M_PI * W);
}

// A unit wall and the floor strip that stops 1 mm short of it (the corner cube of
// tests/experiments/run/verdicts_test.cpp: its floor's 1 mm band holds a 1e-6 m^2 corner piece):
// its lowest point lies on the strip's plane, so the adaptive rule ran from one cell per fan
// triangle and accepted its first estimate, 0.200019726 against 0.199545184 (2.4e-3 relative, the
// same at tolerance 1e-3); started from 4 x 4 cells it meets the tolerance 1e-4.
TEST(RaycastQuadrature, TouchingPairMeetsTheTolerance) {
  ASSERT_NEAR(perpendicular_with_common_edge(1, 1, 1), 0.200043776075, 1e-11);  // Howell's value
  // The scene as the trust test writes it (the fan's first corner decides where the rule's
  // cells fall, so the file, not a re-typed polygon): element 3 is the wall y = 0, element 7 the
  // floor's strip y in [0.001, 1], which stops 1 mm short of the wall.
  testing::TempDir dir;
  dir.write("m.mtl", "newmtl wall\nKd 0.5 0.5 0.5\nnewmtl light\nKd 0.5 0.5 0.5\nKe 1 1 1\n");
  const std::string file =
      dir.write("corner.obj",
                "mtllib m.mtl\n"
                "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
                "v 0.001 0 0\nv 0.001 0.001 0\nv 0 0.001 0\nv 1 0.001 0\n"
                "usemtl light\nf 5 8 7 6\n"
                "usemtl wall\nf 1 4 8 5\nf 2 6 7 3\nf 1 5 6 2\nf 4 3 7 8\n"
                "f 1 9 10 11\nf 9 2 12 10\nf 11 12 3 4\n");
  const LoadedScene loaded = load_scene(file, false);
  const Scene& scene = loaded.scene;
  const Mesh mesh = build_mesh(scene, {});
  // The strip is the floor less the 1 mm band along the wall: C-14 twice.
  const double truth =
      perpendicular_with_common_edge(1, 1, 1) - perpendicular_with_common_edge(1, 1, 0.001);
  for (double tolerance : {1e-3, 1e-4}) {
    RaycastOptions options;
    options.tolerance = tolerance;
    const RaycastFormFactors ff(scene, mesh, options);
    EXPECT_NEAR(ff.unoccluded_pair(3, 7) / truth - 1.0, 0.0, tolerance) << tolerance;
  }
}

// Each row's visibility sampling error is the same whether it comes from a build of every row
// (V and its error kept per pair), from computing the row alone, or from the file kept beside a
// cached matrix; and a build gives every row one (the row-sum check needs them).
TEST(RowSamplingError, SameFromTheBuildTheRowAloneAndTheCacheFile) {
  const LoadedScene loaded = load_scene("builtin:cornell", false);
  const Mesh mesh = build_mesh(loaded.scene, {});
  const RaycastFormFactors built(loaded.scene, mesh, {});
  BuildReport report;
  const FormFactorMatrix matrix = build_matrix(built, mesh.size(), Precision::kFloat, report);
  const std::vector<float> sigma = built.row_sampling_errors();
  ASSERT_EQ(sigma.size(), mesh.size());
  size_t positive = 0;
  for (float s : sigma) {
    ASSERT_FALSE(std::isnan(s));
    positive += s > 0.0f ? 1 : 0;
  }
  EXPECT_GT(positive, 0u);  // the boxes occlude: some rows have traced pairs
  const RaycastFormFactors alone(loaded.scene, mesh, {});
  for (size_t i = 0; i < mesh.size(); i += 3) EXPECT_EQ(alone.row_sampling_error(i), sigma[i]);
  testing::TempDir dir;
  const MatrixCache cache(dir.path());
  const MatrixCacheKey key = matrix_cache_key(mesh, "raycast", "", Precision::kFloat);
  ASSERT_TRUE(cache.store(key, matrix, report));
  const std::string file = cache.path(key).string();
  save_row_sampling_errors(built, file);
  const RaycastFormFactors restored(loaded.scene, mesh, {});
  EXPECT_FALSE(load_row_sampling_errors(restored, file, mesh.size() + 1));  // wrong size
  ASSERT_TRUE(load_row_sampling_errors(restored, file, mesh.size()));
  EXPECT_EQ(restored.row_sampling_errors(), sigma);

  // The side file is bound to its matrix file and checksummed (issue 36.8): each of these was
  // accepted when it held 2n bare floats. A zeroed file (every row's error 0: the row-sum check
  // then fails a good matrix as unphysical), one value edited to 1e30 (turns the check off), a
  // file beside another matrix (copied from another key), one beside a rebuilt matrix.
  const std::string side = file + ".sigma";
  const auto size = std::filesystem::file_size(side);
  const auto refused = [&] {
    const RaycastFormFactors fresh(loaded.scene, mesh, {});
    return !load_row_sampling_errors(fresh, file, mesh.size());
  };
  std::ofstream(side, std::ios::binary) << std::string(size, '\0');
  EXPECT_TRUE(refused()) << "zeroed";
  save_row_sampling_errors(built, file);
  {
    std::fstream edit(side, std::ios::binary | std::ios::in | std::ios::out);
    edit.seekp(std::streamoff(size) - 8 - 4 * std::streamoff(mesh.size()) - 4);
    const float huge = 1e30f;
    edit.write(reinterpret_cast<const char*>(&huge), sizeof huge);
  }
  EXPECT_TRUE(refused()) << "a value edited";
  save_row_sampling_errors(built, file);
  const MatrixCacheKey other = matrix_cache_key(mesh, "raycast", "rays=32", Precision::kFloat);
  ASSERT_TRUE(cache.store(other, matrix, report));
  std::filesystem::copy_file(side, cache.path(other).string() + ".sigma");
  EXPECT_FALSE(load_row_sampling_errors(restored, cache.path(other).string(), mesh.size()))
      << "another key's";
  BuildReport rebuilt = report;
  rebuilt.seconds += 1.0;  // the same key built again: another header
  ASSERT_TRUE(cache.store(key, matrix, rebuilt));
  EXPECT_TRUE(refused()) << "an earlier build's";
}

}  // namespace
}  // namespace radlab
