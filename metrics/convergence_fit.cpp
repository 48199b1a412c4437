#include "metrics/convergence_fit.h"

#include <ceres/ceres.h>

#include <cmath>
#include <vector>

namespace radlab {
namespace {

struct LineResidual {
  LineResidual(double x, double y) : x_(x), y_(y) {}
  template <class T>
  bool operator()(const T* const ab, T* residual) const {
    residual[0] = ab[0] + ab[1] * T(x_) - T(y_);
    return true;
  }
  double x_, y_;
};

}  // namespace

ConvergenceFit fit_convergence(std::span<const double> x, std::span<const double> error,
                               double tolerance, const FitOptions& options) {
  ConvergenceFit fit;
  fit.tolerance = tolerance;
  double x_max = 0.0;
  for (size_t k = 0; k < x.size(); ++k)
    if (std::isfinite(error[k]) && error[k] > 0) x_max = std::max(x_max, x[k]);
  if (!(x_max > 0)) {
    fit.reason = "no positive errors";
    return fit;
  }
  // Normalise x to [0,1] for conditioning; convert back at the end.
  std::vector<double> xs, ys;
  for (size_t k = 0; k < x.size(); ++k) {
    if (!(std::isfinite(error[k]) && error[k] > 0)) continue;
    if (x[k] < (1.0 - options.tail_fraction) * x_max) continue;
    xs.push_back(x[k] / x_max);
    ys.push_back(std::log(error[k]));
  }
  fit.points = int(xs.size());
  if (fit.points < options.min_points) {
    fit.reason = "only " + std::to_string(fit.points) + " checkpoints in the tail";
    return fit;
  }
  // Start from the chord through the first and last tail points.
  double ab[2] = {ys.front(), 0.0};
  if (xs.back() > xs.front()) ab[1] = (ys.back() - ys.front()) / (xs.back() - xs.front());
  ab[0] = ys.front() - ab[1] * xs.front();

  ceres::Problem problem;
  for (size_t k = 0; k < xs.size(); ++k)
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<LineResidual, 1, 2>(new LineResidual(xs[k], ys[k])),
        new ceres::CauchyLoss(options.loss_scale), ab);
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_QR;
  solver_options.max_num_iterations = 100;
  solver_options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);
  if (!summary.IsSolutionUsable()) {
    fit.reason = "Ceres: " + summary.message;
    return fit;
  }

  // Covariance of (a, b), scaled by the residual variance s^2 = sum r^2 / (m - 2).
  ceres::Covariance::Options covariance_options;
  ceres::Covariance covariance(covariance_options);
  std::vector<std::pair<const double*, const double*>> blocks = {{ab, ab}};
  double cov[4] = {0, 0, 0, 0};
  double s2 = 0.0;
  for (size_t k = 0; k < xs.size(); ++k) {
    const double r = ab[0] + ab[1] * xs[k] - ys[k];
    s2 += r * r;
  }
  s2 /= double(xs.size() - 2);
  const bool have_covariance =
      covariance.Compute(blocks, &problem) && covariance.GetCovarianceBlock(ab, ab, cov);

  fit.intercept = ab[0];
  fit.log_rate = ab[1] / x_max;
  fit.rate = std::exp(fit.log_rate);
  if (have_covariance) fit.log_rate_sigma = std::sqrt(std::max(0.0, cov[3] * s2)) / x_max;
  if (!(ab[1] < 0)) {
    fit.reason = "error is not decreasing over the tail";
    return fit;
  }
  const double target = std::log(tolerance);
  const double t = (target - ab[0]) / ab[1];  // normalised x at the tolerance
  fit.x_to_tolerance = t * x_max;
  if (have_covariance) {
    const double da = -1.0 / ab[1];
    const double db = -(target - ab[0]) / (ab[1] * ab[1]);
    const double var = s2 * (da * da * cov[0] + 2 * da * db * cov[1] + db * db * cov[3]);
    fit.x_to_tolerance_sigma = std::sqrt(std::max(0.0, var)) * x_max;
  }
  fit.valid = true;
  return fit;
}

}  // namespace radlab
