// The ray sampling and the batched power propagation behind stochastic-jacobi (and the direction
// random-walk shares): the concentric-map cosine direction has the cosine density, its sin/cos
// polynomials are sin and cos, and a propagation gives the same bits on any number of threads
// although its rays are reordered and cast in batches.
#include "solvers/monte_carlo/power_propagation.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <numbers>

#include "core/random.h"
#include "solvers/monte_carlo/ray_sampler.h"
#include "tests/solvers/monte_carlo/matrix_free.h"

namespace radlab {
namespace {

using namespace monte_carlo;

TEST(CosineDirection, QuarterPolynomialsAreSinAndCos) {
  // The series are cut where the first term left out is 2e-14 at pi/4; a wrong coefficient in
  // any of the first terms moves the result by 1e-12 or more somewhere on [-pi/4, pi/4]
  // (the last kept terms are ~3e-11 and ~5e-13 there).
  double worst = 0.0;
  for (int k = -1000; k <= 1000; ++k) {
    const double theta = std::numbers::pi / 4.0 * double(k) / 1000.0;
    double s = 0.0, c = 0.0;
    sin_cos_quarter(theta, s, c);
    worst = std::max({worst, std::abs(s - std::sin(theta)), std::abs(c - std::cos(theta))});
  }
  EXPECT_LT(worst, 1e-13);
}

TEST(CosineDirection, HasTheCosineDensityAboutATiltedNormal) {
  // 2^18 directions about a normal off every axis. Under density cos(theta)/pi, z = cos(theta)
  // has mean 2/3 and variance 1/2 - 4/9 = 1/18 (sd 0.236), so the sample mean's sd is
  // 0.236/512 = 4.6e-4; the tangential components have mean 0 and variance 1/4 (sd 9.8e-4 for
  // the mean). Bounds at 5 sd: a uniform hemisphere (mean z 1/2) is far outside, and so is a
  // concentric map with sine and cosine swapped in one of its two cases (every direction then
  // lies nearer the bitangent: none with |x| > |y| in the tangent plane).
  const Vec3 n = glm::normalize(Vec3(0.3, -0.5, 0.8));
  const Frame f = frame_about(n);
  Pcg32 rng(11);
  const int count = 1 << 18;
  double z = 0.0, x = 0.0, y = 0.0, wide = 0.0, worst_length = 0.0;
  for (int k = 0; k < count; ++k) {
    const double u1 = rng.next_double(), u2 = rng.next_double();
    const Vec3 d = cosine_direction(n, u1, u2);
    worst_length = std::max(worst_length, std::abs(glm::length(d) - 1.0));
    ASSERT_GE(glm::dot(d, n), 0.0);
    z += glm::dot(d, n);
    const double dx = glm::dot(d, f.t), dy = glm::dot(d, f.b);
    x += dx;
    y += dy;
    wide += std::abs(dx) > std::abs(dy) ? 1.0 : 0.0;
  }
  EXPECT_LT(worst_length, 1e-12);
  EXPECT_NEAR(z / count, 2.0 / 3.0, 5 * 4.6e-4);
  EXPECT_NEAR(x / count, 0.0, 5 * 9.8e-4);
  EXPECT_NEAR(y / count, 0.0, 5 * 9.8e-4);
  // By symmetry half the directions lie nearer the tangent than the bitangent (binomial sd
  // 0.5/512 = 9.8e-4).
  EXPECT_NEAR(wide / count, 0.5, 5 * 9.8e-4);
}

TEST(PowerPropagation, SameBitsOnOneTwoAndFourThreads) {
  // The rays are sorted by their first number and cast in batches inside a TBB loop whose
  // split depends on the thread count; every ray's numbers and the order of the deposits do
  // not, so the estimate must be the same bits.
  auto s = testing::matrix_free("cornell", 2);
  const ElementRays rays(s->mesh);
  const PowerPropagation propagation(s->mesh, s->system->reflectance(), rays);
  Radiosity reference;
  for (int threads : {1, 2, 4}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));
    auto stream = make_pseudo_stream(5);
    uint64_t block = 0;
    Radiosity y;
    // 10,000 rays: several blocks, the last one partial.
    EXPECT_EQ(propagation.propagate(s->system->emission(), 10000, *stream, &block, y), 10000u);
    if (threads == 1) {
      reference = y;
      double received = 0.0;
      for (double v : y.raw()) received += v;
      EXPECT_GT(received, 0.0);  // the lamp lights the box
      continue;
    }
    ASSERT_EQ(y.raw().size(), reference.raw().size());
    for (size_t k = 0; k < y.raw().size(); ++k)
      ASSERT_EQ(y.raw()[k], reference.raw()[k]) << threads << " threads, value " << k;
  }
}

}  // namespace
}  // namespace radlab
