// Every registered solver, on scenes whose answer is known: convergence to the certified
// reference, the monotone approach from below, the shooting bookkeeping (DESIGN §2) checked
// against the dense matrix, the energy ledger, the interleaving's exact bookkeeping against a
// brute-force model, conjugate gradients' preconditions and A-norm descent.
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

#include "core/error.h"
#include "formfactor/raycast.h"
#include "metrics/error_metrics.h"
#include "scene/builtin_scenes.h"
#include "scene/validate.h"
#include "solvers/interleaved.h"
#include "solvers/kernels.h"
#include "solvers/reference.h"
#include "solvers/registry.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

struct Setup {
  Scene scene;
  Mesh mesh;
  FormFactorMatrix matrix;
  std::unique_ptr<System> system;
  Reference reference;

  size_t n() const { return mesh.size(); }
  int channels() const { return system->channels(); }
};

std::unique_ptr<Setup> setup_scene(Scene scene, int subdiv, Precision precision = Precision::kFloat,
                                   bool symmetrised = false) {
  auto s = std::make_unique<Setup>();
  s->scene = std::move(scene);
  validate_scene(s->scene);
  s->mesh = build_mesh(s->scene, {subdiv, 0.0});
  RaycastOptions options;
  options.rays = 4;
  RaycastFormFactors ff(s->scene, s->mesh, options);
  BuildReport report;
  s->matrix = build_matrix(ff, s->mesh.size(), precision, report);
  if (symmetrised) symmetrise(s->matrix, s->mesh.area);
  s->system = std::make_unique<System>(s->scene, s->mesh, s->matrix);
  s->reference = compute_reference(*s->system, s->matrix);
  return s;
}

std::unique_ptr<Setup> setup(const std::string& spec, int subdiv,
                             Precision precision = Precision::kFloat, bool symmetrised = false) {
  return setup_scene(make_builtin_scene(spec), subdiv, precision, symmetrised);
}

std::unique_ptr<Solver> make(const std::string& name, const std::vector<std::string>& params = {}) {
  ParamBag bag = ParamBag::from_assignments(params, "solver '" + name + "'");
  return make_solver(name, bag);
}

double max_relative_error(const Radiosity& B, const Radiosity& ref) {
  double worst = 0.0;
  for (int c = 0; c < ref.channels(); ++c)
    for (size_t i = 0; i < ref.size(); ++i)
      worst = std::max(worst, std::abs(B.at(c, i) - ref.at(c, i)) / std::abs(ref.at(c, i)));
  return worst;
}

double max_abs(const Radiosity& v) {
  double m = 0.0;
  for (double x : v.raw()) m = std::max(m, std::abs(x));
  return m;
}

Radiosity minus(const Radiosity& a, const Radiosity& b) {
  Radiosity d = a;
  for (size_t k = 0; k < d.raw().size(); ++k) d.raw()[k] -= b.raw()[k];
  return d;
}

// E + J' x - x with J'_jk = rho_j F_kj A_k / A_j (the operator a shot applies; long double).
Radiosity shooting_residual(const Setup& s, const Radiosity& x) {
  const System& sys = *s.system;
  Radiosity r(x.channels(), x.size());
  for (int c = 0; c < x.channels(); ++c)
    for (size_t j = 0; j < x.size(); ++j) {
      long double in = 0.0L;
      for (size_t k = 0; k < x.size(); ++k)
        in += static_cast<long double>(s.matrix.at(k, j)) * sys.area()[k] * x.at(c, k);
      const long double rho = sys.reflectance().at(c, j);
      r.at(c, j) = double(sys.emission().at(c, j) + rho * in / sys.area()[j] - x.at(c, j));
    }
  return r;
}

// E + J x - x, the System's own residual (long double).
Radiosity gathering_residual(const Setup& s, const Radiosity& x) {
  const System& sys = *s.system;
  Radiosity r(x.channels(), x.size());
  for (int c = 0; c < x.channels(); ++c)
    for (size_t i = 0; i < x.size(); ++i) {
      long double g = 0.0L;
      for (size_t j = 0; j < x.size(); ++j)
        g += static_cast<long double>(s.matrix.at(i, j)) * x.at(c, j);
      r.at(c, i) = double(sys.emission().at(c, i) + sys.reflectance().at(c, i) * g - x.at(c, i));
    }
  return r;
}

