// fit_power_law (metrics/power_law_fit.h): exact power laws recovered, and on scattered data the
// exponent and its 1-sigma equal ordinary least squares on log-log axes, computed here in closed
// form (slope = Sxy / Sxx, standard error = sqrt(residual variance / Sxx)).
#include "metrics/power_law_fit.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace radlab {
namespace {

TEST(PowerLawFit, RecoversExactGrowingAndDecayingLaws) {
  const std::vector<double> s = {1952, 3808, 7520, 14944, 29792, 59488, 118880, 200544};
  for (double p : {1.2, 0.75, -0.5, 2.0}) {
    std::vector<double> y;
    for (double v : s) y.push_back(3.0 * std::pow(v, p));
    const PowerLawFit fit = fit_power_law(s, y);
    ASSERT_TRUE(fit.valid) << fit.reason;
    EXPECT_EQ(fit.points, 8);
    // Exact data: only Ceres' convergence and rounding in log/pow remain.
    EXPECT_NEAR(fit.exponent, p, 1e-9);
    EXPECT_NEAR(fit.constant, 3.0, 3.0 * 1e-7);
    EXPECT_LT(fit.exponent_sigma, 1e-7);
  }
}

TEST(PowerLawFit, ScatteredDataGiveTheLeastSquaresSlopeAndStandardError) {
  // y = 5 s^0.9 times a fixed scatter of up to +-30%.
  const std::vector<double> s = {1000, 2000, 4000, 8000, 16000, 32000};
  const std::vector<double> scatter = {1.3, 0.8, 1.1, 0.75, 1.2, 0.9};
  std::vector<double> y;
  for (size_t k = 0; k < s.size(); ++k) y.push_back(5.0 * std::pow(s[k], 0.9) * scatter[k]);
  double mx = 0, my = 0;
  for (size_t k = 0; k < s.size(); ++k) mx += std::log(s[k]), my += std::log(y[k]);
  mx /= double(s.size()), my /= double(s.size());
  double sxx = 0, sxy = 0;
  for (size_t k = 0; k < s.size(); ++k) {
    sxx += (std::log(s[k]) - mx) * (std::log(s[k]) - mx);
    sxy += (std::log(s[k]) - mx) * (std::log(y[k]) - my);
  }
  const double slope = sxy / sxx, intercept = my - slope * mx;
  double ss = 0;
  for (size_t k = 0; k < s.size(); ++k) {
    const double r = std::log(y[k]) - intercept - slope * std::log(s[k]);
    ss += r * r;
  }
  const double sigma = std::sqrt(ss / double(s.size() - 2) / sxx);
  const PowerLawFit fit = fit_power_law(s, y);
  ASSERT_TRUE(fit.valid) << fit.reason;
  // The Cauchy loss at scale 10 weighs a residual r by 1/(1 + (r/10)^2): with |r| <= 0.3 the fit
  // departs from least squares by about (0.3/10)^2 ~ 1e-3 relative, at most.
  EXPECT_NEAR(fit.exponent, slope, 2e-3 * std::abs(slope));
  EXPECT_NEAR(fit.exponent_sigma, sigma, 2e-3 * sigma);
  EXPECT_NEAR(std::log(fit.constant), intercept, 2e-3 * std::abs(intercept));
  EXPECT_GT(fit.exponent_sigma, 0.01);  // the scatter is seen, not fitted away
}

TEST(PowerLawFit, RefusesTooFewPointsAndCountsBelowOne) {
  const std::vector<double> two_s = {10, 100}, two_y = {1, 10};
  EXPECT_FALSE(fit_power_law(two_s, two_y).valid);
  // A non-positive y is skipped, which leaves two points here.
  const std::vector<double> s = {10, 100, 1000}, y = {1, 0, 100};
  const PowerLawFit skipped = fit_power_law(s, y);
  EXPECT_FALSE(skipped.valid);
  EXPECT_EQ(skipped.points, 2);
  const std::vector<double> small = {0.5, 10, 100}, grows = {1, 10, 100};
  const PowerLawFit refused = fit_power_law(small, grows);
  EXPECT_FALSE(refused.valid);
  EXPECT_NE(refused.reason.find("> 1"), std::string::npos);
}

}  // namespace
}  // namespace radlab
