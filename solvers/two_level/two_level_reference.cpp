// Certified reference of the two-level system by its rank-P reduction (see two_level_reference.h).
#include "solvers/two_level/two_level_reference.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>

#include "core/error.h"

namespace radlab {
namespace {

using Long = long double;

// gamma_k = k u / (1 - k u), u the unit roundoff of long double (Higham §3.1).
Long gamma_for(size_t k) {
  const Long u = std::numeric_limits<Long>::epsilon() / 2;
  return Long(k) * u / (1 - Long(k) * u);
}

struct Parts {
  const System& system;
  const Patches& patches;
  const RowMatrix& rows;
  size_t n() const { return system.size(); }
  size_t P() const { return patches.size(); }
};

// z_e = sum_p P_pe y_p / A_e (long double) and its magnitude with |y| (for the rounding bound).
void patch_sums(const Parts& s, const std::vector<Long>& y, const std::vector<Long>& y_mag,
                std::vector<Long>& z, std::vector<Long>& z_mag) {
  const size_t n = s.n(), P = s.P();
  z.assign(n, 0);
  z_mag.assign(n, 0);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 256),
                    [&](const tbb::blocked_range<size_t>& r) {
                      for (size_t e = r.begin(); e != r.end(); ++e) {
                        Long sum = 0, mag = 0;
                        for (size_t p = 0; p < P; ++p) {
                          const Long f = Long(s.rows.at(p, e));
                          sum += f * y[p];
                          mag += f * y_mag[p];
                        }
                        const Long a = Long(s.system.area()[e]);
                        z[e] = sum / a;
                        z_mag[e] = mag / a;
                      }
                    });
}

// y_p = sum_{j in p} A_j x_j and sum A_j |x_j|.
void patch_powers(const Parts& s, std::span<const double> x, std::vector<Long>& y,
                  std::vector<Long>& y_mag) {
  y.assign(s.P(), 0);
  y_mag.assign(s.P(), 0);
  for (size_t p = 0; p < s.P(); ++p)
    for (uint32_t j : s.patches.members(p)) {
      const Long t = Long(s.system.area()[j]) * Long(x[j]);
      y[p] += t;
      y_mag[p] += std::abs(t);
    }
}

// r = b - (I - J) x in long double; returns max |r_e| + its rounding bound.
double residual(const Parts& s, std::span<const double> rho, std::span<const double> b,
                std::span<const double> x, std::vector<double>* r_out) {
  std::vector<Long> y, y_mag, z, z_mag;
  patch_powers(s, x, y, y_mag);
  patch_sums(s, y, y_mag, z, z_mag);
  // Every term A_j x_j P_pe / A_e rho_e passes through the product, the sum over j in p, the
  // product with P_pe, the sum over p, the division and rho: largest + P + 3 roundings, and
  // b - x + ... three more.
  const Long g = gamma_for(s.patches.largest() + s.P() + 6);
  double worst = 0.0;
  if (r_out) r_out->resize(s.n());
  for (size_t e = 0; e < s.n(); ++e) {
    const Long r = Long(b[e]) - Long(x[e]) + Long(rho[e]) * z[e];
    const Long mag = std::abs(Long(b[e])) + std::abs(Long(x[e])) + Long(rho[e]) * z_mag[e];
    if (r_out) (*r_out)[e] = double(r);
    worst = std::max(worst, double(std::abs(r) + g * mag));
  }
  return worst;
}

// Solves (I - J) x = b through the P x P reduction, in double.
class ReducedSolve {
 public:
  ReducedSolve(const Parts& s, std::span<const double> rho) : s_(s), rho_(rho) {
    const size_t P = s.P();
    Eigen::MatrixXd M = Eigen::MatrixXd::Identity(Eigen::Index(P), Eigen::Index(P));
    // M_qp = sum_{j in q} rho_j P_pj.
    tbb::parallel_for(size_t(0), P, [&](size_t p) {
      s.rows.visit_row(p, [&](const auto* row) {
        for (size_t q = 0; q < P; ++q) {
          double sum = 0.0;
          for (uint32_t j : s.patches.members(q)) sum += rho[j] * double(row[j]);
          M(Eigen::Index(q), Eigen::Index(p)) -= sum;
        }
      });
    });
    lu_.compute(M);
  }
  void solve(std::span<const double> b, std::vector<double>& x) const {
    const size_t n = s_.n(), P = s_.P();
    Eigen::VectorXd rhs(static_cast<Eigen::Index>(P));
    for (size_t p = 0; p < P; ++p) {
      double sum = 0.0;
      for (uint32_t j : s_.patches.members(p)) sum += s_.system.area()[j] * b[j];
      rhs(Eigen::Index(p)) = sum;
    }
    const Eigen::VectorXd y = lu_.solve(rhs);
    x.resize(n);
    for (size_t e = 0; e < n; ++e) {
      double sum = 0.0;
      for (size_t p = 0; p < P; ++p) sum += s_.rows.at(p, e) * y(Eigen::Index(p));
      x[e] = b[e] + rho_[e] * sum / s_.system.area()[e];
    }
  }

 private:
  const Parts& s_;
  std::span<const double> rho_;
  Eigen::PartialPivLU<Eigen::MatrixXd> lu_;
};

}  // namespace

