#include "solvers/reference/reference.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <Eigen/Dense>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <memory>

#include "core/error.h"
#include "core/log.h"
#include "core/text.h"
#include "solvers/reference/dense_lu.h"

namespace radlab {
namespace {

using Long = long double;

// gamma_k = k u / (1 - k u), u the unit roundoff of long double: bounds the relative rounding
// error of a sum of k products (Higham, Accuracy and Stability, §3.1).
long double gamma_for(size_t k) {
  const long double u = std::numeric_limits<long double>::epsilon() / 2;
  return Long(k) * u / (1 - Long(k) * u);
}

struct ChannelData {
  std::span<const double> rho, E;
};

// Row sums are accumulated in blocks of kBlock products, then the block sums added: the rounding
// bound is gamma_{kBlock + n/kBlock + 5} (Higham §4.2, blocked summation, plus the product, the
// three operations of b - x + rho sum, and one for the magnitude's own rounding) instead of
// gamma_{n+3}. At n = 10,000 that is 50 times tighter, which is what lets the rho = 0.999 cube
// certify to 1e-12 of max B (the bound is ||(I-J)^-1|| = 1000 times this rounding bound).
constexpr size_t kBlock = 128;

// sum_j row[j] x[j] in long double, summed in blocks of kBlock (the rounding bound's gamma
// above), with the sum of the products' magnitudes in `magnitude`.
template <class T>
long double blocked_dot(const T* row, std::span<const double> x, long double& magnitude) {
  const size_t n = x.size();
  long double sum = 0;
  magnitude = 0;
  for (size_t j0 = 0; j0 < n; j0 += kBlock) {
    long double part = 0, part_magnitude = 0;
    const size_t j1 = std::min(n, j0 + kBlock);
    for (size_t j = j0; j < j1; ++j) {
      const long double p = Long(row[j]) * Long(x[j]);
      part += p;
      part_magnitude += std::abs(p);
    }
    sum += part;
    magnitude += part_magnitude;
  }
  return sum;
}

// r = b - (I - J) x for one channel in long double; returns max_i |r_i| + rounding bound.
double residual(const FormFactorMatrix& F, std::span<const double> rho, std::span<const double> b,
                std::span<const double> x, std::vector<double>* r_out) {
  const size_t n = F.size();
  const long double g = gamma_for(kBlock + n / kBlock + 5);
  if (r_out) r_out->resize(n);
  return tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, n, 16), 0.0,
      [&](const tbb::blocked_range<size_t>& range, double worst) {
        for (size_t i = range.begin(); i != range.end(); ++i) {
          long double sum = 0, magnitude = 0;
          F.visit_row(i, [&](const auto* row) { sum = blocked_dot(row, x, magnitude); });
          const long double r = Long(b[i]) - Long(x[i]) + Long(rho[i]) * sum;
          const long double mag =
              std::abs(Long(b[i])) + std::abs(Long(x[i])) + Long(rho[i]) * magnitude;
          if (r_out) (*r_out)[i] = double(r);
          worst = std::max(worst, double(std::abs(r) + g * mag));
        }
        return worst;
      },
      [](double a, double c) { return std::max(a, c); });
}

// y = (I - J) x in double, rows in parallel.
void apply(const FormFactorMatrix& F, std::span<const double> rho, const std::vector<double>& x,
           std::vector<double>& y) {
  const size_t n = F.size();
  y.resize(n);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 16), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) {
      double sum = 0.0;
      F.visit_row(i, [&](const auto* row) {
        for (size_t j = 0; j < n; ++j) sum += double(row[j]) * x[j];
      });
      y[i] = x[i] - rho[i] * sum;
    }
  });
}

class LinearSolve {
 public:
  virtual ~LinearSolve() = default;
  virtual void solve(const std::vector<double>& b, std::vector<double>& x) = 0;
};

class DenseLu final : public LinearSolve {
  static uint64_t next_build() {
    static std::atomic<uint64_t> count{0};
    return ++count;
  }

 public:
  DenseLu(const FormFactorMatrix& F, std::span<const double> rho)
      : lu_(F.size(), [&, build = next_build()](size_t i, size_t j) {
          // BlockedLu asks row by row on each thread: expand row i once (F.at() on a sparse row
          // is a search per entry). The cache is keyed by this factorisation's number, not the
          // matrix's address, which a later matrix may reuse.
          thread_local std::vector<double> row;
          thread_local size_t row_index = size_t(-1);
          thread_local uint64_t row_build = 0;
          if (row_index != i || row_build != build) {
            row.resize(F.size());
            F.visit_row(i, [&](const auto* values) {
              for (size_t k = 0; k < row.size(); ++k) row[k] = double(values[k]);
            });
            row_index = i;
            row_build = build;
          }
          return (i == j ? 1.0 : 0.0) - rho[i] * row[j];
        }) {}
  void solve(const std::vector<double>& b, std::vector<double>& x) override { lu_.solve(b, x); }

