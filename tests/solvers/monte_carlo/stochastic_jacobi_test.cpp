// stochastic-jacobi (solvers/monte_carlo/): determinism per seed, the estimator's expectation on
// the furnace within a confidence interval from the sample variance over 64 seeds, the N^-1/2
// fall of its error, Sobol' ahead of pseudo-random numbers, the control variate, and refused
// parameters. Every test is deterministic: fixed seeds, results independent of thread count.
//
// The furnace (builtin:furnace: a closed box, every face emits E and reflects rho) makes the
// expectation exact and known: F's rows sum to 1 and every ray lands, so every Jacobi iterate
// from a uniform start is uniform, b' = E + rho b. After k incremental steps the expectation is
// E (1 + rho + ... + rho^k), and the regular iterates' expectations follow b' = E + rho b from
// there (solvers/monte_carlo/stochastic_jacobi.cpp, "Bias"): the test compares with exactly the
// deterministic Jacobi iterates the estimator estimates, not with the limit E/(1-rho).

#include <gtest/gtest.h>

#include <boost/math/distributions/students_t.hpp>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "core/error.h"
#include "solvers/registry.h"
#include "tests/solver_support.h"
#include "tests/solvers/monte_carlo/matrix_free.h"

namespace radlab {
namespace {

using testing::matrix_free;

struct RunResult {
  Radiosity solution;
  long long incremental_steps = 0;
};

RunResult run(const System& system, std::vector<std::string> params, int steps) {
  auto solver = testing::make("stochastic-jacobi", params);
  solver->init(system);
  for (int k = 0; k < steps; ++k)
    if (solver->step().finished) break;
  RunResult r{solver->solution(), 0};
  for (const auto& [key, value] : solver->statistics())
    if (key == "incremental_steps") r.incremental_steps = static_cast<long long>(value);
  return r;
}

// The expectation of the solution on the furnace after `steps` steps of which `incremental`
// were incremental: the mean of the regular Jacobi iterates (see the top).
double furnace_expectation(double E, double rho, long long incremental, int steps) {
  double b = 0.0, term = E;
  for (long long m = 0; m <= incremental; ++m, term *= rho) b += term;
  const long long regular = steps - incremental;
  if (regular <= 0) return b;
  double sum = 0.0;
  for (long long m = 0; m < regular; ++m) {
    b = E + rho * b;
    sum += b;
  }
  return sum / double(regular);
}

constexpr double kRho = 0.5, kE = 1.0;
const char* const kFurnace = "furnace:rho=0.5";

// The root mean square, over elements and seeds, of the solution's departure from its
// expectation on the furnace, with `rays` rays per step.
double furnace_rms_error(const System& system, const std::vector<std::string>& extra,
                         long long rays, int steps, int seeds) {
  double sum = 0.0;
  size_t count = 0;
  for (int seed = 1; seed <= seeds; ++seed) {
    std::vector<std::string> params = extra;
    params.push_back("rays=" + std::to_string(rays));
    params.push_back("seed=" + std::to_string(seed));
    const RunResult r = run(system, params, steps);
    const double expected = furnace_expectation(kE, kRho, r.incremental_steps, steps);
    for (double b : r.solution.raw()) {
      sum += (b - expected) * (b - expected);
      ++count;
    }
  }
  return std::sqrt(sum / double(count));
}

TEST(StochasticJacobi, SameSeedSameBitsOtherSeedOtherBits) {
  auto s = matrix_free("cornell", 2);
  for (const char* sequence : {"sequence=pseudo", "sequence=sobol"}) {
    s->system->reset_counters();
    const RunResult a = run(*s->system, {"rays=3000", "seed=7", sequence}, 12);
    // Matrix-free: no row read, every ray charged as a ray and as a pair evaluation.
    EXPECT_EQ(s->system->rows_used(), 0u);
    EXPECT_EQ(s->system->rays_used(), 12u * 3000u) << sequence;
    EXPECT_EQ(s->system->pair_evaluations(), 12u * 3000u) << sequence;
    const RunResult b = run(*s->system, {"rays=3000", "seed=7", sequence}, 12);
    const RunResult c = run(*s->system, {"rays=3000", "seed=8", sequence}, 12);
    ASSERT_EQ(a.solution.raw().size(), b.solution.raw().size());
    size_t differ = 0;
    for (size_t k = 0; k < a.solution.raw().size(); ++k) {
      ASSERT_EQ(a.solution.raw()[k], b.solution.raw()[k]) << sequence << " at " << k;
      differ += a.solution.raw()[k] != c.solution.raw()[k] ? 1 : 0;
    }
    // Another seed moves (almost) every value: at least half of them, of the lit ones.
    EXPECT_GT(differ, a.solution.raw().size() / 2) << sequence;
  }
}

TEST(StochasticJacobi, MeanOverSeedsIsTheJacobiIterateOnTheFurnace) {
  // 96 elements, 64 seeds, 20 steps of 10^4 rays. For each element, the mean over seeds must lie
  // within t * s / sqrt(64) of the expectation, s the sample standard deviation over seeds and t
  // Student's quantile with 63 degrees of freedom at 1 - alpha / (2n): a two-sided interval per
  // element with Bonferroni's correction, so the whole test holds at confidence 1 - alpha =
  // 99.9% for a correct estimator (the runs are independent across seeds; elements within a run
  // are not, which Bonferroni does not need).
  auto s = matrix_free(kFurnace, 4);
  const size_t n = s->mesh.size();
  const int seeds = 64, steps = 20;
  std::vector<double> sum(n, 0.0), sum2(n, 0.0);
  double expected = 0.0;
  for (int seed = 1; seed <= seeds; ++seed) {
    const RunResult r = run(*s->system, {"rays=10000", "seed=" + std::to_string(seed)}, steps);
    ASSERT_LT(r.incremental_steps, steps) << "the regular phase must be reached";
    expected += furnace_expectation(kE, kRho, r.incremental_steps, steps) / seeds;
    for (size_t i = 0; i < n; ++i) {
      sum[i] += r.solution.at(0, i);
      sum2[i] += r.solution.at(0, i) * r.solution.at(0, i);
    }
  }
  const double alpha = 1e-3;
  const boost::math::students_t t_distribution(seeds - 1);
  const double t = boost::math::quantile(t_distribution, 1.0 - alpha / (2.0 * double(n)));
  size_t outside = 0;
  for (size_t i = 0; i < n; ++i) {
    const double mean = sum[i] / seeds;
    const double variance = (sum2[i] - seeds * mean * mean) / (seeds - 1);
    const double half_width = t * std::sqrt(std::max(variance, 0.0) / seeds);
    ASSERT_GT(half_width, 0.0) << "a Monte Carlo estimate with no variance at element " << i;
    if (std::abs(mean - expected) > half_width) {
      ++outside;
      ADD_FAILURE() << "element " << i << ": mean " << mean << ", expected " << expected
                    << ", interval +-" << half_width;
    }
  }
  std::printf("expectation %.6f; t = %.3f; %zu of %zu elements outside their interval\n", expected,
              t, outside, n);
  EXPECT_EQ(outside, 0u);
  // And the expectation itself is within 1% of the furnace's B = E/(1-rho): the incremental
  // phase's deficit (at most 1% of the power at the switch), diluted by the averaging.
  EXPECT_NEAR(expected, kE / (1.0 - kRho), 1e-2 * kE / (1.0 - kRho));
}

TEST(StochasticJacobi, ErrorFallsAsTheInverseSquareRootOfTheRays) {
  // Sixteen times the rays: the rms error about the expectation falls by sqrt(16) = 4 for an
  // unbiased estimator with independent rays. The band [3.2, 5] (fitted exponents 0.42 to 0.58)
  // allows for the sampling error of two rms estimates over 8 seeds x 96 elements (the squared
  // errors' relative standard error is ~sqrt(2/768) = 5%, so each rms's ~2.5% and the ratio's
  // ~4%: the band is more than 4 standard errors wide on each side); a biased estimator stalls
  // (ratio -> 1) and an exponent of -1/4 or -1 gives 2 or 16.
  auto s = matrix_free(kFurnace, 4);
  const double coarse = furnace_rms_error(*s->system, {}, 1000, 20, 8);
  const double fine = furnace_rms_error(*s->system, {}, 16000, 20, 8);
  const double ratio = coarse / fine;
  std::printf("rms error about the expectation: %.4g at 1000 rays, %.4g at 16000; ratio %.3f\n",
              coarse, fine, ratio);
  EXPECT_GT(ratio, 3.2) << coarse << " / " << fine;
  EXPECT_LT(ratio, 5.0) << coarse << " / " << fine;
}

TEST(StochasticJacobi, SobolBeatsPseudoRandomAtEqualRays) {
  // Randomised quasi-Monte Carlo (shifted Sobol' points) on the furnace: same rays, same steps,
  // same seeds; the rms error about the expectation must be lower than with PCG32 numbers.
  auto s = matrix_free(kFurnace, 4);
  const double pseudo = furnace_rms_error(*s->system, {"sequence=pseudo"}, 4000, 20, 8);
  const double sobol = furnace_rms_error(*s->system, {"sequence=sobol"}, 4000, 20, 8);
  std::printf("rms error at 4000 rays: pseudo %.4g, sobol %.4g (ratio %.3f)\n", pseudo, sobol,
              sobol / pseudo);
  EXPECT_LT(sobol, pseudo);
}

TEST(StochasticJacobi, ControlVariateLowersTheErrorOnTheFurnace) {
  // On the furnace every B_i is the same number in expectation: with beta the area-weighted
  // median, the regular steps propagate only B - beta, the noise of the incremental start, and
  // the rest, beta rho S~ with S~ = 1 exactly (a closed box), carries no variance. The error must
  // at least halve (measured: see docs/solvers.md).
  auto s = matrix_free(kFurnace, 4);
  const double without = furnace_rms_error(*s->system, {"control_variate=false"}, 4000, 20, 8);
  const double with = furnace_rms_error(*s->system, {"control_variate=true"}, 4000, 20, 8);
  std::printf("rms error at 4000 rays: without control variate %.4g, with %.4g (ratio %.3f)\n",
              without, with, with / without);
  EXPECT_LT(with, 0.5 * without);
}

TEST(StochasticJacobi, BadParametersAreRefusedNamingTheKey) {
  const std::vector<std::string> bad = {"rays=0",
                                        "rays=-5",
                                        "rays=nan",
                                        "rays=1.5",
                                        "seed=-1",
                                        "sequence=halton",
                                        "control_variate=nan",
                                        "control_variate=-1",
                                        "control_variate=maybe",
                                        "control_variate=inf"};
  for (const std::string& item : bad) {
    const std::string key = item.substr(0, item.find('='));
    try {
      testing::make("stochastic-jacobi", {item});
      ADD_FAILURE() << "accepted " << item;
    } catch (const UsageError& e) {
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
  }
  // Accepted forms of the control variate.
  for (const char* good : {"control_variate=true", "control_variate=false", "control_variate=0.5"})
    EXPECT_NO_THROW(testing::make("stochastic-jacobi", {good})) << good;
}

TEST(StochasticJacobi, NoEmitterFinishesAtZeroLikeTheDeterministicSolvers) {
  // No emission: B = 0 solves the system; jacobi and shooting stop with it, and so does this
  // solver, at once and without casting a ray.
  auto s = matrix_free("cube:emission=0", 2);
  auto solver = testing::make("stochastic-jacobi");
  solver->init(*s->system);
  s->system->reset_counters();
  EXPECT_TRUE(solver->step().finished);
  EXPECT_EQ(s->system->rays_used(), 0u);
  for (double b : solver->solution().raw()) EXPECT_EQ(b, 0.0);
  auto shooting = testing::make("shooting");
  shooting->init(*s->system);
  EXPECT_TRUE(shooting->step().finished);
}

}  // namespace
}  // namespace radlab
