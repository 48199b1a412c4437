// The Monte Carlo solvers' element distribution (solvers/monte_carlo/element_rays.h): the guide
// table finds, for every u, the element the plain binary search in the cumulative weights finds
// (the first whose cumulative weight exceeds u * total), so its probabilities are the weights'.
#include "solvers/monte_carlo/element_rays.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "core/random.h"

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

}  // namespace
}  // namespace radlab
