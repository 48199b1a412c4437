// Bad input to the Monte Carlo solvers through `radlab solve` (issue 32 item 7): rays or walks per
// step <= 0, NaN or negative parameters, more than `--limits rays=`, a reflectance of 1 for
// random walks, a scene without emitters. Each is refused before any ray with the documented exit
// code (2 usage, 3 invalid input) and a message naming the parameter or the cause; nothing is
// written that could pass for a result.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "tests/test_support.h"

namespace radlab {
namespace {

struct Case {
  std::string arguments;  // after `radlab`
  int code;
  std::vector<std::string> message;
};

TEST(MonteCarloInput, RefusedWithTheExitCodeAndTheCause) {
  testing::TempDir dir;
  const std::string solve = "solve builtin:cube --steps 2 --reference none ";
  const std::vector<Case> cases = {
      {solve + "--solver stochastic-jacobi --set rays=0", 2, {"rays", "got 0"}},
      {solve + "--solver stochastic-jacobi --set rays=-4", 2, {"rays"}},
      {solve + "--solver stochastic-jacobi --set rays=nan", 2, {"rays"}},
      {solve + "--solver stochastic-jacobi --set control_variate=-1", 2, {"control_variate"}},
      {solve + "--solver stochastic-jacobi --set seed=-2", 2, {"seed"}},
      {solve + "--solver random-walk --set paths=0", 2, {"paths"}},
      {solve + "--solver random-walk --set paths=nan", 2, {"paths"}},
      {solve + "--solver random-walk --set seed=-1", 2, {"seed"}},
      {solve + "--solver random-walk --set estimator=none", 2, {"estimator"}},
      // Beyond the rays limit: the value given, and the default (checked at the run's start).
      {"--limits rays=1000 " + solve + "--solver stochastic-jacobi --set rays=5000",
       3,
       {"rays=5000", "--limits rays="}},
      {"--limits rays=1000 " + solve + "--solver stochastic-jacobi",
       3,
       {"rays=10000", "--limits rays="}},
      {"--limits rays=1000 " + solve + "--solver random-walk --set paths=2000",
       3,
       {"paths=2000", "--limits rays="}},
      // Walks that would never end.
      {"solve builtin:furnace:rho=1 --steps 2 --reference none --solver random-walk",
       3,
       {"random-walk", "reflects 1", "never end"}},
      // Nothing emits.
      {"solve builtin:cube:emission=0 --steps 2 --reference none --solver random-walk",
       3,
       {"no emitter"}},
  };
  for (const Case& c : cases) {
    const std::string trace = dir.file("t.csv");
    const testing::CommandResult r = testing::run_command(
        "timeout 120 " + std::string(RADLAB_BINARY) + " " + c.arguments + " --trace " + trace);
    EXPECT_EQ(r.code, c.code) << c.arguments << "\n" << r.output;
    for (const std::string& part : c.message)
      EXPECT_NE(r.output.find(part), std::string::npos)
          << c.arguments << ": '" << part << "' missing from\n"
          << r.output;
    EXPECT_FALSE(std::filesystem::exists(trace)) << c.arguments << " wrote a trace";
  }
}

}  // namespace
}  // namespace radlab
