// The shooting family (shooting, sorted-shooting, overshooting) and its shot kernel: the
// bookkeeping of DESIGN §2 checked against the dense matrix, the energy ledger, the error bound
// by unshot power, the ambient term, and the AVX2 and scalar kernels against their definition.
//
// A note on reciprocity, which many tests below depend on. Gathering reads row i of F and solves
// B = E + diag(rho) F B, the System's equation, whose certified reference every metric uses.
// Shooting reads row i too but delivers rho_j F_ij (A_i/A_j) to j: it solves the same equation
// with F'_ji = F_ij A_i / A_j, which is F only when A_i F_ij = A_j F_ji. Raycast form factors are
// reciprocal only up to quadrature (relative defect ~3e-7 on the cube, up to 1 on the Cornell
// box, where one direction of a pair can see a sliver the other misses), so shooting solvers
// converge to a solution that differs from the reference by that much (1.6e-3 on the Cornell box
// at --subdiv 2). Tests that compare a shooting solver with the reference therefore symmetrise
// the matrix first (formfactor's symmetrise(): A_i F_ij = A_j F_ji exactly in double, to float
// rounding in float); tests of the bookkeeping itself run on the raw, non-reciprocal matrix.

#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>

#include "core/error.h"
#include "core/random.h"
#include "formfactor/methods/exact.h"
#include "formfactor/methods/raycast.h"
#include "metrics/error_metrics.h"
#include "scene/builtin/builtin_scenes.h"
#include "scene/validate.h"
#include "solvers/flat/interleaved.h"
#include "solvers/flat/shooting_core.h"
#include "solvers/kernels/kernels.h"
#include "solvers/reference/reference.h"
#include "solvers/registry.h"
#include "tests/solver_support.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

using namespace radlab::testing;

// Runs of random length (1 to 97) with random reflectance covering n elements; rho (3 channels
// of n, channel after channel) gets each element's run's values.
std::vector<kernels::ReflectanceRun> random_runs(size_t n, Pcg32& rng, std::vector<double>& rho) {
  std::vector<kernels::ReflectanceRun> runs;
  for (size_t j = 0; j < n;) {
    kernels::ReflectanceRun run;
    run.end = std::min(n, j + 1 + size_t(rng.next_double() * 97));
    for (int c = 0; c < 3; ++c) run.rho[c] = rng.next_double();
    for (; j < run.end; ++j)
      for (int c = 0; c < 3; ++c) rho[size_t(c) * n + j] = run.rho[c];
    runs.push_back(run);
  }
  return runs;
}

// The receivers of a kernel test's shot: C channels of n elements in dB, rho (and offset, if
// given) laid out channel after channel; coverage and runs optional.
kernels::ShotTargets shot_targets(int C, size_t n, std::vector<double>& dB,
                                  const std::vector<double>& rho,
                                  const std::vector<double>& inverse_area,
                                  const std::vector<double>& area, double* coverage,
                                  const std::vector<kernels::ReflectanceRun>* runs,
                                  const double* offset = nullptr) {
  kernels::ShotTargets t;
  t.channels = C;
  for (int c = 0; c < C; ++c) {
    t.unshot[c] = dB.data() + size_t(c) * n;
    t.reflectance[c] = rho.data() + size_t(c) * n;
    if (offset) t.offset[c] = offset + size_t(c) * n;
  }
  t.inverse_area = inverse_area.data();
  t.area = area.data();
  t.coverage = coverage;
  if (runs) {
    t.runs = runs->data();
    t.run_count = runs->size();
  }
  return t;
}

