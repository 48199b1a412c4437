// random-walk (solvers/monte_carlo/random_walk.cpp): determinism per seed and honest counters;
// the mean over 64 seeds agrees with the exact-F system's solution within a confidence interval
// from the sample variance, for shooting and gathering walks and every estimator, on a closed
// box (the furnace) and on an occluded scene (the Cornell box and its two blocks, exact
// form factors with clipped visibility); the error falls as walks^-1/2 (Ceres fit); refused
// reflectances and parameters. Every test is deterministic: fixed seeds, results independent of
// the thread count.
//
// Each walk is an independent unbiased estimate (no averaging bias, unlike stochastic-jacobi), so
// the expectation is the solution of the system with the exact element-to-element F, whatever
// the number of steps.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/limits.h"
#include "formfactor/methods/exact.h"
#include "metrics/convergence_fit.h"
#include "solvers/registry.h"
#include "tests/solver_support.h"
#include "tests/solvers/monte_carlo/matrix_free.h"
#include "tests/solvers/monte_carlo/seed_intervals.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

using testing::matrix_free;

Radiosity run(const System& system, std::vector<std::string> params, int steps) {
  auto solver = testing::make("random-walk", params);
  solver->init(system);
  for (int k = 0; k < steps; ++k)
    if (solver->step().finished) break;
  return solver->solution();
}

const std::vector<std::vector<std::string>> kVariants = {
    {"walks=shooting", "estimator=collision"},   {"walks=shooting", "estimator=absorption"},
    {"walks=shooting", "estimator=survival"},    {"walks=gathering", "estimator=collision"},
    {"walks=gathering", "estimator=absorption"}, {"walks=gathering", "estimator=survival"}};

std::string describe(const std::vector<std::string>& params) {
  std::string s;
  for (const std::string& p : params) s += (s.empty() ? "" : " ") + p;
  return s;
}

// The mean over `seeds` seeds of every value after `steps` steps against `expected`, at
// confidence 99.9% (tests/solvers/monte_carlo/seed_intervals.h). Returns the values outside.
size_t outside_interval(const System& system, const std::vector<std::string>& params, int steps,
                        int seeds, const Radiosity& expected) {
  return testing::outside_interval(describe(params), seeds,
                                   [&](int seed) -> std::vector<double> {
                                     std::vector<std::string> p = params;
                                     p.push_back("seed=" + std::to_string(seed));
                                     const Radiosity B = run(system, p, steps);
                                     return {B.raw().begin(), B.raw().end()};
                                   },
                                   {expected.raw().begin(), expected.raw().end()});
}

TEST(RandomWalk, SameSeedSameBitsAndEveryRayCharged) {
  auto s = matrix_free("cornell", 1);
  for (const auto& variant : kVariants) {
    std::vector<std::string> params = variant;
    params.insert(params.end(), {"paths=2000", "seed=7"});
    s->system->reset_counters();
    auto solver = testing::make("random-walk", params);
    solver->init(*s->system);
    for (int k = 0; k < 3; ++k) solver->step();
    const Radiosity a = solver->solution();
    double rays = 0.0, walks = 0.0;
    for (const auto& [key, value] : solver->statistics()) {
      if (key == "rays") rays = value;
      if (key == "walks") walks = value;
    }
    // Matrix-free: no row read; every ray charged as a ray and as a pair evaluation.
    EXPECT_EQ(s->system->rows_used(), 0u);
    EXPECT_EQ(double(s->system->rays_used()), rays) << describe(variant);
    EXPECT_EQ(s->system->pair_evaluations(), s->system->rays_used());
    EXPECT_EQ(walks, 6000.0);
    EXPECT_GE(rays, walks);  // one ray per walk at least (a black start casts none: none here)
    const Radiosity b = run(*s->system, params, 3);
    params.back() = "seed=8";
    const Radiosity c = run(*s->system, params, 3);
    size_t differ = 0;
    for (size_t k = 0; k < a.raw().size(); ++k) {
      ASSERT_EQ(a.raw()[k], b.raw()[k]) << describe(variant) << " at " << k;
      differ += a.raw()[k] != c.raw()[k] ? 1 : 0;
    }
    EXPECT_GT(differ, a.raw().size() / 2) << describe(variant);
  }
}

TEST(RandomWalk, MeanOverSeedsIsTheSolutionOnTheFurnace) {
  // The furnace (closed box, every face emits 1 and reflects 0.5): F's rows sum to 1, so the
  // exact-F solution is B = E/(1-rho) = 2 everywhere, exactly. 96 elements, 64 seeds of 10^4
  // walks (one step) for each of the six walk/estimator pairs.
  auto s = matrix_free("furnace:rho=0.5", 4);
  const Radiosity expected(1, s->mesh.size(), 2.0);
  for (const auto& variant : kVariants) {
    std::vector<std::string> params = variant;
    params.push_back("paths=10000");
    EXPECT_EQ(outside_interval(*s->system, params, 1, 64, expected), 0u);
  }
}