std::vector<double> two_level_residual_inf(const System& system, const Patches& patches,
                                           const RowMatrix& rows, const Radiosity& B) {
  const Parts s{system, patches, rows};
  std::vector<double> out;
  for (int c = 0; c < B.channels(); ++c)
    out.push_back(residual(s, system.reflectance().channel(c), system.emission().channel(c),
                           B.channel(c), nullptr));
  return out;
}

Reference compute_two_level_reference(const System& system, const Patches& patches,
                                      const RowMatrix& rows, const ReferenceOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  if (rows.precision() != Precision::kDouble || rows.rows() != patches.size() ||
      rows.columns() != system.size() || patches.elements() != system.size())
    throw std::invalid_argument("two-level reference: needs the double patch rows of the system");
  const Parts s{system, patches, rows};
  const size_t n = system.size();
  const int channels = system.channels();
  Reference ref;
  ref.B = Radiosity(channels, n);
  ref.method = "rank-" + std::to_string(patches.size()) + " reduction, dense LU";
  // sum_j K_ej = sum_p P_pe A_p / A_e, in long double and rounded up by a relative 1e-15 (far
  // above the few roundings of the sum), so q is an upper bound.
  std::vector<double> sums(n);
  for (size_t e = 0; e < n; ++e) {
    Long sum = 0;
    for (size_t p = 0; p < patches.size(); ++p) sum += Long(rows.at(p, e)) * Long(patches.area(p));
    sums[e] = double(sum / Long(system.area()[e])) * (1.0 + 1e-15);
  }
  const char* names[] = {"r", "g", "b"};
  double max_B_all = 0.0;
  for (int c = 0; c < channels; ++c) {
    const std::string channel = channels == 1 ? std::string("grey") : names[c];
    auto rho = system.reflectance().channel(c);
    auto E = system.emission().channel(c);
    double q = 0.0;
    for (size_t e = 0; e < n; ++e) q = std::max(q, rho[e] * sums[e]);
    ref.q = std::max(ref.q, q);
    const ReducedSolve solver(s, rho);

    // ||(I-J)^-1||_inf from w ~ (I-J)^-1 1, one refinement step (see the header).
    std::vector<double> ones(n, 1.0), w, r1, d;
    solver.solve(ones, w);
    residual(s, rho, ones, w, &r1);
    solver.solve(r1, d);
    for (size_t e = 0; e < n; ++e) w[e] += d[e];
    std::vector<double> s_vec;
    const double s_norm = residual(s, rho, ones, w, &s_vec);
    double inverse_norm = q < 1.0 ? 1.0 / (1.0 - q) : std::numeric_limits<double>::infinity();
    const bool w_positive = std::all_of(w.begin(), w.end(), [](double v) { return v > 0.0; });
    double radius_upper = q;
    if (w_positive && s_norm < 1.0) {
      const double w_norm = *std::max_element(w.begin(), w.end());
      inverse_norm = std::min(inverse_norm, w_norm / (1.0 - s_norm));
      // Collatz–Wielandt at w > 0: (J w)_e = w_e - 1 + s_e, bounded with the residual's bound.
      double cw = 0.0;
      for (size_t e = 0; e < n; ++e) cw = std::max(cw, (w[e] - 1.0 + s_norm) / w[e]);
      radius_upper = std::min(radius_upper, cw);
    }
    if (!std::isfinite(inverse_norm))
      throw NumericalError("two-level reference: no certified solution in channel " + channel +
                           ": (I - diag(rho)K) is singular or nearly so (q = " + std::to_string(q) +
                           ", residual of (I-J)w = 1 " + std::to_string(s_norm) + ")");
    ref.inverse_norm_bound = std::max(ref.inverse_norm_bound, inverse_norm);
    ref.channel_inverse_norm.push_back(inverse_norm);
    ref.spectral_radius_upper = std::max(ref.spectral_radius_upper, radius_upper);

    std::vector<double> x, r;
    solver.solve(E, x);
    double r_norm = residual(s, rho, E, x, &r);
    double bound = r_norm * inverse_norm;
    double max_B = 0.0;
    for (int k = 0; k < options.max_refinements; ++k) {
      max_B = 0.0;
      for (double v : x) max_B = std::max(max_B, std::abs(v));
      if (!std::isfinite(bound) || bound <= options.target * max_B) break;
      solver.solve(r, d);
      for (size_t e = 0; e < n; ++e) x[e] += d[e];
      const double previous = r_norm;
      r_norm = residual(s, rho, E, x, &r);
      bound = r_norm * inverse_norm;
      ++ref.refinements;
      if (r_norm > 0.5 * previous) break;
    }
    max_B = 0.0;
    for (size_t e = 0; e < n; ++e) {
      if (!std::isfinite(x[e]))
        throw NumericalError("two-level reference: non-finite radiosity at element " +
                             std::to_string(e) + " in channel " + channel);
      max_B = std::max(max_B, std::abs(x[e]));
      ref.B.at(c, e) = x[e];
    }
    if (!(bound <= options.acceptable * std::max(max_B, 1e-300)))
      throw NumericalError("two-level reference: could not certify channel " + channel +
                           ": bound " + std::to_string(bound) + " exceeds " +
                           std::to_string(options.acceptable) + " of max B");
    ref.bound_inf = std::max(ref.bound_inf, bound);
    ref.residual_inf = std::max(ref.residual_inf, r_norm);
    max_B_all = std::max(max_B_all, max_B);
  }
  ref.bound_relative = max_B_all > 0 ? ref.bound_inf / max_B_all : 0.0;
  ref.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return ref;
}

}  // namespace radlab