// The shot kernel on its own, against its definition (kernels.h):
//   dB_cj += (F_j * (1/A_j)) * (k_c * rho_cj),  coverage_j += (F_j * (1/A_j)) * coverage_scale,
// and the lowest index of the largest A_j sum_c |dB_cj| afterwards. Every combination (channels,
// float or double rows, selection, coverage, reflectance runs or per element, scalar or vector)
// must give the same bits as that formula evaluated here. n = 301 and ranges starting at odd
// offsets exercise the alignment peel, partial blocks and tails; runs of lengths 1 to 97 the
// run boundaries inside blocks. Negative unshot values check the |dB| in the priority.
TEST(ShotKernel, EveryPathComputesTheDefinitionBitForBit) {
  const size_t n = 301;
  Pcg32 rng(5);
  std::vector<float> Ff(n);
  std::vector<double> Fd(n), area(n), inverse_area(n), rho(3 * n), dB0(3 * n), cov0(n);
  const std::vector<kernels::ReflectanceRun> runs = random_runs(n, rng, rho);
  for (size_t j = 0; j < n; ++j) {
    Ff[j] = float(rng.next_double() * 1e-2);
    Fd[j] = rng.next_double() * 1e-2;
    area[j] = 0.01 + rng.next_double();
    inverse_area[j] = 1.0 / area[j];
    cov0[j] = rng.next_double();
    for (int c = 0; c < 3; ++c) dB0[size_t(c) * n + j] = rng.next_double() - 0.2;
  }
  const double k[3] = {0.7, -0.3, 1.9}, coverage_scale = 0.37;
  const std::vector<std::pair<size_t, size_t>> ranges = {
      {0, n}, {3, n}, {1, 70}, {5, 6}, {77, 300}};
  const bool have_vector = kernels::use_vector_kernels(true);
  int cases = 0;
  for (int C : {1, 3})
    for (bool use_float : {true, false})
      for (bool select : {true, false})
        for (bool coverage : {true, false})
          for (bool with_runs : {true, false})
            for (bool vector : {false, true}) {
              if (vector && !have_vector) continue;
              for (const auto& [lo, hi] : ranges) {
                std::vector<double> dB = dB0, cov = cov0;
                const kernels::ShotTargets t =
                    shot_targets(C, n, dB, rho, inverse_area, area, coverage ? cov.data() : nullptr,
                                 with_runs ? &runs : nullptr);
                kernels::use_vector_kernels(vector);
                const kernels::Argmax got =
                    use_float ? kernels::shoot(Ff.data(), lo, hi, k, coverage_scale, t, select)
                              : kernels::shoot(Fd.data(), lo, hi, k, coverage_scale, t, select);
                kernels::use_vector_kernels(true);
                std::vector<double> want = dB0, want_cov = cov0;
                kernels::Argmax best;
                for (size_t j = lo; j < hi; ++j) {
                  const double g = (use_float ? double(Ff[j]) : Fd[j]) * inverse_area[j];
                  double p = 0.0;
                  for (int c = 0; c < C; ++c) {
                    double& u = want[size_t(c) * n + j];
                    // volatile: each product rounded, never fused into a multiply-add.
                    const volatile double delivered = g * (k[c] * rho[size_t(c) * n + j]);
                    u += delivered;
                    p += std::abs(u);
                  }
                  p *= area[j];
                  if (p > best.value) best = {p, j};
                  const volatile double covered = g * coverage_scale;
                  want_cov[j] += covered;
                }
                const std::string what =
                    "C=" + std::to_string(C) + (use_float ? " float" : " double") +
                    (select ? " select" : "") + (coverage ? " coverage" : "") +
                    (with_runs ? " runs" : "") + (vector ? " vector" : " scalar") + " [" +
                    std::to_string(lo) + "," + std::to_string(hi) + ")";
                for (size_t e = 0; e < size_t(C) * n; ++e)
                  ASSERT_EQ(dB[e], want[e]) << what << " " << e;
                for (size_t j = 0; j < n; ++j)
                  ASSERT_EQ(cov[j], coverage ? want_cov[j] : cov0[j]) << what << " " << j;
                if (select) {
                  EXPECT_EQ(got.index, best.index) << what;
                  EXPECT_EQ(got.value, best.value) << what;
                }
                ++cases;
              }
            }
  EXPECT_GE(cases, 5 * 32);
}

