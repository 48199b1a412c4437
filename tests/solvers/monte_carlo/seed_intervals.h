// The Monte Carlo solvers' statistical check: the mean over independent seeds of each value
// (element and channel) against its expectation, within a two-sided Student-t interval from the
// sample variance over the seeds, Bonferroni-corrected over the values so that the whole check
// holds at confidence 1 - alpha for an unbiased estimator. Seeds are independent runs; the values
// within one run are not, which Bonferroni does not need.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <boost/math/distributions/students_t.hpp>
#include <cmath>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

namespace radlab::testing {

// `run(seed)` gives one run's values for seeds 1..seeds, `expected` their expectation. Returns the
// values whose mean lies outside its interval (each one is also an ADD_FAILURE naming it), and
// prints the largest |mean - expected| / half-width.
inline size_t outside_interval(const std::string& what, int seeds,
                               const std::function<std::vector<double>(int)>& run,
                               const std::vector<double>& expected, double alpha = 1e-3) {
  const size_t m = expected.size();
  std::vector<double> sum(m, 0.0), sum2(m, 0.0);
  for (int seed = 1; seed <= seeds; ++seed) {
    const std::vector<double> values = run(seed);
    EXPECT_EQ(values.size(), m) << what;
    for (size_t k = 0; k < std::min(m, values.size()); ++k) {
      sum[k] += values[k];
      sum2[k] += values[k] * values[k];
    }
  }
  const double t =
      boost::math::quantile(boost::math::students_t(seeds - 1), 1.0 - alpha / (2.0 * double(m)));
  size_t outside = 0;
  double worst = 0.0;
  for (size_t k = 0; k < m; ++k) {
    const double mean = sum[k] / seeds;
    const double variance = std::max(0.0, (sum2[k] - seeds * mean * mean) / (seeds - 1));
    const double half_width = t * std::sqrt(variance / seeds);
    const double deviation = std::abs(mean - expected[k]);
    // Rounding of the sums: a value that no ray reaches (variance 0) must be exact.
    if (deviation > half_width + 1e-12 * std::abs(expected[k])) {
      ++outside;
      ADD_FAILURE() << what << ": value " << k << " mean " << mean << ", expected " << expected[k]
                    << ", interval +-" << half_width;
    }
    if (half_width > 0) worst = std::max(worst, deviation / half_width);
  }
  std::printf("%-44s t = %.3f; %zu of %zu outside; largest |mean - expected| / half-width %.3f\n",
              what.c_str(), t, outside, m, worst);
  return outside;
}

}  // namespace radlab::testing
