#include "metrics/power_law_fit.h"

#include <cmath>
#include <string>
#include <vector>

#include "metrics/convergence_fit.h"

namespace radlab {

PowerLawFit fit_power_law(std::span<const double> s, std::span<const double> y) {
  PowerLawFit result;
  std::vector<double> x, error;
  for (size_t k = 0; k < s.size() && k < y.size(); ++k) {
    if (!(std::isfinite(y[k]) && y[k] > 0)) continue;
    if (!(std::isfinite(s[k]) && s[k] > 1)) {
      result.reason = "s must be finite and > 1 (its logarithm is the fit's positive abscissa)";
      return result;
    }
    x.push_back(std::log(s[k]));
    error.push_back(y[k]);
  }
  // fit_convergence fits decreasing errors: a growing y is given as 1/y, whose log slope is -p.
  const bool growing = error.size() >= 2 && error.back() > error.front();
  if (growing)
    for (double& e : error) e = 1.0 / e;
  FitOptions options;
  options.tail_fraction = 1.0;
  options.min_points = 3;
  options.loss_scale = 10.0;
  const ConvergenceFit fit = fit_convergence(x, error, 1.0, options);
  result.points = fit.points;
  if (!fit.valid) {
    result.reason = fit.points < options.min_points
                        ? "only " + std::to_string(fit.points) + " points with y > 0 (3 needed)"
                        : fit.reason;
    return result;
  }
  const double sign = growing ? -1.0 : 1.0;
  result.exponent = sign * fit.log_rate;
  result.exponent_sigma = fit.log_rate_sigma;
  result.constant = std::exp(sign * fit.intercept);
  result.valid = true;
  return result;
}

}  // namespace radlab