// Runs until `rows` form-factor rows are used (counting from now) or the solver finishes.
void run_rows(Solver& solver, const System& system, uint64_t rows) {
  const uint64_t end = system.rows_used() + rows;
  while (system.rows_used() < end)
    if (solver.step().finished) break;
}

// ---------------------------------------------------------------------------------------------
// Every registered solver.

class EverySolver : public ::testing::TestWithParam<std::string> {};

TEST_P(EverySolver, ReachesTheReference) {
  // Symmetrised (see the note at the top): every solver's fixed point is then the reference's.
  // The cube and furnace at --subdiv 2 have equal element areas, so even float storage keeps
  // A_i F_ij = A_j F_ji exactly and 1e-9 is far above what is left: the reference's certified
  // bound (~1e-12) and double rounding.
  for (const char* spec : {"cube:rho=0.5", "cube:rho=0.9", "furnace:rho=0.7"}) {
    auto s = setup(spec, 2, Precision::kFloat, /*symmetrised=*/true);
    auto solver = make(GetParam());
    s->system->reset_counters();
    solver->init(*s->system);
    const uint64_t limit = 2000 * s->n();  // rows
    long long step = 0;
    double error = 1.0;
    for (; s->system->rows_used() < limit && error > 1e-9; ++step) {
      if (solver->step().finished) break;
      if (step % 64 == 0) error = max_relative_error(solver->solution(), s->reference.B);
    }
    error = max_relative_error(solver->solution(), s->reference.B);
    EXPECT_LE(error, 1e-9) << GetParam() << " on " << spec << " after " << step << " steps";
  }
}

TEST_P(EverySolver, ReachesTheCornellReferenceWithinABudget) {
  // Symmetrised in float: unequal areas leave a relative reciprocity defect of ~1e-7, so the
  // shooting solvers' fixed point is within ~1e-6 of the reference; 1e-5 leaves room for it.
  auto s = setup("cornell", 2, Precision::kFloat, /*symmetrised=*/true);
  auto solver = make(GetParam());
  s->system->reset_counters();
  solver->init(*s->system);
  // 60 sweeps' worth of rows: rho <= 0.78 gives a contraction of at most ~0.78 per sweep.
  run_rows(*solver, *s->system, 60 * s->n());
  EXPECT_LE(max_relative_error(solver->solution(), s->reference.B), 1e-5) << GetParam();
}

TEST_P(EverySolver, SameSeedSameNumbers) {
  // Two independent builds (parallel matrix build, same seed) and runs agree bit for bit.
  // (Symmetrised so that conjugate gradients accepts the matrix.)
  auto a = setup("cornell", 1, Precision::kFloat, true);
  auto b = setup("cornell", 1, Precision::kFloat, true);
  ASSERT_EQ(a->n(), b->n());
  for (size_t i = 0; i < a->n(); ++i)
    for (size_t j = 0; j < a->n(); ++j) ASSERT_EQ(a->matrix.at(i, j), b->matrix.at(i, j));
  auto sa = make(GetParam());
  auto sb = make(GetParam());
  sa->init(*a->system);
  sb->init(*b->system);
  for (int k = 0; k < 300; ++k) {
    const bool fa = sa->step().finished, fb = sb->step().finished;
    ASSERT_EQ(fa, fb);
    if (fa) break;
  }
  for (size_t k = 0; k < sa->solution().raw().size(); ++k) {
    ASSERT_EQ(sa->solution().raw()[k], sb->solution().raw()[k]) << GetParam();
    ASSERT_EQ(sa->display().raw()[k], sb->display().raw()[k]) << GetParam();
  }
}

TEST_P(EverySolver, VectorAndScalarKernelsAgreeBitForBit) {
  if (!kernels::use_vector_kernels(true)) GTEST_SKIP() << "no AVX2 on this CPU";
  // n = 320 exercises full 64-element blocks, the 16-lane sums and the tails.
  auto s = setup("cornell", 4, Precision::kFloat, true);
  Radiosity with_vector, with_scalar;
  for (bool vector : {true, false}) {
    kernels::use_vector_kernels(vector);
    auto solver = make(GetParam());
    solver->init(*s->system);
    for (int k = 0; k < 700; ++k)
      if (solver->step().finished) break;
    (vector ? with_vector : with_scalar) = solver->solution();
  }
  kernels::use_vector_kernels(true);
  for (size_t k = 0; k < with_vector.raw().size(); ++k)
    ASSERT_EQ(with_vector.raw()[k], with_scalar.raw()[k]) << GetParam() << " at " << k;
}

