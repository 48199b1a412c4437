// Every registered solver, on scenes whose answer is known: convergence to the certified
// reference, and the monotone approach from below that gathering from B = E guarantees.
#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
#include "formfactor/raycast.h"
#include "metrics/error_metrics.h"
#include "scene/builtin_scenes.h"
#include "scene/validate.h"
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
};

std::unique_ptr<Setup> setup(const std::string& spec, int subdiv) {
  auto s = std::make_unique<Setup>();
  s->scene = make_builtin_scene(spec);
  validate_scene(s->scene);
  s->mesh = build_mesh(s->scene, {subdiv, 0.0});
  RaycastOptions options;
  options.rays = 4;
  RaycastFormFactors ff(s->scene, s->mesh, options);
  BuildReport report;
  s->matrix = build_matrix(ff, s->mesh.size(), Precision::kFloat, report);
  s->system = std::make_unique<System>(s->scene, s->mesh, s->matrix);
  s->reference = compute_reference(*s->system, s->matrix);
  return s;
}

double max_relative_error(const Radiosity& B, const Radiosity& ref) {
  double worst = 0.0;
  for (int c = 0; c < ref.channels(); ++c)
    for (size_t i = 0; i < ref.size(); ++i)
      worst = std::max(worst, std::abs(B.at(c, i) - ref.at(c, i)) / std::abs(ref.at(c, i)));
  return worst;
}

class EverySolver : public ::testing::TestWithParam<std::string> {};

TEST_P(EverySolver, ReachesTheReference) {
  for (const char* spec : {"cube:rho=0.5", "cube:rho=0.9", "furnace:rho=0.7"}) {
    auto s = setup(spec, 2);
    ParamBag none("test");
    auto solver = make_solver(GetParam(), none);
    solver->init(*s->system);
    const long long limit = 2000 * static_cast<long long>(s->mesh.size());
    long long step = 0;
    double error = 1.0;
    for (; step < limit && error > 1e-9; ++step) {
      if (solver->step().finished) break;
      if (step % 64 == 0) error = max_relative_error(solver->solution(), s->reference.B);
    }
    error = max_relative_error(solver->solution(), s->reference.B);
    EXPECT_LE(error, 1e-9) << GetParam() << " on " << spec << " after " << step << " steps";
  }
}

TEST_P(EverySolver, ReachesTheCornellReferenceWithinABudget) {
  auto s = setup("cornell", 2);
  ParamBag none("test");
  auto solver = make_solver(GetParam(), none);
  solver->init(*s->system);
  // 60 sweeps' worth of rows: rho <= 0.78 gives a contraction of at most ~0.78 per sweep.
  for (size_t k = 0; k < 60 * s->mesh.size(); ++k)
    if (solver->step().finished) break;
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
    if (c == '-') c = '_';
  return name;
}

INSTANTIATE_TEST_SUITE_P(Registry, EverySolver, ::testing::ValuesIn(registered_solvers()),
                         test_name);

// Gathering from B = E with non-negative J: every iterate lies below the solution and no
// element ever decreases; after each sweep Gauss–Seidel lies above Jacobi element-wise.
TEST(Gathering, MonotoneFromBelowAndGaussSeidelAheadOfJacobi) {
  auto s = setup("cornell", 2);
  ParamBag a("test"), b("test");
  auto jacobi = make_solver("jacobi", a);
  auto gs = make_solver("gauss-seidel", b);
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

TEST(Registry, CountsTheSolvers) {
  // jacobi and gauss-seidel (foundation).
  EXPECT_EQ(solver_registry().size(), 2u);
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

}  // namespace
}  // namespace radlab
