// The Monte Carlo solvers' element distribution (solvers/monte_carlo/element_rays.h): the guide
// table finds, for every u, the element the plain binary search in the cumulative weights finds
// (the first whose cumulative weight exceeds u * total), so its probabilities are the weights';
// and a batch of rays, made in a vectorised loop and cast through Embree's stream call, has ray
// for ray the origin, direction and element of the single-ray path.
#include "solvers/monte_carlo/element_rays.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "core/random.h"
#include "solvers/monte_carlo/ray_sampler.h"
#include "tests/solvers/monte_carlo/matrix_free.h"

namespace radlab {
namespace {

size_t binary_search_pick(const std::vector<double>& weights, double u) {
  std::vector<double> cumulative(weights.size());
  double total = 0.0;
  for (size_t i = 0; i < weights.size(); ++i) cumulative[i] = total += weights[i];
  size_t i = size_t(std::upper_bound(cumulative.begin(), cumulative.end(), u * total) -
                    cumulative.begin());
  i = std::min(i, weights.size() - 1);
  while (i > 0 && cumulative[i] == cumulative[i - 1]) --i;
  return i;
}

TEST(ElementDistribution, GuideTableAgreesWithTheBinarySearch) {
  // Skewed weights (a lamp holding most of the power, runs of zeros, tiny and huge values) and
  // u at random, at bucket edges k/n and just below 1.
  Pcg32 rng(7);
  std::vector<double> weights(997);
  for (size_t i = 0; i < weights.size(); ++i) {
    const double r = rng.next_double();
    weights[i] = r < 0.2 ? 0.0 : r < 0.25 ? 1e-12 * r : r;
  }
  weights[500] = 1e6;
  const monte_carlo::ElementDistribution distribution(weights);
  std::vector<double> us = {0.0, 0x1.fffffffffffffp-1, 0.5};
  for (size_t k = 0; k < weights.size(); ++k) us.push_back(double(k) / double(weights.size()));
  for (int k = 0; k < 200000; ++k) us.push_back(rng.next_double());
  for (double u : us) ASSERT_EQ(distribution.pick(u), binary_search_pick(weights, u)) << u;
  // Never an element of weight zero.
  for (int k = 0; k < 20000; ++k) EXPECT_GT(weights[distribution.pick(rng.next_double())], 0.0);
}

TEST(ElementRays, BatchCastMeetsWhatEachRayMeetsAlone) {
  // The batch cast (rtcIntersect1M, then the checks of the elements met) must give every ray the
  // answer of trace() (rtcIntersect1 per ray): the same element, or kMiss for the open front and
  // back faces. Rays from every element of the Cornell box (blocks, walls, the lamp), batches
  // full and partial; a batch answer shifted by one ray, or a hit taken from another lane, would
  // differ on most rays.
  auto s = testing::matrix_free("cornell", 2);
  const monte_carlo::ElementRays rays(s->mesh);
  Pcg32 rng(11);
  size_t compared = 0, misses = 0;
  for (size_t size : {size_t(64), size_t(37), size_t(1)}) {
    for (int round = 0; round < 200; ++round) {
      monte_carlo::ElementRays::Batch batch;
      std::vector<double> u(size * monte_carlo::kDimensions);
      std::vector<size_t> source(size);
      for (size_t k = 0; k < size; ++k) {
        source[k] = rng.next_below(uint32_t(s->mesh.size()));
        for (int d = 0; d < monte_carlo::kDimensions; ++d)
          u[k * monte_carlo::kDimensions + size_t(d)] = rng.next_double();
        rays.add(source[k], &u[k * monte_carlo::kDimensions], batch);
      }
      ASSERT_EQ(batch.size, size);
      std::vector<uint32_t> hit(size);
      rays.cast(batch, hit.data());
      for (size_t k = 0; k < size; ++k) {
        // The batch's rays are made in a vectorised loop: the same bits as one ray alone.
        const monte_carlo::ElementRays::Ray alone =
            rays.ray(source[k], &u[k * monte_carlo::kDimensions]);
        for (int c = 0; c < 3; ++c) {
          ASSERT_EQ(batch.origin[k][c], alone.origin[c]) << k;
          ASSERT_EQ(batch.direction[k][c], alone.direction[c]) << k;
        }
        ASSERT_EQ(hit[k], rays.trace(source[k], &u[k * monte_carlo::kDimensions])) << k;
        misses += hit[k] == monte_carlo::ElementRays::kMiss ? 1 : 0;
        ++compared;
      }
    }
  }
  // Both kinds of answer were exercised: the open front lets rays escape, most rays land.
  EXPECT_GT(misses, 0u);
  EXPECT_LT(misses, compared / 2);
}

}  // namespace
}  // namespace radlab