// ---------------------------------------------------------------------------------------------
// Shooting bookkeeping (DESIGN §2).

TEST(Shooting, CyclicShootingIsGaussSeidelFromZero) {
  // Unequal areas (lx = 2) and exact reciprocity (double, symmetrised), planar elements
  // (F_ii = 0). Every furnace element emits, so no element is ever skipped and n steps are one
  // full cycle. Then x = B - dB after each cycle is the Gauss–Seidel iterate started from x = 0.
  // Tolerance 1e-12 relative: the two sum the same products in different orders (<= 24 terms).
  auto s = setup("furnace:lx=2,rho=0.7", 2, Precision::kDouble, /*symmetrised=*/true);
  const System& sys = *s->system;
  const size_t n = s->n();
  auto solver = make("shooting");
  sys.reset_counters();
  solver->init(sys);
  std::vector<double> from_zero(n, 0.0), from_e(n);
  for (size_t i = 0; i < n; ++i) {
    ASSERT_EQ(s->matrix.at(i, i), 0.0);
    from_e[i] = sys.emission().at(0, i);
  }
  auto sweep = [&](std::vector<double>& x) {
    for (size_t i = 0; i < n; ++i) {
      double g = 0.0;
      for (size_t j = 0; j < n; ++j) g += s->matrix.at(i, j) * x[j];
      x[i] = sys.emission().at(0, i) + sys.reflectance().at(0, i) * g;
    }
  };
  for (int cycle = 1; cycle <= 6; ++cycle) {
    for (size_t k = 0; k < n; ++k) solver->step();
    ASSERT_EQ(sys.rows_used(), cycle * n) << "an element was skipped";
    sweep(from_zero);
    sweep(from_e);
    const Radiosity x = minus(solver->solution(), *solver->unshot());
    double worst = 0.0, worst_e = 0.0, scale = 0.0;
    for (size_t i = 0; i < n; ++i) {
      worst = std::max(worst, std::abs(x.at(0, i) - from_zero[i]));
      worst_e = std::max(worst_e, std::abs(x.at(0, i) - from_e[i]));
      scale = std::max(scale, from_zero[i]);
    }
    EXPECT_LE(worst, 1e-12 * scale) << "cycle " << cycle;
    // Gauss–Seidel started from E is a different sequence (one emission ahead).
    EXPECT_GT(worst_e, 1e-3 * scale) << "cycle " << cycle;
  }
}

// Solvers whose unshot() is the residual of B - dB (interleaved with gathers adds its advance).
const std::vector<Variant> kShootingFamily = {
    {"shooting", {}},
    {"sorted-shooting", {}},
    {"sorted-shooting", {"omega=1.5"}},
    {"overshooting", {}},
    {"overshooting", {"variant=ambient"}},
    {"overshooting", {"clamp=true"}},
    {"interleaved", {"gathers=0"}},
};

std::string describe(const Variant& v) {
  std::string d = v.solver;
  for (const auto& p : v.params) d += " " + p;
  return d;
}

TEST(Shooting, UnshotIsTheResidualOfBMinusDBForAnyFormFactors) {
  // On the raw, non-reciprocal float matrix: dB equals E + J'x - x exactly up to rounding, J'
  // being the operator shots apply. Tolerance: 1e-13 of the largest emission; each dB entry is
  // a double sum of <= a few hundred contributions, each rounded at ~1e-16 relative.
  auto s = setup("cornell", 2);
  const double scale = max_abs(s->system->emission());
  for (const Variant& v : kShootingFamily) {
    auto solver = make(v.solver, v.params);
    solver->init(*s->system);
    for (int step = 1; step <= 200; ++step) {
      solver->step();
      if (step % 20 != 0) continue;
      const Radiosity x = minus(solver->solution(), *solver->unshot());
      const Radiosity r = shooting_residual(*s, x);
      EXPECT_LE(max_abs(minus(r, *solver->unshot())), 1e-13 * scale)
          << describe(v) << " step " << step;
    }
  }
}