TEST_P(EverySolver, RowsOnTheFlyAreCountedAndConverge) {
  // --ff-mode on-the-fly: rows come from the method in double, one with_row call each, and the
  // System counts every one. Tolerance 1e-5: the reference is of the float matrix (rows differ
  // by float rounding, ~6e-8) and shooting sees F' (cube reciprocity defect ~3e-7).
  auto s = setup("cube:rho=0.5", 2);
  RaycastOptions options;
  options.rays = 4;
  RaycastFormFactors ff(s->scene, s->mesh, options);
  System streaming(s->scene, s->mesh, ff);
  // Conjugate gradients cannot check reciprocity without the matrix: it must be told to
  // symmetrise.
  auto solver =
      GetParam() == "conjugate-gradient" ? make(GetParam(), {"symmetrise=true"}) : make(GetParam());
  solver->init(streaming);
  const uint64_t after_init = streaming.rows_used();
  long long steps = 0;
  while (streaming.rows_used() < 30 * s->n()) {
    if (solver->step().finished) break;
    ++steps;
  }
  if (GetParam() != "conjugate-gradient") {
    EXPECT_EQ(streaming.rows_used() - after_init, uint64_t(steps));
  } else {
    EXPECT_EQ(streaming.rows_used(), uint64_t(steps + 1) * s->n());  // all reflect
  }
  EXPECT_LE(max_relative_error(solver->solution(), s->reference.B), 1e-5) << GetParam();
}

std::vector<std::string> registered_solvers() {
  std::vector<std::string> names;
  for (const SolverInfo& entry : solver_registry()) names.push_back(entry.name);
  return names;
}

std::string test_name(const ::testing::TestParamInfo<std::string>& param) {
  std::string name = param.param;
  for (char& c : name)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  return name;
}

INSTANTIATE_TEST_SUITE_P(Registry, EverySolver, ::testing::ValuesIn(registered_solvers()),
                         test_name);

// ---------------------------------------------------------------------------------------------
// Variants beyond the defaults reach the reference too.

struct Variant {
  std::string solver;
  std::vector<std::string> params;
};

std::vector<std::string> split_params(const std::string& spec) {
  std::vector<std::string> out;
  size_t start = 0;
  while (start < spec.size()) {
    size_t comma = spec.find(',', start);
    if (comma == std::string::npos) comma = spec.size();
    out.push_back(spec.substr(start, comma - start));
    start = comma + 1;
  }
  return out;
}

class SolverVariant : public ::testing::TestWithParam<std::string> {
 protected:
  // "name" or "name:k=v,k=v"
  std::unique_ptr<Solver> create() const {
    const std::string& spec = GetParam();
    const size_t colon = spec.find(':');
    if (colon == std::string::npos) return make(spec);
    return make(spec.substr(0, colon), split_params(spec.substr(colon + 1)));
  }
};

TEST_P(SolverVariant, ReachesTheReferenceOnTheCube) {
  auto s = setup("cube:rho=0.9", 2, Precision::kFloat, /*symmetrised=*/true);
  auto solver = create();
  s->system->reset_counters();
  solver->init(*s->system);
  double error = 1.0;
  for (long long step = 0; s->system->rows_used() < 2000 * s->n() && error > 1e-9; ++step) {
    if (solver->step().finished) break;
    if (step % 64 == 0) error = max_relative_error(solver->solution(), s->reference.B);
  }
  EXPECT_LE(max_relative_error(solver->solution(), s->reference.B), 1e-9) << GetParam();
}

INSTANTIATE_TEST_SUITE_P(
    Variants, SolverVariant,
    ::testing::Values("sorted-shooting:omega=1.5", "sorted-shooting:omega=0.7",
                      "sorted-shooting:ambient=true", "overshooting:variant=ambient",
                      "overshooting:variant=ambient,clamp=true", "overshooting:clamp=true",
                      "interleaved:shots=5,gathers=5",
                      "interleaved:shots=3,gathers=7,max_sessions=2", "interleaved:gathers=0",
                      "conjugate-gradient:preconditioner=none",
                      "conjugate-gradient:symmetrise=true"),
    test_name);