 private:
  BlockedLu
      lu_;  // solvers/reference/dense_lu.h: blocked, parallel, the same bits on any thread count
};

// Restarted GMRES(m) with modified Gram–Schmidt and Givens rotations (Saad & Schultz 1986).
//
// It is the inner solver of iterative refinement, which supplies the accuracy (residuals in long
// double): each solve only has to shrink the residual by `tolerance` (1e-10), which double
// precision reaches even at rho = 0.999. A tighter inner tolerance (1e-14 once) sits below what
// double can reach when ||(I-J)^-1|| is large, and GMRES then spent its restarts on rounding
// noise (94 s at 9,600 elements). A restart that does not lower the residual to 0.9 of the
// previous one ends the solve early for the same reason. The matrix-vector product runs rows in
// parallel, each row summed in a fixed order, so the result does not depend on the thread count.
class Gmres final : public LinearSolve {
 public:
  Gmres(const FormFactorMatrix& F, std::span<const double> rho, double tolerance, std::string label,
        long long& iterations)
      : F_(F),
        rho_(rho),
        tolerance_(tolerance),
        label_(std::move(label)),
        total_iterations_(iterations) {}
  void solve(const std::vector<double>& b, std::vector<double>& x) override {
    const auto start = std::chrono::steady_clock::now();
    const size_t n = b.size();
    const int m = 30;
    x.assign(n, 0.0);
    const double bnorm = norm(b);
    if (bnorm == 0.0) return;
    const double target = tolerance_ * bnorm;
    std::vector<std::vector<double>> V(size_t(m + 1), std::vector<double>(n));
    const auto mm = static_cast<size_t>(m);
    std::vector<double> H((mm + 1) * mm), cs(mm), sn(mm), g(mm + 1);
    std::vector<double> w;
    auto h = [&](int i, int j) -> double& { return H[size_t(i * m + j)]; };
    int iterations = 0, restart = 0;
    double beta = bnorm, previous = std::numeric_limits<double>::infinity();
    for (; restart < 200; ++restart) {
      apply(F_, rho_, x, w);
      for (size_t i = 0; i < n; ++i) V[0][i] = b[i] - w[i];
      beta = norm(V[0]);
      if (beta <= target || !(beta < 0.9 * previous)) break;  // done, or stalled on rounding
      previous = beta;
      for (double& v : V[0]) v /= beta;
      std::fill(g.begin(), g.end(), 0.0);
      g[0] = beta;
      int k = 0;
      for (; k < m; ++k) {
        ++iterations;
        apply(F_, rho_, V[size_t(k)], w);
        for (int i = 0; i <= k; ++i) {
          h(i, k) = dot(w, V[size_t(i)]);
          for (size_t t = 0; t < n; ++t) w[t] -= h(i, k) * V[size_t(i)][t];
        }
        h(k + 1, k) = norm(w);
        if (h(k + 1, k) > 0)
          for (size_t t = 0; t < n; ++t) V[size_t(k + 1)][t] = w[t] / h(k + 1, k);
        for (int i = 0; i < k; ++i) {
          const double a = cs[size_t(i)] * h(i, k) + sn[size_t(i)] * h(i + 1, k);
          h(i + 1, k) = -sn[size_t(i)] * h(i, k) + cs[size_t(i)] * h(i + 1, k);
          h(i, k) = a;
        }
        const double r = std::hypot(h(k, k), h(k + 1, k));
        cs[size_t(k)] = h(k, k) / r;
        sn[size_t(k)] = h(k + 1, k) / r;
        h(k, k) = r;
        h(k + 1, k) = 0.0;
        g[size_t(k + 1)] = -sn[size_t(k)] * g[size_t(k)];
        g[size_t(k)] = cs[size_t(k)] * g[size_t(k)];
        if (std::abs(g[size_t(k + 1)]) <= target) {
          ++k;
          break;
        }
      }
      // Back substitution for the Krylov coefficients, then update x.
      std::vector<double> y(static_cast<size_t>(k));
      for (int i = k - 1; i >= 0; --i) {
        double s = g[size_t(i)];
        for (int j = i + 1; j < k; ++j) s -= h(i, j) * y[size_t(j)];
        y[size_t(i)] = s / h(i, i);
      }
      for (int i = 0; i < k; ++i)
        for (size_t t = 0; t < n; ++t) x[t] += y[size_t(i)] * V[size_t(i)][t];
      if (!std::isfinite(x[0])) return;
    }
    total_iterations_ += iterations;
    char line[200];
    std::snprintf(line, sizeof line,
                  "reference: GMRES(30) %s: %d iterations, %d cycles, relative residual %.2g, "
                  "%.1f s",
                  label_.c_str(), iterations, restart, beta / bnorm,
                  std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    log::info(line);
  }

 private:
  static double dot(const std::vector<double>& a, const std::vector<double>& b) {
    double s = 0.0;
    for (size_t i = 0; i < a.size(); ++i) s += a[i] * b[i];
    return s;
  }
  static double norm(const std::vector<double>& a) { return std::sqrt(dot(a, a)); }
  const FormFactorMatrix& F_;
  std::span<const double> rho_;
  double tolerance_;
  std::string label_;
  long long& total_iterations_;
};

std::vector<double> row_sums(const FormFactorMatrix& F) {
  std::vector<double> sums(F.size());
  tbb::parallel_for(size_t(0), F.size(), [&](size_t i) {
    double s = 0.0;
    F.visit_row(i, [&](const auto* row) {
      for (size_t j = 0; j < F.size(); ++j) s += double(row[j]);
    });
    sums[i] = s;
  });
  return sums;
}

// Collatz–Wielandt: for non-negative J and x >= 0, x != 0:
//   min_{x_i>0} (Jx)_i / x_i <= rho(J) <= max_i (Jx)_i / x_i  (the upper bound needs x > 0).
// Power iteration tightens both. Returns {lower, upper}.
//
// An element that sees nothing (a floor element under a box) drops to x_i = 0 after one step,
// and an upper bound that needs x > 0 would then stay at its first value, q. So the iterate is
// floored at kFloor (relative to its maximum 1): any positive x gives a valid upper bound. The
// lower bound uses x' = x with the floored entries set to 0, for which
// (Jx')_i >= (Jx)_i - kFloor * rho_i * sum_j F_ij, over the entries that are not floored.
std::pair<double, double> collatz_wielandt(const FormFactorMatrix& F, std::span<const double> rho,
                                           int iterations, bool stop_at_one) {
  constexpr double kFloor = 1e-12;
  const size_t n = F.size();
  const std::vector<double> sums = row_sums(F);
  std::vector<double> x(n, 1.0), y(n);
  std::vector<char> floored(n, 0);
  bool any_floored = false;
  double lower = 0.0, upper = std::numeric_limits<double>::infinity();
  for (int k = 0; k < iterations; ++k) {
    apply(F, rho, x, y);  // y = x - Jx
    double lo = std::numeric_limits<double>::infinity(), hi = 0.0, scale = 0.0;
    for (size_t i = 0; i < n; ++i) {
      const double jx = x[i] - y[i];
      hi = std::max(hi, jx / x[i]);
      if (!floored[i]) {
        const double lost = any_floored ? kFloor * rho[i] * sums[i] : 0.0;
        lo = std::min(lo, std::max(0.0, jx - lost) / x[i]);
      }
      y[i] = jx;
      scale = std::max(scale, jx);
    }
    lower = std::max(lower, std::isfinite(lo) ? lo : 0.0);
    upper = std::min(upper, hi);
    if (scale <= 0.0) return {0.0, 0.0};
    for (size_t i = 0; i < n; ++i) {
      x[i] = y[i] / scale;
      floored[i] = x[i] < kFloor;
      any_floored = any_floored || floored[i];
      if (floored[i]) x[i] = kFloor;
    }
    if (stop_at_one && (lower >= 1.0 || upper < 1.0)) break;
    if (upper - lower <= 1e-9 * upper) break;
  }
  return {lower, upper};
}

}  // namespace