TEST(Shooting, ErrorBoundedByUnshotPower) {
  // With dB the residual of x = B - dB and J reciprocal, B* - B = (I - J)^-1 J dB, so in the
  // area-weighted 1-norm sum A|e| <= q/(1-q) sum A|dB| with q = ||J||_A1 =
  // max_j sum_i A_i rho_i F_ij / A_j (= max_j sum_i rho_i F_ji <= rho_max when rows sum to <= 1:
  // the rho_max/(1-rho_max)). Checked per channel at every 10th step; slack: the
  // reference's certified bound times the total area, plus 1e-12 relative rounding.
  for (const char* spec : {"cornell", "cube:rho=0.9"}) {
    auto s = setup(spec, 2, Precision::kDouble, /*symmetrised=*/true);
    const System& sys = *s->system;
    const size_t n = s->n();
    for (const Variant& v : kShootingFamily) {
      auto solver = make(v.solver, v.params);
      solver->init(sys);
      for (int step = 0; step <= 400; step += 10) {
        const Radiosity& B = solver->solution();
        const Radiosity& dB = *solver->unshot();
        for (int c = 0; c < sys.channels(); ++c) {
          double q = 0.0;
          for (size_t j = 0; j < n; ++j) {
            double col = 0.0;
            for (size_t i = 0; i < n; ++i)
              col += sys.area()[i] * sys.reflectance().at(c, i) * s->matrix.at(i, j);
            q = std::max(q, col / sys.area()[j]);
          }
          ASSERT_LT(q, 1.0);
          // Rows sum to at most 1 + raycast's quadrature tolerance here (closed rooms).
          EXPECT_LE(q, sys.max_reflectance() * (1 + RaycastOptions{}.tolerance)) << spec;
          double error = 0.0, unshot = 0.0, total = 0.0;
          for (size_t i = 0; i < n; ++i) {
            error += sys.area()[i] * std::abs(B.at(c, i) - s->reference.B.at(c, i));
            unshot += sys.area()[i] * std::abs(dB.at(c, i));
            total += sys.area()[i] * s->reference.B.at(c, i);
          }
          EXPECT_LE(error, q / (1 - q) * unshot + sys.total_area() * s->reference.bound_inf +
                               1e-12 * total)
              << describe(v) << " on " << spec << " step " << step;
        }
        for (int k = 0; k < 10; ++k) solver->step();
      }
    }
  }
}

// Per channel: emitted + advance = unshot + absorbed + escaped, from x = B - dB and the matrix.
struct Ledger {
  double emitted = 0, advance = 0, unshot = 0, absorbed = 0, escaped = 0;
};

Ledger ledger(const Setup& s, const Radiosity& B, const Radiosity& dB, const Radiosity* a, int c) {
  const System& sys = *s.system;
  const size_t n = s.n();
  Ledger l;
  std::vector<long double> incoming(n, 0.0L);  // power arriving at j from the shots
  long double escaped = 0.0L;
  for (size_t i = 0; i < n; ++i) {
    const long double shot = static_cast<long double>(sys.area()[i]) * (B.at(c, i) - dB.at(c, i));
    long double row = 0.0L;
    for (size_t j = 0; j < n; ++j) {
      incoming[j] += shot * s.matrix.at(i, j);
      row += s.matrix.at(i, j);
    }
    escaped += shot * (1.0L - row);
  }
  long double absorbed = 0.0L;
  for (size_t j = 0; j < n; ++j) {
    absorbed += (1.0L - sys.reflectance().at(c, j)) * incoming[j];
    l.emitted += sys.area()[j] * sys.emission().at(c, j);
    l.unshot += sys.area()[j] * dB.at(c, j);
    if (a) l.advance += sys.area()[j] * a->at(c, j);
  }
  l.absorbed = double(absorbed);
  l.escaped = double(escaped);
  return l;
}

