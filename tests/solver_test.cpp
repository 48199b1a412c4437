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
#include <map>

#include "core/error.h"
#include "core/random.h"
#include "formfactor/exact.h"
#include "formfactor/raycast.h"
#include "metrics/error_metrics.h"
#include "scene/builtin_scenes.h"
#include "scene/validate.h"
#include "solvers/interleaved.h"
#include "solvers/kernels.h"
#include "solvers/reference.h"
#include "solvers/registry.h"
#include "solvers/shooting_core.h"
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

// The one registered solver that does not solve the flat system (its own discretisation): the
// tests say what it cannot satisfy and what they assert instead.
const std::string kHierarchical = "hierarchical";

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
    if (GetParam() == kHierarchical) {
      // Cannot satisfy 1e-9: a different discretisation (quadtrees, estimated link form factors),
      // projected on this mesh; its fixed point differs from the flat reference by its
      // refinement error, amplified by the multiple reflections (~1/(1-rho)). Asserted instead:
      // within 2.5%/(1-rho) (max relative; the default feps = 0.01 gives 1-3% at rho = 0.5,
      // ~10% at rho = 0.9).
      const double bound = 0.025 / (1.0 - s->system->max_reflectance());
      EXPECT_LE(error, bound) << spec << " after " << step << " steps";
      continue;
    }
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
  // hierarchical reads no rows (run_rows stops when it reaches its fixed point) and cannot reach
  // 1e-5 of the flat reference (see ReachesTheReference): asserted within its rms floor instead.
  if (GetParam() == kHierarchical) {
    EXPECT_LE(
        compare(solver->solution(), s->reference.B, s->system->area(), kMeanOfChannels).rms_rel,
        2e-2);
    return;
  }
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
    ++steps;  // the step that finishes reads rows too (conjugate gradients stop at rounding)
    if (solver->step().finished) break;
  }
  if (GetParam() == kHierarchical) {
    // It evaluates its own link form factors: no rows, and its own floor (ReachesTheReference).
    EXPECT_EQ(streaming.rows_used(), 0u);
    EXPECT_GT(streaming.pair_evaluations(), 0u);
    EXPECT_LE(max_relative_error(solver->solution(), s->reference.B), 5e-2);
    return;
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

// The monotone approach from below and Gauss–Seidel ahead of Jacobi are in
// tests/orderings_test.cpp (ctest label `orderings`), on several scene families.

// ---------------------------------------------------------------------------------------------
// The furnace against its analytic answer.
//
// Every face of a closed box emits e and reflects rho: B = e / (1 - rho) on every element when the
// rows of F sum to 1, whatever the mesh. The test compares the gathering solvers with that value,
// not with the reference, on cubic and non-cubic boxes, coarse and fine meshes, rho up to 0.99.
//
// Form factors: `exact` (adaptive quadrature, 1e-9 relative per pair) in double, so the rows sum to
// 1 within delta = max_i |sum_j F_ij - 1| (~1e-12 to 4e-11 here), measured in long double and
// used in the bound (and required to be <= 1e-9, or the bound would say little). With q = rho (1 +
// delta)
// (>= the inf-norm of J = rho F), the tolerance on |B_i - e/(1-rho)| after k sweeps is the sum of
//   - discretisation: the solution B_d of the discrete system has residual rho e (s_i - 1)/(1-rho)
//     at the analytic value, so |B_d - B*| <= rho delta B* / (1 - q);
//   - iteration: Jacobi's and Gauss-Seidel's errors both contract by q per sweep in the inf-norm
//     (every update is rho sum_j F_ij e_j, F_ii = 0, with old or new e_j), and the start B = E is
//     at most ||B_d|| <= e / (1 - q) away: q^k e / (1 - q);
//   - rounding: each gather of n positive terms is within (n + 3) u of exact (u = 2^-53), an
//     error the later sweeps contract like any other: (n + 3) u (e / (1 - q)) / (1 - q).
// The number of sweeps is chosen from the same rate so that the iteration term is 1e-10 of B*
// (2,300 sweeps at rho = 0.99); the total tolerance is then ~1.1e-10 of B*, the row-sum term
// adding rho delta / (1 - q) <= 4e-9 at rho = 0.99. The bound is sharp: on the cube with one
// element per face every row sums to 1 - 2.6e-11, the discrete solution lies that much (times
// rho / (1 - q)) below e/(1-rho), and Jacobi at rho = 0.99 ends at 0.9996 of the tolerance; leave
// out the row-sum term and the test fails, as it does if the expected value is off by 1e-8.
struct FurnaceBound {
  double analytic, discretisation, rounding, q, e;
  double iteration(long long sweeps) const { return std::pow(q, double(sweeps)) * e / (1 - q); }
};

// One exact matrix per box and mesh (F does not depend on rho), shared by both solvers' runs.
// Quadrature tolerance 1e-9: the rows then sum to 1 within ~1e-11 (measured), and building the
// subdiv-3 meshes takes seconds rather than minutes (the non-cubic box at 1e-10: ~2.5 minutes).
struct FurnaceMatrix {
  FormFactorMatrix F;
  double delta = 0.0;  // max_i |sum_j F_ij - 1|, summed in long double
};

const FurnaceMatrix& furnace_matrix(const std::string& box, int subdiv) {
  static std::map<std::pair<std::string, int>, FurnaceMatrix> cache;
  auto [it, fresh] = cache.try_emplace({box, subdiv});
  if (fresh) {
    Scene geometry = make_builtin_scene(box + "rho=0.5");
    validate_scene(geometry);
    const Mesh mesh = build_mesh(geometry, {subdiv, 0.0});
    ExactOptions options;
    options.tolerance = 1e-9;
    ExactFormFactors ff(geometry, mesh, options);
    BuildReport report;
    it->second.F = build_matrix(ff, mesh.size(), Precision::kDouble, report);
    long double delta = 0.0L;
    for (size_t i = 0; i < mesh.size(); ++i) {
      long double row = 0.0L;
      for (size_t j = 0; j < mesh.size(); ++j) row += it->second.F.at(i, j);
      delta = std::max(delta, std::abs(row - 1.0L));
    }
    it->second.delta = delta;
  }
  return it->second;
}

class Furnace : public ::testing::TestWithParam<std::string> {};

TEST_P(Furnace, GatheringReachesEOverOneMinusRho) {
  const bool jacobi = GetParam() == "jacobi";
  const double u = std::ldexp(1.0, -53);
  const double e = 1.5;
  for (const std::string box : {"furnace:", "furnace:lx=1.5,ly=1,lz=0.75,"}) {
    for (int subdiv : {1, 3}) {
      const FurnaceMatrix& matrix = furnace_matrix(box, subdiv);
      const FormFactorMatrix& F = matrix.F;
      const size_t n = F.size();
      const double delta = matrix.delta;
      for (size_t i = 0; i < n; ++i) ASSERT_EQ(F.at(i, i), 0.0);
      ASSERT_LE(delta, 1e-9) << box << " subdiv " << subdiv;
      for (double rho : {0.3, 0.9, 0.99}) {
        const std::string spec =
            box + "rho=" + std::to_string(rho) + ",emission=" + std::to_string(e);
        Scene scene = make_builtin_scene(spec);
        validate_scene(scene);
        const Mesh scene_mesh = build_mesh(scene, {subdiv, 0.0});
        ASSERT_EQ(scene_mesh.size(), n);
        System sys(scene, scene_mesh, F);
        ASSERT_EQ(sys.channels(), 1);
        FurnaceBound b;
        b.e = e;
        b.analytic = e / (1 - rho);
        b.q = rho * (1 + delta);
        b.discretisation = rho * delta * b.analytic / (1 - b.q);
        b.rounding = double(n + 3) * u * (e / (1 - b.q)) / (1 - b.q);
        const long long sweeps = static_cast<long long>(
            std::ceil(std::log(1e-10 * b.analytic * (1 - b.q) / e) / std::log(b.q)));
        auto solver = make(GetParam());
        solver->init(sys);
        for (long long k = 1; k <= sweeps; ++k) {
          for (size_t step = 0; step < n; ++step) solver->step();
          const Radiosity& B = solver->solution();
          // The a-priori rate, after every sweep: |B_k - B*| <= iteration(k) + the rest.
          const double tolerance = b.iteration(k) + b.discretisation + b.rounding;
          // Jacobi from the uniform E stays uniform: sweep k is the partial geometric series
          // e (1 - rho^(k+1)) / (1 - rho), up to the row-sum defect, which moves the m-th term by
          // at most m delta q^(m-1) rho e: in all rho e delta / (1 - q)^2.
          const double partial = e * (1 - std::pow(rho, double(k + 1))) / (1 - rho);
          const double series_tolerance = rho * e * delta / ((1 - b.q) * (1 - b.q)) + b.rounding;
          for (size_t i = 0; i < n; ++i) {
            ASSERT_LE(std::abs(B.at(0, i) - b.analytic), tolerance)
                << GetParam() << " " << spec << " subdiv " << subdiv << " sweep " << k
                << " element " << i;
            if (jacobi) {
              ASSERT_LE(std::abs(B.at(0, i) - partial), series_tolerance)
                  << spec << " subdiv " << subdiv << " sweep " << k << " element " << i;
            }
          }
        }
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Gathering, Furnace, ::testing::Values("jacobi", "gauss-seidel"),
                         test_name);

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
  //
  // Session retirement is modelled too, independently of the solver's data structures: the model
  // keeps its own list of gathering sessions (snapshot, members = elements whose latest gather
  // was in it). When a gathering session starts it drops (1) every session whose snapshot x has
  // reached everywhere (all its pre-receipts delivered), then (2) the oldest sessions while
  // max_sessions are live; dropping hands back each member's outstanding pre-receipts
  // (dB_r -= rho_r sum_j F'_rj P[r][j], P[r][*] = 0), so the energy arrives later by shooting.
  // A session also ends when all its members have gathered again later. With max_sessions = 1000
  // no session is ever retired for the cap; with 2 and 1 the cap retires sessions that still
  // hold pre-receipts, and the solver must hand back exactly what the model does.
  auto s = setup("cornell", 2, Precision::kDouble, /*symmetrised=*/true);
  const System& sys = *s->system;
  const size_t n = s->n();
  const int C = s->channels();
  auto Fp = [&](size_t j, size_t i) {  // F'_ji as shots apply it
    return s->matrix.at(i, j) * sys.area()[i] / sys.area()[j];
  };
  for (const long long max_sessions : {1000LL, 2LL, 1LL}) {
    SCOPED_TRACE("max_sessions=" + std::to_string(max_sessions));
    auto solver = make("interleaved",
                       {"shots=10", "gathers=8", "max_sessions=" + std::to_string(max_sessions)});
    const auto& il = dynamic_cast<const InterleavedSolver&>(*solver);
    solver->init(sys);

    Radiosity dB = sys.emission(), x(C, n);
    std::vector<double> P(size_t(C) * n * n, 0.0);
    auto pre = [&](int c, size_t r, size_t j) -> double& { return P[(size_t(c) * n + r) * n + j]; };
    struct ModelSession {
      long long id;
      Radiosity snapshot;
      std::vector<size_t> members;
    };
    std::vector<ModelSession> sessions;    // oldest first
    std::vector<long long> latest(n, -1);  // id of r's latest live gathering session
    long long next_id = 0;
    int capped = 0, capped_with_outstanding = 0, delivered_sessions = 0, emptied_sessions = 0;
    // Drops session q, handing back its members' outstanding pre-receipts; returns whether any
    // was outstanding.
    auto retire = [&](size_t q) {
      bool outstanding = false;
      for (size_t r : sessions[q].members) {
        for (int c = 0; c < C; ++c) {
          double a = 0.0;
          for (size_t j = 0; j < n; ++j) {
            a += Fp(r, j) * pre(c, r, j);
            pre(c, r, j) = 0.0;
          }
          a *= sys.reflectance().at(c, r);
          dB.at(c, r) -= a;
          outstanding |= a > 0.0;
        }
        latest[r] = -1;
      }
      sessions.erase(sessions.begin() + std::ptrdiff_t(q));
      return outstanding;
    };

    // The model's own schedule: after every 10th shot of a shooting session a gathering session
    // of 8 gathers starts (the Cornell box has far more than 8 candidates).
    auto start_gathering = [&] {
      for (size_t q = sessions.size(); q-- > 0;) {
        bool passed = true;
        for (size_t k = 0; k < x.raw().size() && passed; ++k)
          passed = x.raw()[k] >= sessions[q].snapshot.raw()[k];
        if (passed) {
          retire(q);
          ++delivered_sessions;
        }
      }
      while (sessions.size() >= size_t(max_sessions)) {
        ++capped;
        capped_with_outstanding += retire(0);
      }
      ModelSession session{next_id++, x, {}};  // snapshot of B = x + dB, after the hand-backs
      for (size_t k = 0; k < x.raw().size(); ++k) session.snapshot.raw()[k] += dB.raw()[k];
      sessions.push_back(std::move(session));
    };
    int shots_in_session = 0, gathers_left = 0;
    int gathers = 0, paid_down = 0;
    double scale = max_abs(sys.emission());
    for (int step = 1; step <= 400; ++step) {
      const Radiosity advance_before = il.advance();
      solver->step();
      const auto action = il.last_action();
      ASSERT_EQ(action.gather, gathers_left > 0) << "step " << step;
      if (action.gather) {
        ++gathers;
        --gathers_left;
        const size_t r = action.element;
        ModelSession& current = sessions.back();
        for (int c = 0; c < C; ++c)
          for (size_t j = 0; j < n; ++j) {
            const double outstanding = std::max(current.snapshot.at(c, j) - x.at(c, j), 0.0);
            const double take = outstanding - pre(c, r, j);
            pre(c, r, j) = outstanding;
            dB.at(c, r) += sys.reflectance().at(c, r) * s->matrix.at(r, j) * take;
          }
        if (latest[r] != current.id) {
          for (size_t q = 0; q + 1 < sessions.size(); ++q) {
            auto& members = sessions[q].members;
            const auto it = std::find(members.begin(), members.end(), r);
            if (it == members.end()) continue;
            members.erase(it);
            if (members.empty()) {
              sessions.erase(sessions.begin() + std::ptrdiff_t(q));
              ++emptied_sessions;
            }
            break;
          }
          sessions.back().members.push_back(r);
          latest[r] = sessions.back().id;
        }
      } else {
        const size_t i = action.element;
        for (int c = 0; c < C; ++c) {
          const double shot = dB.at(c, i);
          ASSERT_GE(shot, 0.0) << "step " << step;
          for (size_t j = 0; j < n; ++j) {
            const double excluded = std::min(shot, pre(c, j, i));
            pre(c, j, i) -= excluded;
            dB.at(c, j) += sys.reflectance().at(c, j) * Fp(j, i) * (shot - excluded);
          }
          dB.at(c, i) -= shot;
          x.at(c, i) += shot;
        }
        paid_down += max_abs(minus(il.advance(), advance_before)) > 0;
        if (++shots_in_session == 10) {
          shots_in_session = 0;
          gathers_left = 8;
          start_gathering();
        }
      }

      ASSERT_EQ(il.live_sessions(), sessions.size()) << "step " << step;
      ASSERT_LE(il.live_sessions(), size_t(max_sessions)) << "step " << step;
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
    // Which ways sessions ended (22 gathering sessions in 400 steps). Without a cap: some sessions
    // emptied by regathers (11 here) and some delivered (1); with max_sessions 2 or 1 the cap
    // retires 20 or 21, each still owed energy when retired.
    if (max_sessions >= 1000) {
      EXPECT_EQ(capped, 0);
      EXPECT_GT(emptied_sessions, 0) << delivered_sessions << " delivered";
    } else {
      EXPECT_GT(capped_with_outstanding, 10)
          << capped << " retired by the cap, " << delivered_sessions << " delivered, "
          << emptied_sessions << " emptied";
    }
  }
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
  // On the raw matrix, symmetrise=true must reach the reference of the plain-average
  // symmetrised system, F_ij <- (A_i F_ij + A_j F_ji) / (2 A_i) (computed here from a double
  // copy) to 1e-9: certified reference bound ~1e-12, and the one-pass symmetric product is exact
  // up to double rounding.
  auto s = setup("cornell", 2);
  FormFactorMatrix sym(s->n(), Precision::kDouble);
  const auto& area = s->mesh.area;
  for (size_t i = 0; i < s->n(); ++i)
    for (size_t j = 0; j < s->n(); ++j)
      sym.set(i, j, 0.5 * (area[i] * s->matrix.at(i, j) + area[j] * s->matrix.at(j, i)) / area[i]);
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
  // hierarchical (issue 9); adaptive-shooting (issue 10).
  EXPECT_EQ(solver_registry().size(), 9u);
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

}  // namespace
}  // namespace radlab