SpectralRadiusBounds spectral_radius_bounds(const FormFactorMatrix& matrix,
                                            std::span<const double> rho, int iterations) {
  auto [lower, upper] = collatz_wielandt(matrix, rho, iterations, false);
  return {lower, upper};
}

std::vector<double> residual_inf(const System& system, const FormFactorMatrix& matrix,
                                 const Radiosity& B) {
  std::vector<double> out;
  for (int c = 0; c < B.channels(); ++c)
    out.push_back(residual(matrix, system.reflectance().channel(c), system.emission().channel(c),
                           B.channel(c), nullptr));
  return out;
}

Reference compute_reference(const System& system, const FormFactorMatrix& F,
                            const ReferenceOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const size_t n = system.size();
  const int channels = system.channels();
  Reference ref;
  ref.B = Radiosity(channels, n);
  ref.method = n <= options.dense_limit ? "dense LU" : "GMRES(30)";
  const std::vector<double> sums = row_sums(F);
  const double min_row_sum = *std::min_element(sums.begin(), sums.end());
  const char* names[] = {"r", "g", "b"};
  double max_B_all = 0.0;

  for (int c = 0; c < channels; ++c) {
    const std::string channel = channels == 1 ? std::string("grey") : names[c];
    auto rho = system.reflectance().channel(c);
    auto E = system.emission().channel(c);
    double q = 0.0;
    bool all_reflect = true;
    for (size_t i = 0; i < n; ++i) {
      q = std::max(q, rho[i] * sums[i]);
      all_reflect = all_reflect && rho[i] == 1.0;
    }
    ref.q = std::max(ref.q, q);
    // A closed scene (no row loses more than 1% to escape) where everything reflects all light:
    // emitted power is never absorbed, radiosity grows without bound.
    if (all_reflect && min_row_sum > 0.99)
      throw NumericalError(
          "no finite solution in channel " + channel +
          ": every element has reflectance 1 in a closed scene (row sums of F >= " +
          std::to_string(min_row_sum) +
          "), so emitted light is never absorbed; lower a reflectance");
    double radius_upper = q;
    if (q >= 1.0) {
      auto [lower, upper] = collatz_wielandt(F, rho, 60, true);
      radius_upper = upper;
      if (lower >= 1.0)
        throw NumericalError("no finite solution in channel " + channel +
                             ": the spectral radius of diag(rho)F is at least " +
                             std::to_string(lower) + " (Collatz-Wielandt bound)");
    }
    ref.spectral_radius_upper = std::max(ref.spectral_radius_upper, radius_upper);

    std::unique_ptr<LinearSolve> solver;
    if (n <= options.dense_limit)
      solver = std::make_unique<DenseLu>(F, rho);
    else
      solver = std::make_unique<Gmres>(F, rho, options.gmres_tolerance, "channel " + channel,
                                       ref.gmres_iterations);

    // Certified bound on ||(I-J)^-1||_inf from w ~ (I-J)^-1 1 (see the header).
    std::vector<double> ones(n, 1.0), w, s, d;
    solver->solve(ones, w);
    double s_norm = residual(F, rho, ones, w, &s);
    solver->solve(s, d);
    for (size_t i = 0; i < n; ++i) w[i] += d[i];
    s_norm = residual(F, rho, ones, w, nullptr);
    double inverse_norm = std::numeric_limits<double>::infinity();
    if (q < 1.0) inverse_norm = 1.0 / (1.0 - q);
    const bool w_positive = std::all_of(w.begin(), w.end(), [](double v) { return v > 0.0; });
    if (w_positive && s_norm < 1.0) {
      const double w_norm = *std::max_element(w.begin(), w.end());
      inverse_norm = std::min(inverse_norm, w_norm / (1.0 - s_norm));
    }
    if (!std::isfinite(inverse_norm))
      throw NumericalError("no certified solution in channel " + channel +
                           ": (I - diag(rho)F) is singular or nearly so (spectral radius of "
                           "diag(rho)F close to 1); the scene may absorb no light");
    ref.inverse_norm_bound = std::max(ref.inverse_norm_bound, inverse_norm);
    ref.channel_inverse_norm.push_back(inverse_norm);

    // Solve and refine.
    std::vector<double> x, r;
    std::vector<double> e(E.begin(), E.end());
    solver->solve(e, x);
    double max_B = 0.0;
    double r_norm = residual(F, rho, E, x, &r);
    double bound = r_norm * inverse_norm;
    for (int k = 0; k < options.max_refinements; ++k) {
      max_B = 0.0;
      for (double v : x) max_B = std::max(max_B, std::abs(v));
      if (!std::isfinite(bound) || bound <= options.target * max_B) break;
      solver->solve(r, d);
      for (size_t i = 0; i < n; ++i) x[i] += d[i];
      const double previous = r_norm;
      r_norm = residual(F, rho, E, x, &r);
      bound = r_norm * inverse_norm;
      ++ref.refinements;
      if (r_norm > 0.5 * previous) break;  // refinement has stopped paying
    }
    max_B = 0.0;
    for (double v : x) max_B = std::max(max_B, std::abs(v));
    for (size_t i = 0; i < n; ++i) {
      if (!std::isfinite(x[i]))
        throw NumericalError("reference: non-finite radiosity at element " + std::to_string(i) +
                             " in channel " + channel);
      ref.B.at(c, i) = x[i];
    }
    if (!(bound <= options.acceptable * std::max(max_B, 1e-300)))
      throw NumericalError("reference: could not certify channel " + channel + ": bound " +
                           std::to_string(bound) + " exceeds " +
                           text::format_double(options.acceptable) +
                           " of max B = " + std::to_string(max_B));
    ref.bound_inf = std::max(ref.bound_inf, bound);
    ref.residual_inf = std::max(ref.residual_inf, r_norm);
    max_B_all = std::max(max_B_all, max_B);
  }
  ref.bound_relative = max_B_all > 0 ? ref.bound_inf / max_B_all : 0.0;
  ref.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return ref;
}