// ---------------------------------------------------------------------------------------------
// Monotone approach from below.

class MonotoneFromBelow : public SolverVariant {};

TEST_P(MonotoneFromBelow, NoCheckpointWorseThanTheLast) {
  // From B = E with J >= 0 (and exact reciprocity, so shooting's fixed point is the reference's:
  // a double-precision symmetrised matrix), each of these methods only ever adds non-negative
  // amounts: every element rises and stays below the solution, so the error never grows.
  // Slack: 1e-12 relative for double rounding (values are sums of <= 80 positive terms) plus the
  // reference's certified bound.
  auto s = setup("cornell", 2, Precision::kDouble, /*symmetrised=*/true);
  auto solver = create();
  solver->init(*s->system);
  const auto area = s->system->area();
  const double slack = 1e-12;
  Radiosity last = solver->solution();
  double last_error = 1e300;
  for (int checkpoint = 0; checkpoint < 60; ++checkpoint) {
    for (size_t k = 0; k < s->n() / 4; ++k) solver->step();
    const Radiosity& B = solver->solution();
    double error = 0.0;  // area-weighted L1 error over the channels
    for (int c = 0; c < s->channels(); ++c)
      for (size_t i = 0; i < s->n(); ++i) {
        const double ref = s->reference.B.at(c, i);
        ASSERT_LE(B.at(c, i), ref * (1 + slack) + s->reference.bound_inf)
            << GetParam() << " element " << i << " checkpoint " << checkpoint;
        ASSERT_GE(B.at(c, i), last.at(c, i) * (1 - slack))
            << GetParam() << " element " << i << " checkpoint " << checkpoint;
        error += area[i] * std::abs(ref - B.at(c, i));
      }
    ASSERT_LE(error, last_error * (1 + slack) + 1e-12) << GetParam() << " " << checkpoint;
    last_error = error;
    last = B;
  }
  if (auto* il = dynamic_cast<const InterleavedSolver*>(solver.get())) {
    EXPECT_GT(il->live_sessions(), 0u) << "the run should have gathered";
  }
}

INSTANTIATE_TEST_SUITE_P(Solvers, MonotoneFromBelow,
                         ::testing::Values("jacobi", "gauss-seidel", "shooting", "sorted-shooting",
                                           "interleaved:shots=20,gathers=10"),
                         test_name);

