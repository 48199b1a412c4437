// The state and the shot shared by the shooting solvers (shooting, sorted-shooting, overshooting,
// interleaved), following DESIGN §2.
//
// Stored: x, the radiosity each element has shot so far, and dB, the unshot radiosity; the
// estimate is B = x + dB (formed on demand). Both start from x = 0, dB = E, i.e. B = E. A shot of
// s_c from i (row i of F) does, for every receiver j (the self term j = i included, so that the
// books stay exact when a form-factor method reports F_ii != 0):
//
//   dB_cj += rho_cj F_ij (A_i / A_j) s_c,      then  dB_ci -= s_c,  x_ci += s_c.
//
// Invariant (exact for any s, any F): dB = E + J' x - x, the residual of x for J' = diag(rho) F',
// F'_ji = F_ij A_i / A_j. With reciprocal form factors F' = F, so dB is the residual of x in the
// System's own equation, and B - B* = (I - J)^-1 J dB. Shooting reads rows, so it can only ever
// see F': when F is not reciprocal, every shooting method converges to the solution of F', which
// differs from the System's (the gathering) solution by the reciprocity defect (Cohen et al. 1988
// note the same between their gathering and shooting hemicubes).
//
// Storing x rather than B keeps the shot loop to one updated array per channel.
//
// Shooters (solvers/two_level/patches.h): solvers pick and shoot *shooters* — elements on a
// one-level System, patches on a two-level one — through shooters(), shooter_unshot(), priority(),
// shoot() and System::with_shooter_row(). A patch's unshot radiosity is the area-weighted mean of
// its elements' dB (dB_p A_p = sum_i A_i dB_i), its priority A_p sum_c |dB_cp (+ o_cp)|. Shooting s
// from patch p (its row P_p) is the simultaneous shot of every member i of s_i = dB_i + (s - dB_p)
// through the shared row: every receiver e gets rho_e P_pe (A_p / A_e) s, then each member's books
// move s_i from dB_i to x_i. With s = dB_p that empties the patch (Cohen's Delta B_i = 0), and the
// invariant above holds with J' = diag(rho) K (solvers/two_level/patches.h). A one-element patch
// shoots s itself, so one element per patch reproduces the one-level shots bit for bit.
#pragma once

#include <cmath>
#include <cstddef>
#include <vector>

#include "core/radiosity.h"
#include "solvers/kernels/kernels.h"
#include "solvers/system.h"

namespace radlab {

class ShootingCore {
 public:
  void init(const System& system);

  const System& system() const { return *system_; }
  size_t size() const { return dB_.size(); }
  int channels() const { return dB_.channels(); }

  // The shooters: elements (one-level System) or patches (two-level).
  size_t shooters() const { return system_->shooters().size(); }
  // dB of shooter p in channel c: the area-weighted mean over its elements.
  double shooter_unshot(int c, size_t p) const;
  // The area-weighted mean reflectance of shooter p.
  double shooter_reflectance(int c, size_t p) const;
  double shooter_area(size_t p) const { return system_->shooters().area(p); }
  // Whether any element of shooter p has a non-zero dB in any channel.
  bool shooter_has_unshot(size_t p) const;

  // Priorities become A_j sum_c |dB_cj + o_cj| (overshooting), o kept by the caller with one
  // value per shooter and read whenever a priority is formed; null (the default, and after init)
  // for A_j sum_c |dB_cj|.
  void set_priority_offset(const Radiosity* offset) { offset_ = offset; }

  // Shoots s[c] from shooter i, given its row (read through System::with_shooter_row or
  // with_compact_shooter_row by the caller, which counts it): Row is const T* (n values) or
  // kernels::RunRow<T> (a sparse row's stored runs; the same bits). With select, returns the
  // element with the largest priority A_j sum_c |dB_cj| (+ o_cj with an offset; o_i as it is at the
  // call) afterwards (lowest index among equals): the same value and index as max_priority() after
  // the shot. With coverage, adds F_ji to coverage[j] for every receiver j != i (Wu & Wang's dff;
  // element shooters only).
  template <class Row>
  kernels::Argmax shoot(const Row& F, size_t i, const double* s, bool select,
                        double* coverage = nullptr);