namespace {

// One pass over rows fetched by `row_of(i, row)` (n doubles): the residual per channel, every row's
// sum and emission-weighted sum. Shared by rows on the fly and rows of a matrix in memory.
StreamedCheck check_rows(const System& system, const Radiosity& B,
                         const std::function<void(size_t, std::vector<double>&)>& row_of) {
  const size_t n = system.size();
  const int channels = B.channels();
  const long double g = gamma_for(kBlock + n / kBlock + 5);
  StreamedCheck out;
  out.row_sum.assign(n, 0.0);
  out.emitter_sum.assign(n, 0.0);
  std::vector<double> emission(n, 0.0);
  for (int c = 0; c < system.channels(); ++c)
    for (size_t i = 0; i < n; ++i) emission[i] += system.emission().at(c, i);
  std::vector<size_t> emitters;
  for (size_t i = 0; i < n; ++i)
    if (emission[i] > 0) emitters.push_back(i);
  using Worst = std::vector<double>;
  out.residual = tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, n, 4), Worst(size_t(channels), 0.0),
      [&](const tbb::blocked_range<size_t>& range, Worst worst) {
        thread_local std::vector<double> row;
        row.resize(n);
        for (size_t i = range.begin(); i != range.end(); ++i) {
          row_of(i, row);
          double sum = 0.0, emitted = 0.0;
          for (size_t j = 0; j < n; ++j) sum += row[j];
          for (size_t j : emitters) emitted += emission[j] * row[j];
          out.row_sum[i] = sum;
          out.emitter_sum[i] = emitted;
          // The arithmetic of residual() above, term for term.
          for (int c = 0; c < channels; ++c) {
            const auto x = B.channel(c);
            const double b = system.emission().at(c, i), rho = system.reflectance().at(c, i);
            long double magnitude = 0;
            const long double total = blocked_dot(row.data(), x, magnitude);
            const long double r = Long(b) - Long(x[i]) + Long(rho) * total;
            const long double mag =
                std::abs(Long(b)) + std::abs(Long(x[i])) + Long(rho) * magnitude;
            worst[size_t(c)] = std::max(worst[size_t(c)], double(std::abs(r) + g * mag));
          }
        }
        return worst;
      },
      [](Worst a, const Worst& c) {
        for (size_t k = 0; k < a.size(); ++k) a[k] = std::max(a[k], c[k]);
        return a;
      });
  return out;
}

}  // namespace