TEST(Shooting, EnergyLedgerBalances) {
  // Every shot of s from i sends A_i s of power: the fraction F_ij reaches j, which reflects
  // rho_j of it into its unshot radiosity and absorbs the rest; 1 - sum_j F_ij leaves the open
  // Cornell box. So emitted = unshot + absorbed + escaped (+ the interleaving's advance, power
  // received before it was shot, on the left). Raw non-reciprocal matrix: the ledger holds for
  // any F. Tolerance 1e-12 of the emitted power (sums of <= 80 x 200 positive terms in double).
  auto s = setup("cornell", 2);
  std::vector<Variant> variants = kShootingFamily;
  variants.push_back({"interleaved", {"shots=10", "gathers=8"}});
  variants.push_back({"interleaved", {"shots=10", "gathers=8", "max_sessions=1"}});
  for (const Variant& v : variants) {
    auto solver = make(v.solver, v.params);
    solver->init(*s->system);
    for (int step = 1; step <= 200; ++step) {
      solver->step();
      if (step % 25 != 0) continue;
      const auto* il = dynamic_cast<const InterleavedSolver*>(solver.get());
      for (int c = 0; c < s->channels(); ++c) {
        const Ledger l =
            ledger(*s, solver->solution(), *solver->unshot(), il ? &il->advance() : nullptr, c);
        EXPECT_NEAR(l.emitted + l.advance, l.unshot + l.absorbed + l.escaped, 1e-12 * l.emitted)
            << describe(v) << " step " << step << " channel " << c;
        EXPECT_GT(l.escaped, 0.0) << "the Cornell box is open";
      }
    }
  }
}

TEST(Shooting, FinishesOnlyWhenNothingIsLeftToShoot) {
  auto s = setup("cube:rho=0.5", 2, Precision::kFloat, /*symmetrised=*/true);
  for (const char* name : {"shooting", "sorted-shooting"}) {
    auto solver = make(name);
    solver->init(*s->system);
    bool finished = false;
    for (int k = 0; k < 200000 && !finished; ++k) finished = solver->step().finished;
    ASSERT_TRUE(finished) << name;
    for (double v : solver->unshot()->raw()) EXPECT_EQ(v, 0.0) << name;
    EXPECT_LE(max_relative_error(solver->solution(), s->reference.B), 1e-12) << name;
  }
}

TEST(SortedShooting, AmbientIsDisplayOnly) {
  auto s = setup("cornell", 2);
  auto plain = make("sorted-shooting");
  auto ambient = make("sorted-shooting", {"ambient=true"});
  plain->init(*s->system);
  ambient->init(*s->system);
  for (int k = 0; k < 150; ++k) {
    plain->step();
    ambient->step();
    for (size_t e = 0; e < plain->solution().raw().size(); ++e)
      ASSERT_EQ(plain->solution().raw()[e], ambient->solution().raw()[e]) << "step " << k;
  }
  const Radiosity shown = ambient->display();
  const Radiosity& rho = s->system->reflectance();
  // The display adds rho_i * Ambient_c, positive where unshot energy remains.
  for (int c = 0; c < 3; ++c)
    for (size_t i = 0; i < s->n(); ++i) {
      if (rho.at(c, i) > 0) {
        EXPECT_GT(shown.at(c, i), ambient->solution().at(c, i));
      }
      EXPECT_EQ(plain->display().at(c, i), plain->solution().at(c, i));
    }
}

TEST(SortedShooting, AmbientIsExactForTheFurnaceBeforeAnyShot) {
  // Cohen's ambient assumes F_ij = A_j / sum A and uniform reflectance: exact for a furnace
  // (uniform E and rho, rows summing to 1), where E + rho R E = E / (1 - rho). Tolerance 1e-5:
  // the raycast rows sum to 1 within ~1e-6 here.
  auto s = setup("furnace:rho=0.7", 2);
  auto solver = make("sorted-shooting", {"ambient=true"});
  solver->init(*s->system);
  EXPECT_LE(max_relative_error(solver->display(), s->reference.B), 1e-5);
  EXPECT_GT(max_relative_error(solver->solution(), s->reference.B), 0.5);
}

