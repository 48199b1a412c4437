// Convergence-rate fits with Ceres (DESIGN §6). The tail of an error trace of an iterative solver
// is close to geometric, error ~ C rate^x, so log(error) is fitted by a line a + b x over the
// tail with a robust (Cauchy) loss, which keeps a few outlying checkpoints (a solver's transient,
// rounding floors) from dragging the rate. x is form-factor rows or seconds.
//
// Reported: the rate per unit of x (exp(b)), the x at which the fitted line reaches a tolerance,
// and 1-sigma uncertainties from Ceres' covariance of (a, b) scaled by the residual variance
// (the delta method for the predicted x).
#pragma once

#include <span>
#include <string>

namespace radlab {

struct ConvergenceFit {
  bool valid = false;
  std::string reason;     // why the fit is not valid
  int points = 0;         // checkpoints in the tail
  double log_rate = 0.0;  // b: d log(error) / dx
  double log_rate_sigma = 0.0;
  double intercept = 0.0;       // a
  double rate = 0.0;            // exp(b): error factor per unit of x
  double x_to_tolerance = 0.0;  // where a + b x = log(tolerance)
  double x_to_tolerance_sigma = 0.0;
  double tolerance = 0.0;
};

struct FitOptions {
  double tail_fraction = 0.5;  // fit the checkpoints with x >= (1 - tail_fraction) * max x
  int min_points = 4;
  double loss_scale = 0.5;  // Cauchy loss scale, in natural-log units of error
};

// `x` increasing; `error` > 0 where used (non-positive or non-finite errors are skipped).
ConvergenceFit fit_convergence(std::span<const double> x, std::span<const double> error,
                               double tolerance, const FitOptions& options = {});

}  // namespace radlab