StreamedCheck streamed_check(const System& system, const FormFactorMethod& method,
                             const Radiosity& B) {
  return check_rows(system, B, [&](size_t i, std::vector<double>& row) {
    RowCost cost;
    method.row(i, row, cost);
  });
}

StreamedCheck matrix_check(const System& system, const FormFactorMatrix& matrix,
                           const Radiosity& B) {
  return check_rows(system, B, [&](size_t i, std::vector<double>& row) {
    matrix.visit_row(i, [&](const auto* f) {
      for (size_t j = 0; j < row.size(); ++j) row[j] = static_cast<double>(f[j]);
    });
  });
}

void recertify_reference(const System& system, const FormFactorMatrix& matrix, Reference& ref,
                         const ReferenceOptions& options) {
  if (ref.B.channels() != system.channels() || ref.B.size() != system.size())
    throw NumericalError("reference: the stored solution does not fit this system");
  recertify_reference(system, residual_inf(system, matrix, ref.B), ref, options);
}

void recertify_reference(const System& system, const std::vector<double>& residuals, Reference& ref,
                         const ReferenceOptions& options) {
  const int channels = system.channels();
  if (ref.B.channels() != channels || ref.B.size() != system.size() ||
      int(ref.channel_inverse_norm.size()) != channels || int(residuals.size()) != channels)
    throw NumericalError("reference: the stored solution does not fit this system");
  ref.bound_inf = ref.residual_inf = 0.0;
  double max_B_all = 0.0;
  for (int c = 0; c < channels; ++c) {
    double max_B = 0.0;
    for (double v : ref.B.channel(c)) {
      if (!std::isfinite(v)) throw NumericalError("reference: stored radiosity is not finite");
      max_B = std::max(max_B, std::abs(v));
    }
    const double bound = residuals[size_t(c)] * ref.channel_inverse_norm[size_t(c)];
    if (!(bound <= options.acceptable * std::max(max_B, 1e-300)))
      throw NumericalError("reference: the stored solution's bound " + std::to_string(bound) +
                           " exceeds " + text::format_double(options.acceptable) + " of max B");
    ref.bound_inf = std::max(ref.bound_inf, bound);
    ref.residual_inf = std::max(ref.residual_inf, residuals[size_t(c)]);
    max_B_all = std::max(max_B_all, max_B);
  }
  ref.bound_relative = max_B_all > 0 ? ref.bound_inf / max_B_all : 0.0;
}