TEST(RandomWalk, MeanOverSeedsIsTheExactFSolutionOnTheOccludedCornellBox) {
  // The Cornell box's two blocks occlude, its front is open (rays escape) and it is RGB (walks
  // survive by the largest channel's reflectance and reweight the others). The expectation is the
  // solution with the exact F: the `exact` form factors with clipped visibility (tolerance 1e-8
  // per pair, far below the intervals' ~1e-3 relative), solved by the certified reference.
  // 20 elements x 3 channels, 64 seeds of 2 x 10^4 walks (two steps) for each pair.
  auto exact = testing::exact_cornell();
  for (const auto& variant : kVariants) {
    std::vector<std::string> params = variant;
    params.push_back("paths=10000");
    EXPECT_EQ(outside_interval(*exact->system, params, 2, 64, exact->reference.B), 0u);
  }
}

TEST(RandomWalk, ErrorFallsAsTheInverseSquareRootOfTheWalks) {
  // The rms error about the furnace's exact solution against the walks, 10^3 to 1.6 x 10^4 walks
  // (8 seeds each), fitted by Ceres as log rms = a + b log walks (metrics/convergence_fit.h on
  // log x). Independent unbiased walks give b = -1/2. Each rms is over 8 seeds x 96 elements:
  // its relative standard error ~sqrt(1/(2 x 768)) = 2.6%, so the slope's over ln 16 of
  // log-walks is ~0.012; the band [-0.56, -0.44] is 5 of them. A biased estimator flattens
  // (b -> 0) and b = -1/4 or -1 falls outside.
  auto s = matrix_free("furnace:rho=0.5", 4);
  for (const char* walks : {"walks=shooting", "walks=gathering"}) {
    std::vector<double> log_walks, rms;
    for (long long paths : {1000, 2000, 4000, 8000, 16000}) {
      double sum = 0.0;
      size_t count = 0;
      for (int seed = 1; seed <= 8; ++seed) {
        const Radiosity B =
            run(*s->system,
                {walks, "paths=" + std::to_string(paths), "seed=" + std::to_string(100 + seed)}, 1);
        for (double b : B.raw()) {
          sum += (b - 2.0) * (b - 2.0);
          ++count;
        }
      }
      log_walks.push_back(std::log(double(paths)));
      rms.push_back(std::sqrt(sum / double(count)));
    }
    FitOptions options;
    options.tail_fraction = 1.0;  // every point: x = log walks > 0
    const ConvergenceFit fit = fit_convergence(log_walks, rms, 1e-6, options);
    ASSERT_TRUE(fit.valid) << fit.reason;
    std::printf("%s: rms %.4g at 1000 walks, %.4g at 16000; fitted exponent %.3f +- %.3f\n", walks,
                rms.front(), rms.back(), fit.log_rate, fit.log_rate_sigma);
    EXPECT_GT(fit.log_rate, -0.56) << walks;
    EXPECT_LT(fit.log_rate, -0.44) << walks;
    // And the fit's own interval: -1/2 within 3 sigma of the fitted exponent.
    EXPECT_LT(std::abs(fit.log_rate + 0.5), 3.0 * fit.log_rate_sigma + 1e-12) << walks;
  }
}

TEST(RandomWalk, ReflectanceOfOneIsRefusedNamingTheElement) {
  // At rho = 1 walks survive every landing and, in a closed box, never end: refused at init
  // (exit 3), naming the element and the cause, before any ray.
  auto s = matrix_free("furnace:rho=1", 1);
  auto solver = testing::make("random-walk");
  testing::expect_error<InputError>([&] { solver->init(*s->system); },
                                    {"random-walk", "element 0", "reflects 1", "never end"});
  EXPECT_EQ(s->system->rays_used(), 0u);
}

TEST(RandomWalk, BadParametersAreRefusedNamingTheKey) {
  const std::vector<std::string> bad = {"paths=0", "paths=-5",   "paths=nan",           "paths=1.5",
                                        "seed=-1", "walks=both", "estimator=next-event"};
  for (const std::string& item : bad) {
    const std::string key = item.substr(0, item.find('='));
    try {
      testing::make("random-walk", {item});
      ADD_FAILURE() << "accepted " << item;
    } catch (const UsageError& e) {
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
  }
  // Beyond --limits rays=: refused (exit 3) with the limit's key.
  const double saved = limits().rays;
  limits().rays = 1e6;
  testing::expect_error<InputError>([] { testing::make("random-walk", {"paths=2000000"}); },
                                    {"paths=2000000", "--limits rays="});
  testing::expect_error<InputError>([] { testing::make("stochastic-jacobi", {"rays=2000000"}); },
                                    {"rays=2000000", "--limits rays="});
  limits().rays = saved;
}

TEST(RandomWalk, NoEmitterFinishesAtZero) {
  auto s = matrix_free("cube:emission=0", 2);
  for (const char* walks : {"walks=shooting", "walks=gathering"}) {
    auto solver = testing::make("random-walk", {walks});
    solver->init(*s->system);
    s->system->reset_counters();
    EXPECT_TRUE(solver->step().finished) << walks;
    EXPECT_EQ(s->system->rays_used(), 0u);
    for (double b : solver->solution().raw()) EXPECT_EQ(b, 0.0);
  }
}

}  // namespace
}  // namespace radlab