  // The shooter with the largest priority, by a full scan.
  kernels::Argmax max_priority() const;
  // The priority of one element (the same arithmetic as the kernels, offset included).
  double priority(size_t j) const;
  // Whether every unshot value is exactly zero.
  bool all_shot() const;
  // The shooter of the lowest-index element with a non-zero unshot value (priority 0 stands in for
  // a priority that underflowed), or kNone.
  kernels::Argmax first_unshot() const;
  // Unshot power sum_j A_j dB_cj per channel (clamp_negative: positive dB only).
  void unshot_power(bool clamp_negative, double* out) const;

  // Adds v to dB_cj without shooting (gathers; bookkeeping corrections).
  void add_unshot(int c, size_t j, double v) {
    dB_.at(c, j) += v;
    if (float_) dB_.at(c, j) = double(float(dB_.at(c, j)));
    dirty_ = true;
  }
  // add_unshot(c, j, v[c]) for every channel, then priority(j), for element j of a one-level
  // System, inline (interleaved's corrections call it once per member of a session, where the
  // out-of-line priority() was as costly as the shot kernel itself).
  double add_unshot_priority(size_t j, const double* v) {
    for (int c = 0; c < channels(); ++c) add_unshot(c, j, v[c]);
    return element_priority(j);
  }

  // Float storage of x and dB (Wu & Wang 2002 §4 blame part of their pure-shooting curves'
  // rise on "accumulated numerical error"; a 2002 implementation kept radiosities in float).
  // On: after every shot (and in add_unshot) each dB_cj and the shooter's x_ci are rounded to
  // float, as if stored in float arrays with each update computed in double; the next shooter
  // is then found by a full scan (the fused selection saw the unrounded values). Off (default):
  // double throughout. Set after init().
  void set_float_storage(bool on);
  bool float_storage() const { return float_; }

  const Radiosity& unshot() const { return dB_; }
  const Radiosity& shot() const { return x_; }
  // B = x + dB.
  const Radiosity& solution() const;

 private:
  kernels::ShotTargets targets() const;
  // An element's priority, A_j sum_c |dB_cj (+ o_cj)|, in the kernels' order.
  double element_priority(size_t j) const {
    double p = 0.0;
    for (int c = 0; c < channels(); ++c)
      p += std::fabs(offset_ ? dB_.at(c, j) + offset_->at(c, j) : dB_.at(c, j));
    return p * system_->area()[j];
  }
  template <class Row>
  kernels::Argmax shoot_patch(const Row& F, size_t p, const double* s, bool select);

  // Runs shorter than this on average are not worth a vector loop each: the kernels then read
  // the reflectance per element instead.
  static constexpr size_t kMinimumRun = 32;

  const System* system_ = nullptr;
  Radiosity x_, dB_;
  std::vector<kernels::ReflectanceRun> runs_;  // equal reflectance (empty: per element)
  const Radiosity* offset_ = nullptr;          // o in the priority (null: none)
  std::vector<double> amounts_;                // a patch shot's s_i per member and channel
  mutable Radiosity B_;
  mutable bool dirty_ = true;
  bool float_ = false;  // float storage of x and dB (set_float_storage)
};

// The area-weighted average reflectance per channel (Cohen et al. 1988 eq. 10).
std::vector<double> average_reflectance(const System& system);

// Cohen et al. 1988 eqs 9-12 per channel: R_c = 1 / (1 - rho_avg,c) times the area-weighted
// average of the given unshot power (sum_j A_j dB_cj / sum_j A_j).
std::vector<double> ambient_radiosity(const std::vector<double>& interreflection,
                                      const double* unshot_power, double total_area);

}  // namespace radlab