void bound_storage_rounding(const System& system, const FormFactorMatrix& certified,
                            const FormFactorMatrix& stored, Reference& ref) {
  const size_t n = system.size();
  const int channels = system.channels();
  struct Row {
    long double product = 0.0L, norm = 0.0L;  // max over channels of |dJ B_ref|_i, (|dJ| 1)_i
  };
  std::vector<Row> rows(n);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 16), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i < r.end(); ++i)
      certified.visit_row(i, [&](const auto* f) {
        stored.visit_row(i, [&](const auto* g) {
          long double absolute = 0.0L, product[3] = {0.0L, 0.0L, 0.0L};
          for (size_t j = 0; j < n; ++j) {
            const long double d = static_cast<long double>(g[j]) - static_cast<long double>(f[j]);
            if (d == 0.0L) continue;
            absolute += std::fabs(d);
            for (int c = 0; c < channels; ++c)
              product[c] += d * static_cast<long double>(ref.B.at(c, j));
          }
          for (int c = 0; c < channels; ++c) {
            const long double rho = system.reflectance().at(c, i);
            rows[i].product = std::max(rows[i].product, rho * std::fabs(product[c]));
            rows[i].norm = std::max(rows[i].norm, rho * absolute);
          }
        });
      });
  });
  long double product = 0.0L, norm = 0.0L;
  for (const Row& row : rows) {
    product = std::max(product, row.product);
    norm = std::max(norm, row.norm);
  }
  const long double N = ref.inverse_norm_bound;
  // The long-double sums of n terms are within n * 2^-64 of exact, relative: 1e-12 covers it.
  const long double numerator =
      N * (product + norm * static_cast<long double>(ref.bound_inf)) * (1.0L + 1e-12L);
  const long double shrink = 1.0L - N * norm * (1.0L + 1e-12L);
  ref.float_storage_bound =
      shrink > 0.0L ? double(numerator / shrink) : std::numeric_limits<double>::infinity();
  double top = 0.0;
  for (double b : ref.B.raw()) top = std::max(top, b);
  ref.float_storage_bound_relative =
      top > 0 ? ref.float_storage_bound / top : ref.float_storage_bound;
}

std::string Reference::summary() const {
  char buffer[300];
  std::snprintf(buffer, sizeof buffer,
                "certified ||B - B*||_inf <= %.3g (%.3g of max B); residual %.3g, "
                "||(I-J)^-1||_inf <= %.6g, q = %.9g; %s, %d refinements, %.2f s",
                bound_inf, bound_relative, residual_inf, inverse_norm_bound, q, method.c_str(),
                refinements, seconds);
  std::string text =
      system.empty() ? std::string(buffer) : std::string(buffer) + "; system: " + system;
  if (!std::isnan(float_storage_bound)) {
    std::snprintf(buffer, sizeof buffer,
                  "; the float system the solvers read has its own solution within %.3g (%.3g of "
                  "max B) of B*: their floor",
                  float_storage_bound, float_storage_bound_relative);
    text += buffer;
  }
  return text;
}

}  // namespace radlab
