// The gathering solvers on the furnace (against its analytic answer) and conjugate gradients'
// preconditions and A-norm descent. The tests every solver passes are in
// tests/solvers/conformance_test.cpp, the shooting family's in
// tests/solvers/flat/shooting_test.cpp, the interleaving's in
// tests/solvers/flat/interleaved_test.cpp.
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
#include "formfactor/methods/hemicube.h"
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
// Conjugate gradients.

// A matrix that is not reciprocal: the hemicube's rows, each from one point of its element (raycast
// integrates every unoccluded pair once, so its raw matrix is reciprocal to rounding).
std::unique_ptr<testing::Setup> hemicube_setup(const std::string& spec, int subdiv) {
  return testing::setup_scene_with(make_builtin_scene(spec), subdiv, Precision::kFloat, false,
                                   [](const Scene& scene, const Mesh& mesh) {
                                     return std::make_unique<HemicubeFormFactors>(
                                         scene, mesh, HemicubeOptions{});
                                   });
}

TEST(ConjugateGradient, RefusesNonReciprocalFormFactors) {
  auto s = hemicube_setup("cornell", 2);  // raw hemicube rows: relative reciprocity defect ~1
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
  auto s = hemicube_setup("cornell", 2);
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

}  // namespace
}  // namespace radlab
