// Growth exponents: y ~ C s^p fitted to measured (s, y), e.g. links or seconds against the
// polygon count of a scaling family (issue 33). It is the Ceres line fit of convergence_fit.h on
// log-log axes (log y = log C + p log s), with every point used and a wide Cauchy scale (10 in
// natural-log units), so it is least squares unless a point is off by orders of magnitude, and the
// 1-sigma of p from Ceres' covariance scaled by the residual variance (the OLS standard error).
#pragma once

#include <span>
#include <string>

namespace radlab {

struct PowerLawFit {
  bool valid = false;
  std::string reason;  // why the fit is not valid
  int points = 0;
  double exponent = 0.0;  // p
  double exponent_sigma = 0.0;
  double constant = 0.0;  // C
};

// `s` increasing, every s > 1 and y > 0 (a point with y <= 0 or non-finite is skipped); at least
// three points, since two define the line exactly and leave no residual to estimate sigma from.
PowerLawFit fit_power_law(std::span<const double> s, std::span<const double> y);

}  // namespace radlab