// Gathering from B = E with non-negative J: every iterate lies below the solution and no
// element ever decreases; after each sweep Gauss–Seidel lies above Jacobi element-wise.
TEST(Gathering, MonotoneFromBelowAndGaussSeidelAheadOfJacobi) {
  auto s = setup("cornell", 2);
  auto jacobi = make("jacobi");
  auto gs = make("gauss-seidel");
  jacobi->init(*s->system);
  gs->init(*s->system);
  const size_t n = s->mesh.size();
  Radiosity last_j = jacobi->solution(), last_g = gs->solution();
  const double slack = 1e-12;  // rounding of the double accumulations
  for (int sweep = 0; sweep < 6; ++sweep) {
    for (size_t k = 0; k < n; ++k) {
      jacobi->step();
      gs->step();
    }
    const Radiosity& J = jacobi->solution();
    const Radiosity& G = gs->solution();
    for (int c = 0; c < 3; ++c)
      for (size_t i = 0; i < n; ++i) {
        const double ref = s->reference.B.at(c, i);
        EXPECT_LE(J.at(c, i), ref * (1 + slack) + s->reference.bound_inf);
        EXPECT_LE(G.at(c, i), ref * (1 + slack) + s->reference.bound_inf);
        EXPECT_GE(J.at(c, i), last_j.at(c, i) * (1 - slack));
        EXPECT_GE(G.at(c, i), last_g.at(c, i) * (1 - slack));
        EXPECT_GE(G.at(c, i), J.at(c, i) * (1 - slack)) << "sweep " << sweep;
      }
    last_j = J;
    last_g = G;
  }
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
          EXPECT_LE(q, sys.max_reflectance() * (1 + 1e-6)) << spec;  // rows sum to <= 1 here
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

// ---------------------------------------------------------------------------------------------
// Interleaving.

TEST(Interleaved, NoEnergyCountedTwiceAgainstABruteForceModel) {
  // The model stores, for every receiver r and source j, P[r][j]: how much of j's unshot
  // radiosity r has already gathered. A gather at r takes, from every j, what j holds unshot as
  // of the session's start and r has not taken yet; a shot of s from i delivers to each receiver
  // only what it had not gathered in advance. This is Wu & Wang's bookkeeping in its plainest
  // form (n^2 memory). The solver must agree with it after every step, given the same actions.
  // Exact reciprocity (double, symmetrised) is needed for the two to coincide: the gather reads
  // F_rj, the shots deliver F_jr A_j / A_r. Tolerance 1e-11 of the largest radiosity: both
  // compute the same quantities in double with different association over <= 400 steps.
  auto s = setup("cornell", 2, Precision::kDouble, /*symmetrised=*/true);
  const System& sys = *s->system;
  const size_t n = s->n();
  const int C = s->channels();
  auto solver = make("interleaved", {"shots=10", "gathers=8", "max_sessions=1000"});
  const auto& il = dynamic_cast<const InterleavedSolver&>(*solver);
  solver->init(sys);

  Radiosity dB = sys.emission(), x(C, n), snapshot;
  std::vector<double> P(size_t(C) * n * n, 0.0);
  auto pre = [&](int c, size_t r, size_t j) -> double& { return P[(size_t(c) * n + r) * n + j]; };
  auto Fp = [&](size_t j, size_t i) {  // F'_ji as shots apply it
    return s->matrix.at(i, j) * sys.area()[i] / sys.area()[j];
  };
  bool previous_was_gather = false;
  int gathers = 0, paid_down = 0;
  double scale = max_abs(sys.emission());
  for (int step = 1; step <= 400; ++step) {
    const Radiosity advance_before = il.advance();
    solver->step();
    const auto action = il.last_action();
    if (action.gather) {
      ++gathers;
      const size_t r = action.element;
      if (!previous_was_gather) {  // a gathering session starts: snapshot of B = x + dB
        snapshot = x;
        for (size_t k = 0; k < x.raw().size(); ++k) snapshot.raw()[k] += dB.raw()[k];
      }
      for (int c = 0; c < C; ++c)
        for (size_t j = 0; j < n; ++j) {
          const double outstanding = std::max(snapshot.at(c, j) - x.at(c, j), 0.0);
          const double take = outstanding - pre(c, r, j);
          pre(c, r, j) = outstanding;
          dB.at(c, r) += sys.reflectance().at(c, r) * s->matrix.at(r, j) * take;
        }
    } else {
      const size_t i = action.element;
      for (int c = 0; c < C; ++c) {
        const double shot = dB.at(c, i);
        ASSERT_GE(shot, 0.0);
        for (size_t j = 0; j < n; ++j) {
          const double excluded = std::min(shot, pre(c, j, i));
          pre(c, j, i) -= excluded;
          dB.at(c, j) += sys.reflectance().at(c, j) * Fp(j, i) * (shot - excluded);
        }
        dB.at(c, i) -= shot;
        x.at(c, i) += shot;
      }
      paid_down += max_abs(minus(il.advance(), advance_before)) > 0;
    }
    previous_was_gather = action.gather;

    Radiosity B = x;
    for (size_t k = 0; k < B.raw().size(); ++k) B.raw()[k] += dB.raw()[k];
    scale = std::max(scale, max_abs(B));
    ASSERT_LE(max_abs(minus(solver->solution(), B)), 1e-11 * scale) << "step " << step;
    ASSERT_LE(max_abs(minus(*solver->unshot(), dB)), 1e-11 * scale) << "step " << step;
    // The advance is the reflected part of everything received early and not yet shot.
    for (int c = 0; c < C; ++c)
      for (size_t r = 0; r < n; ++r) {
        double a = 0.0;
        for (size_t j = 0; j < n; ++j) a += Fp(r, j) * pre(c, r, j);
        a *= sys.reflectance().at(c, r);
        ASSERT_NEAR(il.advance().at(c, r), a, 1e-11 * scale) << "step " << step;
      }
  }
  EXPECT_GT(gathers, 100);
  EXPECT_GT(paid_down, 10) << "shots should have delivered less to elements that gathered";
}

TEST(Interleaved, UnshotMinusAdvanceIsTheResidualForAnyFormFactors) {
  // DESIGN §2's invariant with the advance: dB - a = E + J'x - x, x = B - dB, on the raw
  // non-reciprocal matrix, with session retirement (max_sessions=2) exercised. Tolerance as for
  // the shooting solvers.
  auto s = setup("cornell", 2);
  const double scale = max_abs(s->system->emission());
  for (const char* sessions : {"max_sessions=2", "max_sessions=32"}) {
    auto solver = make("interleaved", {"shots=10", "gathers=8", sessions});
    const auto& il = dynamic_cast<const InterleavedSolver&>(*solver);
    solver->init(*s->system);
    for (int step = 1; step <= 300; ++step) {
      solver->step();
      if (step % 7 != 0) continue;
      const Radiosity x = minus(solver->solution(), *solver->unshot());
      const Radiosity expected = minus(*solver->unshot(), il.advance());
      EXPECT_LE(max_abs(minus(shooting_residual(*s, x), expected)), 1e-13 * scale)
          << sessions << " step " << step;
    }
  }
}

TEST(Interleaved, ReciprocalInvariantIsDesignsWithTheAdvance) {
  // With reciprocal form factors the residual of B - dB in the System's own equation is dB - a.
  auto s = setup("cornell", 2, Precision::kDouble, /*symmetrised=*/true);
  auto solver = make("interleaved", {"shots=10", "gathers=8"});
  const auto& il = dynamic_cast<const InterleavedSolver&>(*solver);
  solver->init(*s->system);
  const double scale = max_abs(s->system->emission());
  for (int step = 1; step <= 200; ++step) {
    solver->step();
    if (step % 9 != 0) continue;
    const Radiosity x = minus(solver->solution(), *solver->unshot());
    EXPECT_LE(max_abs(minus(gathering_residual(*s, x), minus(*solver->unshot(), il.advance()))),
              1e-12 * scale)
        << "step " << step;
  }
}

TEST(Interleaved, WithoutGathersItIsSortedShootingAndRecordsCoverage) {
  auto s = setup("cornell", 2);
  const System& sys = *s->system;
  auto sorted = make("sorted-shooting");
  auto interleaved = make("interleaved", {"shots=25", "gathers=0"});
  const auto& il = dynamic_cast<const InterleavedSolver&>(*interleaved);
  sorted->init(sys);
  interleaved->init(sys);
  std::vector<size_t> shooters;
  for (int k = 0; k < 60; ++k) {
    sorted->step();
    interleaved->step();
    shooters.push_back(il.last_action().element);
    ASSERT_FALSE(il.last_action().gather);
  }
  for (size_t e = 0; e < sorted->solution().raw().size(); ++e)
    ASSERT_EQ(sorted->solution().raw()[e], interleaved->solution().raw()[e]);
  // dff_j = sum over the shots of F_ji = F_ij A_i / A_j (receivers j != i); tolerance: double
  // sums of <= 60 terms.
  const ShotCoverage* coverage = interleaved->shot_coverage();
  ASSERT_NE(coverage, nullptr);
  EXPECT_EQ(coverage->session, 1);
  for (size_t j = 0; j < s->n(); ++j) {
    double dff = 0.0;
    bool shot = false;
    for (size_t i : shooters) {
      if (i == j) shot = true;
      if (i != j) dff += s->matrix.at(i, j) * sys.area()[i] / sys.area()[j];
    }
    EXPECT_NEAR(coverage->form_factor_sum[j], dff, 1e-12 * std::max(1.0, dff)) << j;
    EXPECT_EQ(coverage->shot[j] != 0, shot) << j;
  }
  EXPECT_EQ(sorted->shot_coverage(), nullptr);
}

TEST(Interleaved, GathersAtTheLeastCoveredNonShooters) {
  auto s = setup("cornell", 2);
  auto solver = make("interleaved", {"shots=12", "gathers=6"});
  const auto& il = dynamic_cast<const InterleavedSolver&>(*solver);
  solver->init(*s->system);
  for (int session = 0; session < 3; ++session) {
    for (int k = 0; k < 12; ++k) {
      solver->step();
      ASSERT_FALSE(il.last_action().gather);
    }
    // The coverage of the session that just ended decides the gathers.
    const ShotCoverage& coverage = *solver->shot_coverage();
    std::vector<std::pair<double, size_t>> order;
    for (size_t j = 0; j < s->n(); ++j)
      if (!coverage.shot[j]) order.push_back({coverage.form_factor_sum[j], j});
    std::sort(order.begin(), order.end());
    const std::vector<std::pair<double, size_t>> expected(order.begin(), order.begin() + 6);
    for (int k = 0; k < 6; ++k) {
      solver->step();
      ASSERT_TRUE(il.last_action().gather);
      EXPECT_EQ(il.last_action().element, expected[size_t(k)].second) << session << " " << k;
    }
    EXPECT_EQ(solver->shot_coverage()->session, session + 2);
  }
}

// ---------------------------------------------------------------------------------------------
// Conjugate gradients.

TEST(ConjugateGradient, RefusesNonReciprocalFormFactors) {
  auto s = setup("cornell", 2);  // raw: relative reciprocity defect up to 1
  auto solver = make("conjugate-gradient");
  try {
    solver->init(*s->system);
    FAIL() << "expected a UsageError";
  } catch (const UsageError& e) {
    EXPECT_NE(std::string(e.what()).find("reciprocal"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("symmetrise=true"), std::string::npos) << e.what();
  }
  // On-the-fly rows cannot be checked.
  RaycastOptions options;
  options.rays = 4;
  RaycastFormFactors ff(s->scene, s->mesh, options);
  System streaming(s->scene, s->mesh, ff);
  EXPECT_THROW(make("conjugate-gradient")->init(streaming), UsageError);
}

TEST(ConjugateGradient, SymmetriseSolvesTheSymmetrisedSystem) {
  // On the raw matrix, symmetrise=true must reach the reference of the symmetrised system
  // (computed here from a double copy, symmetrised exactly) to 1e-9: certified reference bound
  // ~1e-12, and the one-pass symmetric product is exact up to double rounding.
  auto s = setup("cornell", 2);
  FormFactorMatrix sym(s->n(), Precision::kDouble);
  for (size_t i = 0; i < s->n(); ++i)
    for (size_t j = 0; j < s->n(); ++j) sym.set(i, j, s->matrix.at(i, j));
  symmetrise(sym, s->mesh.area);
  System sym_system(s->scene, s->mesh, sym);
  const Reference sym_reference = compute_reference(sym_system, sym);
  auto solver = make("conjugate-gradient", {"symmetrise=true"});
  solver->init(*s->system);
  for (int k = 0; k < 200; ++k)
    if (solver->step().finished) break;
  EXPECT_LE(max_relative_error(solver->solution(), sym_reference.B), 1e-9);
  // ... which is not this System's solution: the defect shows.
  EXPECT_GT(max_relative_error(solver->solution(), s->reference.B), 1e-5);
}

TEST(ConjugateGradient, ErrorNeverGrowsInTheSystemNorm) {
  // CG minimises (B - B*)^T M (B - B*) over growing Krylov spaces, so the M-norm of the error
  // cannot grow. M_ij = (A_i/rho_i) delta_ij - A_i F_ij, exactly symmetric for the double
  // symmetrised matrix. Slack: 1e-12 of the initial norm (rounding of the products).
  auto s = setup("cornell", 2, Precision::kDouble, /*symmetrised=*/true);
  const System& sys = *s->system;
  const size_t n = s->n();
  for (const char* preconditioner : {"preconditioner=jacobi", "preconditioner=none"}) {
    auto solver = make("conjugate-gradient", {preconditioner});
    solver->init(sys);
    std::vector<double> last(3, 1e300), first(3, -1.0);
    for (int k = 0; k < 160; ++k) {
      const Radiosity e = minus(solver->solution(), s->reference.B);
      for (int c = 0; c < 3; ++c) {
        long double norm = 0.0L;
        for (size_t i = 0; i < n; ++i) {
          long double Me = sys.area()[i] / sys.reflectance().at(c, i) * e.at(c, i);
          for (size_t j = 0; j < n; ++j)
            Me -= static_cast<long double>(sys.area()[i]) * s->matrix.at(i, j) * e.at(c, j);
          norm += e.at(c, i) * Me;
        }
        if (first[size_t(c)] < 0) first[size_t(c)] = double(norm);
        EXPECT_GE(norm, -1e-12 * first[size_t(c)]);
        EXPECT_LE(double(norm), last[size_t(c)] + 1e-12 * first[size_t(c)])
            << preconditioner << " iteration " << k << " channel " << c;
        last[size_t(c)] = double(norm);
      }
      if (solver->step().finished) break;
    }
    EXPECT_LE(max_relative_error(solver->solution(), s->reference.B), 1e-9) << preconditioner;
  }
}

TEST(ConjugateGradient, EliminatesBlackElementsAndCountsItsRows) {
  // A cube with a black light (rho = 0 in every channel) and walls black in the green channel:
  // those entries are known (B = E) and eliminated. Every step reads one row per element that
  // reflects in some channel, and the solution matches the reference.
  Scene scene = make_builtin_scene("cube:rho=0.8");
  for (Material& m : scene.materials) {
    if (m.emits())
      m.reflectance = Rgb(0.0);
    else
      m.reflectance = Rgb(0.8, 0.0, 0.5);
  }
  auto s = setup_scene(scene, 2, Precision::kFloat, /*symmetrised=*/true);
  ASSERT_EQ(s->channels(), 3);
  size_t reflecting = 0;
  for (size_t i = 0; i < s->n(); ++i) reflecting += s->system->reflectance().at(0, i) > 0;
  ASSERT_LT(reflecting, s->n());
  auto solver = make("conjugate-gradient");
  s->system->reset_counters();
  solver->init(*s->system);
  EXPECT_EQ(s->system->rows_used(), reflecting);  // the initial residual
  for (int k = 1; k <= 30; ++k) {
    const bool finished = solver->step().finished;
    EXPECT_EQ(s->system->rows_used(), reflecting * size_t(k + 1));
    if (finished) break;
  }
  EXPECT_LE(max_relative_error(solver->solution(), s->reference.B), 1e-9);
  for (size_t i = 0; i < s->n(); ++i)
    EXPECT_EQ(solver->solution().at(1, i), s->system->emission().at(1, i));
}

// ---------------------------------------------------------------------------------------------
// Registry and options.

TEST(Registry, CountsTheSolvers) {
  // jacobi, gauss-seidel (foundation); shooting, sorted-shooting, overshooting, interleaved,
  // conjugate-gradient (issue 4).
  EXPECT_EQ(solver_registry().size(), 7u);
}

TEST(Registry, UnknownSolverAndKeyListTheValidOnes) {
  ParamBag bag("test");
  try {
    make_solver("no-such-solver", bag);
    FAIL();
  } catch (const UsageError& e) {
    EXPECT_NE(std::string(e.what()).find("gauss-seidel"), std::string::npos);
  }
  ParamBag bad = ParamBag::from_assignments({"omga=1.2"}, "solver 'gauss-seidel'");
  try {
    make_solver("gauss-seidel", bad);
    FAIL();
  } catch (const UsageError& e) {
    EXPECT_NE(std::string(e.what()).find("omega"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("omga"), std::string::npos) << e.what();
  }
  ParamBag out_of_range = ParamBag::from_assignments({"omega=2.5"}, "solver 'gauss-seidel'");
  EXPECT_THROW(make_solver("gauss-seidel", out_of_range), UsageError);
}

TEST(Registry, InvalidOptionsNameTheFieldAndValue) {
  const std::vector<std::pair<std::string, std::vector<std::string>>> bad = {
      {"sorted-shooting", {"omega=2"}},
      {"sorted-shooting", {"ambient=maybe"}},
      {"overshooting", {"variant=sideways"}},
      {"interleaved", {"shots=0"}},
      {"interleaved", {"gathers=-1"}},
      {"interleaved", {"max_sessions=0"}},
      {"conjugate-gradient", {"preconditioner=ilu"}},
      {"conjugate-gradient", {"reciprocity_tolerance=-1"}},
      {"shooting", {"omega=1"}},
  };
  for (const auto& [name, params] : bad) {
    try {
      make(name, params);
      ADD_FAILURE() << name << " accepted " << params[0];
    } catch (const UsageError& e) {
      const std::string key = params[0].substr(0, params[0].find('='));
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace radlab
