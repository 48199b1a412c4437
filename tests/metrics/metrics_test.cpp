// Metrics: the RMS and p-error definitions on hand-computable fields, and the Ceres convergence
// fit recovering a known rate.
#include <gtest/gtest.h>

#include <cmath>

#include "core/random.h"
#include "metrics/convergence_fit.h"
#include "metrics/error_metrics.h"

namespace radlab {
namespace {

TEST(ErrorMetrics, HandComputedRmsAndPError) {
  // Two elements of areas 1 and 3; reference (2, 4); estimate (1, 5).
  Radiosity ref(1, 2), est(1, 2);
  ref.at(0, 0) = 2, ref.at(0, 1) = 4;
  est.at(0, 0) = 1, est.at(0, 1) = 5;
  const std::vector<double> area = {1.0, 3.0};
  ErrorMetrics m = compare(est, ref, area, kMeanOfChannels);
  // rms = sqrt((1*1 + 3*1)/4) = 1; reference rms = sqrt((4 + 48)/4) = sqrt(13).
  EXPECT_DOUBLE_EQ(m.rms, 1.0);
  EXPECT_NEAR(m.rms_rel, 1.0 / std::sqrt(13.0), 1e-15);
  // p = (-0.5, 0.25): mean |p| = (0.5 + 0.75)/4, rms p = sqrt((0.25 + 3*0.0625)/4), max 0.5.
  EXPECT_DOUBLE_EQ(m.p_mean, 1.25 / 4);
  EXPECT_NEAR(m.p_rms, std::sqrt(0.4375 / 4), 1e-15);
  EXPECT_DOUBLE_EQ(m.p_max, 0.5);
  EXPECT_DOUBLE_EQ(m.p_over, 0.75);
  EXPECT_DOUBLE_EQ(m.p_under, 0.25);
  EXPECT_EQ(m.p_excluded, 0u);
}

TEST(ErrorMetrics, DarkElementsAreLeftOutOfPError) {
  Radiosity ref(1, 3), est(1, 3);
  ref.at(0, 0) = 1.0, ref.at(0, 1) = 1e-12, ref.at(0, 2) = 0.0;
  est.at(0, 0) = 1.1, est.at(0, 1) = 1.0, est.at(0, 2) = 0.5;
  ErrorMetrics m = compare(est, ref, std::vector<double>{1, 1, 1}, 0);
  EXPECT_EQ(m.p_excluded, 2u);
  EXPECT_NEAR(m.p_excluded_area, 2.0 / 3.0, 1e-15);
  EXPECT_NEAR(m.p_max, 0.1, 1e-12);
}

TEST(ErrorMetrics, ALitRoomBesideABrightLampIsNotLeftOut) {
  // builtin:tiny-light:size=3e-4 in numbers: a 0.3 mm lamp (9e-8 m^2) of B* = 1e6 and a 94 m^2
  // room lit by its 0.09 W, B* ~ 1e-3. The old rule (1e-9 of max B*: 1e-3) left the room's
  // darker part out of p (208 of 448 elements at --subdiv 8, issue 35.4); here the 60 m^2 at
  // 3e-4. The mean of B* is power per area, 1.6e-3 here (the lamp's 0.09 W and the room's
  // reflection): 1e-9 of it keeps every lit element.
  // A dark element (B* = 0, no light arrives) is still left out, and its area reported.
  Radiosity ref(1, 4), est(1, 4);
  ref.at(0, 0) = 1e6, ref.at(0, 1) = 3e-4, ref.at(0, 2) = 1.5e-3, ref.at(0, 3) = 0.0;
  est.at(0, 0) = 1e6, est.at(0, 1) = 3.75e-4, est.at(0, 2) = 1.5e-3, est.at(0, 3) = 1e-3;
  const std::vector<double> area = {9e-8, 60.0, 30.0, 4.0};
  const ErrorMetrics m = compare(est, ref, area, 0);
  EXPECT_EQ(m.p_excluded, 1u);
  EXPECT_NEAR(m.p_excluded_area, 4.0 / (94.0 + 9e-8), 1e-15);
  // |p| = 0.25 on 60 m^2 of the 90 m^2 (plus the lamp's 9e-8) kept.
  EXPECT_NEAR(m.p_mean, 0.25 * 60.0 / (90.0 + 9e-8), 1e-12);
  EXPECT_NEAR(m.p_max, 0.25, 1e-12);
  std::vector<double> p(4);
  relative_errors(est, ref, area, 0, p);
  EXPECT_NEAR(p[1], 0.25, 1e-12);
  EXPECT_EQ(p[3], 0.0);
}

TEST(ErrorMetrics, MeanOfChannelsAndSingleChannels) {
  Radiosity ref(3, 1), est(3, 1);
  for (int c = 0; c < 3; ++c) ref.at(c, 0) = 1.0 + c, est.at(c, 0) = 1.0 + c + (c == 1 ? 0.3 : 0);
  const std::vector<double> area = {2.0};
  EXPECT_NEAR(compare(est, ref, area, kMeanOfChannels).rms, 0.1, 1e-15);
  EXPECT_NEAR(compare(est, ref, area, 1).rms, 0.3, 1e-15);
  EXPECT_EQ(compare(est, ref, area, 0).rms, 0.0);
}

TEST(ConvergenceFit, RecoversAKnownGeometricRate) {
  // error_k = 3 * 0.97^x with 5% multiplicative noise, at geometric checkpoints.
  Pcg32 rng(11);
  std::vector<double> x, e;
  for (double s = 10; s < 2000; s *= 1.2) {
    x.push_back(std::round(s));
    e.push_back(3.0 * std::pow(0.97, std::round(s)) * (1.0 + 0.05 * (rng.next_double() - 0.5)));
  }
  ConvergenceFit fit = fit_convergence(x, e, 1e-20);
  ASSERT_TRUE(fit.valid) << fit.reason;
  EXPECT_NEAR(fit.rate, 0.97, 1e-4);
  // The predicted x at 1e-20 follows from the true line: (log 1e-20 - log 3) / log 0.97.
  const double truth = (std::log(1e-20) - std::log(3.0)) / std::log(0.97);
  EXPECT_NEAR(fit.x_to_tolerance, truth, std::max(5 * fit.x_to_tolerance_sigma, 0.01 * truth));
  EXPECT_GT(fit.x_to_tolerance_sigma, 0.0);
}

TEST(ConvergenceFit, RobustToAnOutlier) {
  std::vector<double> x, e;
  for (int k = 1; k <= 30; ++k) {
    x.push_back(100.0 * k);
    e.push_back(std::exp(-0.01 * 100.0 * k));
  }
  e[25] *= 1e4;  // a spike (e.g. a transient of an overshooting solver)
  ConvergenceFit fit = fit_convergence(x, e, 1e-12);
  ASSERT_TRUE(fit.valid);
  EXPECT_NEAR(fit.log_rate, -0.01, 5e-4);
}

TEST(ConvergenceFit, RefusesFlatOrShortTraces) {
  std::vector<double> x = {1, 2, 3, 4, 5, 6}, flat = {1, 1, 1, 1, 1, 1};
  EXPECT_FALSE(fit_convergence(x, flat, 1e-3).valid);
  std::vector<double> x2 = {1, 2}, e2 = {1, 0.5};
  EXPECT_FALSE(fit_convergence(x2, e2, 1e-3).valid);
}

}  // namespace
}  // namespace radlab