// The shot kernel with offsets (overshooting's fused selection): the priority after the shot is
// A_j sum_c |dB_cj + o_cj|, evaluated here as the definition, and the result must equal a scan by
// kernels::max_priority over the updated range, in every path (scalar and vector bit for bit).
// Four elements with F = 0 and equal dB, o and A share the largest priority (two in one block of
// 64, two in others), so the lowest index must win; ranges starting past some of them move it.
TEST(ShotKernel, OffsetPriorityIsTheDefinitionBitForBit) {
  const size_t n = 301;
  Pcg32 rng(9);
  std::vector<float> Ff(n);
  std::vector<double> Fd(n), area(n), inverse_area(n), rho(3 * n), dB0(3 * n), offset(3 * n);
  const std::vector<kernels::ReflectanceRun> runs = random_runs(n, rng, rho);
  for (size_t j = 0; j < n; ++j) {
    Ff[j] = float(rng.next_double() * 1e-2);
    Fd[j] = rng.next_double() * 1e-2;
    area[j] = 0.01 + rng.next_double();
    inverse_area[j] = 1.0 / area[j];
    for (int c = 0; c < 3; ++c) {
      dB0[size_t(c) * n + j] = rng.next_double() - 0.5;
      offset[size_t(c) * n + j] = rng.next_double() - 0.5;  // cancels dB for some
    }
  }
  for (size_t j : {size_t(10), size_t(130), size_t(131), size_t(250)}) {
    Ff[j] = 0.0f;
    Fd[j] = 0.0;
    area[j] = 2.0;
    inverse_area[j] = 0.5;
    for (int c = 0; c < 3; ++c) {
      dB0[size_t(c) * n + j] = -3.0;
      offset[size_t(c) * n + j] = 1.25;
    }
  }
  const double k[3] = {0.7, -0.3, 1.9}, coverage_scale = 0.37;
  const std::vector<std::pair<size_t, size_t>> ranges = {{0, n},  {3, n}, {11, n},   {131, 300},
                                                         {1, 70}, {5, 6}, {77, 300}, {251, n}};
  const bool have_vector = kernels::use_vector_kernels(true);
  int cases = 0;
  for (int C : {1, 3})
    for (bool use_float : {true, false})
      for (bool coverage : {true, false})
        for (bool with_runs : {true, false})
          for (bool vector : {false, true}) {
            if (vector && !have_vector) continue;
            for (const auto& [lo, hi] : ranges) {
              std::vector<double> dB = dB0, cov(n, 0.0);
              const kernels::ShotTargets t =
                  shot_targets(C, n, dB, rho, inverse_area, area, coverage ? cov.data() : nullptr,
                               with_runs ? &runs : nullptr, offset.data());
              kernels::use_vector_kernels(vector);
              const kernels::Argmax got =
                  use_float ? kernels::shoot(Ff.data(), lo, hi, k, coverage_scale, t, true)
                            : kernels::shoot(Fd.data(), lo, hi, k, coverage_scale, t, true);
              kernels::use_vector_kernels(true);
              std::vector<double> want = dB0;
              kernels::Argmax best;
              for (size_t j = lo; j < hi; ++j) {
                const double g = (use_float ? double(Ff[j]) : Fd[j]) * inverse_area[j];
                double p = 0.0;
                for (int c = 0; c < C; ++c) {
                  double& u = want[size_t(c) * n + j];
                  const volatile double delivered = g * (k[c] * rho[size_t(c) * n + j]);
                  u += delivered;
                  p += std::abs(u + offset[size_t(c) * n + j]);
                }
                p *= area[j];
                if (p > best.value) best = {p, j};
              }
              const std::string what = "C=" + std::to_string(C) +
                                       (use_float ? " float" : " double") +
                                       (coverage ? " coverage" : "") + (with_runs ? " runs" : "") +
                                       (vector ? " vector" : " scalar") + " [" +
                                       std::to_string(lo) + "," + std::to_string(hi) + ")";
              for (size_t e = 0; e < size_t(C) * n; ++e)
                ASSERT_EQ(dB[e], want[e]) << what << " " << e;
              const kernels::Argmax scan = kernels::max_priority(lo, hi, t);
              EXPECT_EQ(got.index, best.index) << what;
              EXPECT_EQ(got.value, best.value) << what;
              EXPECT_EQ(scan.index, best.index) << what;
              EXPECT_EQ(scan.value, best.value) << what;
              if (lo <= 10 && hi > 250) {
                EXPECT_EQ(got.index, 10u) << what;
              }
              if (lo == 11) {
                EXPECT_EQ(got.index, 130u) << what;
              }
              if (lo == 131) {
                EXPECT_EQ(got.index, 131u) << what;
              }
              ++cases;
            }
          }
  EXPECT_GE(cases, 8 * 16);
}

