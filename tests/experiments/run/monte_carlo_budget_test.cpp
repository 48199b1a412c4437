// Budgets for the Monte Carlo solvers (issue 32.1): stochastic-jacobi reads no form-factor row and
// never finishes by itself, so a budget in rows alone (or a tolerance alone, which the runner
// caps in rows) would run forever. The runner refuses it with a usage error naming the solver
// and what to give instead; a steps budget runs; an experiment's "all" leaves it out.
#include <gtest/gtest.h>

#include <string>

#include "core/error.h"
#include "core/param_bag.h"
#include "experiments/problem/problem.h"
#include "experiments/run/runner.h"
#include "solvers/registry.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

RunResult run(const Problem& p, const Budget& budget) {
  ParamBag bag = ParamBag::from_assignments({"rays=500"}, "solver");
  auto solver = make_solver("stochastic-jacobi", bag);
  RunLabels labels{"sj", p.spec.scene, "stochastic-jacobi", bag.canonical()};
  return run_solver(*solver, p, budget, CheckpointSchedule{}, labels, nullptr);
}

TEST(MonteCarloBudget, RowsAloneAreRefusedStepsRun) {
  testing::TempDir dir;
  ProblemSpec spec;
  spec.scene = "builtin:cube";
  spec.cache_dir = dir.path().string();
  auto p = prepare_problem(spec);
  Budget rows;
  rows.rows = 100;
  try {
    run(*p, rows);
    FAIL() << "a rows-only budget was accepted";
  } catch (const UsageError& e) {
    EXPECT_NE(std::string(e.what()).find("stochastic-jacobi"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("steps"), std::string::npos) << e.what();
  }
  Budget steps;
  steps.steps = 5;
  const RunResult r = run(*p, steps);
  EXPECT_EQ(r.stop_reason, "step budget");
  EXPECT_TRUE(needs_step_or_time_budget("stochastic-jacobi"));
  EXPECT_TRUE(needs_step_or_time_budget("random-walk"));
  EXPECT_FALSE(needs_step_or_time_budget("no-such-solver"));
  EXPECT_FALSE(needs_step_or_time_budget("hierarchical"));  // it finishes at its fixed point
}

}  // namespace
}  // namespace radlab