// Overshooting regather selects inside the shot (ShootingCore with an offset), no longer by a
// scan. Against a model of the solver as it was (a full scan of A_j sum_c |dB_cj + o_cj| before
// every step, shots without selection): at every step the fused pick equals the scan's, value and
// index, and the solver's B and dB equal the model's bit for bit. Raw (non-reciprocal) raycast
// matrices, RGB and grey, clamp on and off, vector and scalar kernels.
TEST(Overshooting, FusedSelectionIsTheFullScanStepByStep) {
  for (const auto& [spec, subdiv] : {std::pair<std::string, int>{"cornell", 3}, {"cube", 6}}) {
    auto s = setup(spec, subdiv);
    const System& sys = *s->system;
    const size_t n = sys.size();
    const int C = sys.channels();
    const Radiosity& rho = sys.reflectance();
    for (bool clamp : {false, true})
      for (bool vector : {true, false}) {
        kernels::use_vector_kernels(vector);
        const std::string what = spec + (clamp ? " clamp" : "") + (vector ? " vector" : " scalar");
        auto solver = make("overshooting", {clamp ? "clamp=true" : "clamp=false"});
        solver->init(sys);
        ShootingCore model, fused;
        model.init(sys);
        fused.init(sys);
        Radiosity o(C, n);
        fused.set_priority_offset(&o);
        kernels::Argmax from_shot = fused.max_priority();
        int steps = 0;
        for (; steps < 400; ++steps) {
          kernels::Argmax best;  // the old scan
          for (size_t j = 0; j < n; ++j) {
            double p = 0.0;
            for (int c = 0; c < C; ++c) p += std::fabs(model.unshot().at(c, j) + o.at(c, j));
            p *= sys.area()[j];
            if (p > best.value) best = {p, j};
          }
          ASSERT_EQ(from_shot.index, best.index) << what << " step " << steps;
          ASSERT_EQ(from_shot.value, best.value) << what << " step " << steps;
          const bool finished = solver->step().finished;
          if (!(best.value > 0.0)) {
            if (model.all_shot()) {
              ASSERT_TRUE(finished) << what;
              break;
            }
            best = model.first_unshot();
          }
          ASSERT_FALSE(finished) << what << " step " << steps;
          const size_t i = best.index;
          double shot[3] = {0.0, 0.0, 0.0};
          for (int c = 0; c < C; ++c) shot[c] = model.unshot().at(c, i);
          sys.with_row(i, [&](const auto* F) {
            double gathered[3] = {0.0, 0.0, 0.0};
            kernels::gather(F, model.unshot(), gathered, clamp);
            for (int c = 0; c < C; ++c) {
              o.at(c, i) = rho.at(c, i) * gathered[c];
              shot[c] += o.at(c, i);
            }
            model.shoot(F, i, shot, false);
            from_shot = fused.shoot(F, i, shot, true);
          });
          const auto b = solver->solution().raw(), want = model.solution().raw();
          const auto u = solver->unshot()->raw(), want_u = model.unshot().raw();
          for (size_t e = 0; e < b.size(); ++e) {
            ASSERT_EQ(b[e], want[e]) << what << " step " << steps << " at " << e;
            ASSERT_EQ(u[e], want_u[e]) << what << " step " << steps << " at " << e;
          }
        }
        EXPECT_EQ(steps, 400) << what;
        kernels::use_vector_kernels(true);
      }
  }
}

TEST(Overshooting, AmbientClampDivergesNearRhoOneAndItsHelpSaysSo) {
  // clamp=true never counts the negative unshot radiosity that overshoots leave, so with the
  // ambient estimate (R = 1/(1 - rho) = 100 at rho 0.99) every round over-shoots more: on the
  // closed cube at rho 0.99 the radiosities leave any bound (the runner's divergence test stops it
  // by step ~36, exit 4), while clamp=false stays within the solution's scale. Its help used to
  // call it "steadier" (issue 35.5); it must say it diverges.
  auto s = setup("cube:rho=0.99", 4, Precision::kDouble);
  double top = 0.0;
  for (double b : s->reference.B.raw()) top = std::max(top, b);
  for (bool clamp : {true, false}) {
    auto solver = make("overshooting", {"variant=ambient", clamp ? "clamp=true" : "clamp=false"});
    solver->init(*s->system);
    double largest = 0.0;
    for (int k = 0; k < 200; ++k) {
      solver->step();
      for (double b : solver->solution().raw()) largest = std::max(largest, std::abs(b));
    }
    // 1e6 x max B*: divergence, not a transient (clamp=false peaks within 10x of it).
    if (clamp)
      EXPECT_GT(largest, 1e6 * top);
    else
      EXPECT_LT(largest, 10.0 * top);
  }
  std::string help;
  for (const ParameterInfo& p : solver_info("overshooting").parameters)
    if (p.name == "clamp") help = p.help;
  EXPECT_NE(help.find("diverges"), std::string::npos) << help;
}

TEST(GaussSeidel, NegativeRadiositiesOfOverRelaxationAreCounted) {
  // SOR at omega 1.9 overshoots below zero (the Cornell box: -0.15 after 3,000 rows); the
  // solver's statistics say how many values are negative and the lowest any element took, which
  // run.json and `radlab solve` print (issue 35.5). At omega 1 (from B = E, all terms
  // non-negative) none is.
  auto s = setup("cornell", 4);
  for (const char* omega : {"omega=1.9", "omega=1"}) {
    auto solver = make("gauss-seidel", {omega});
    solver->init(*s->system);
    double lowest = 0.0, negative = 0.0;
    for (int k = 0; k < 3000; ++k) solver->step();
    for (double b : solver->solution().raw()) {
      lowest = std::min(lowest, b);
      negative += b < 0.0 ? 1.0 : 0.0;
    }
    std::map<std::string, double> st;
    for (const auto& [k, v] : solver->statistics()) st[k] = v;
    ASSERT_TRUE(st.count("negative_radiosities")) << omega;
    EXPECT_EQ(st["negative_radiosities"], negative) << omega;
    EXPECT_EQ(st["min_radiosity"], lowest) << omega;
    EXPECT_LE(st["min_radiosity_seen"], lowest) << omega;
    if (std::string(omega) == "omega=1.9") {
      EXPECT_GT(negative, 0.0);
      EXPECT_LT(st["min_radiosity_seen"], 0.0);
    } else {
      EXPECT_EQ(st["min_radiosity_seen"], 0.0);
    }
  }
}

}  // namespace
}  // namespace radlab
