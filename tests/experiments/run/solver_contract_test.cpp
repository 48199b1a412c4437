// The solver interface's contract, checked by the runner (issue 36.6, runner side): a solution of
// the wrong size fails its run with a clear error instead of being read out of bounds; an
// exception a solver throws fails its run (exit 4 with the message) and a sweep goes on, instead
// of ending as an internal error (exit 1) with sweep.json left "running"; run.json records the
// plugin files that ran with their SHA-256. In-process solvers test the runner's checks; the
// plugin tests/plugins/contract_breaker.cpp tests the same through `radlab --plugin`.
#include <gtest/gtest.h>

#include <filesystem>
#include <memory>
#include <stdexcept>

#include "core/csv_reader.h"
#include "core/error.h"
#include "core/json_reader.h"
#include "core/sha256.h"
#include "experiments/sweep/experiment_spec.h"
#include "experiments/sweep/sweep.h"
#include "solvers/registry.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;

enum class Fault { kWrongSize, kWrongChannels, kThrows, kThrowsInInit, kThrowsWhenWritten };

// The sweep's step budget (sweep_with): the kThrowsWhenWritten solver counts on it.
constexpr int kBudgetSteps = 20;

// Gauss–Seidel with one deliberate breach of the contract.
class BrokenSolver final : public Solver {
 public:
  explicit BrokenSolver(Fault fault) : fault_(fault) {}
  void init(const System& system) override {
    if (fault_ == Fault::kThrowsInInit) throw std::logic_error("init refused on purpose");
    B_ = system.emission();
    if (fault_ == Fault::kWrongSize) wrong_ = Radiosity(B_.channels(), B_.size() + 5);
    if (fault_ == Fault::kWrongChannels) wrong_ = Radiosity(B_.channels() == 1 ? 3 : 1, B_.size());
  }
  StepInfo step() override {
    ++steps_;
    if (fault_ == Fault::kThrows && steps_ == 3)
      throw std::runtime_error("deliberate failure at step 3");
    return {};
  }
  const Radiosity& solution() const override {
    // After the last step the runner reads the solution once for its final checkpoint; the
    // next read is the run's radiosity file, after the run proper.
    if (fault_ == Fault::kThrowsWhenWritten && steps_ == kBudgetSteps && ++reads_after_last_ > 1)
      throw std::runtime_error("deliberate failure when the result is written");
    return fault_ == Fault::kWrongSize || fault_ == Fault::kWrongChannels ? wrong_ : B_;
  }
  // Not through solution(), so that each checkpoint reads solution() exactly once.
  Radiosity display() const override { return B_; }

 private:
  Fault fault_;
  Radiosity B_, wrong_;
  int steps_ = 0;
  mutable int reads_after_last_ = 0;
};

// Registers the broken solvers once per test program.
void register_broken_solvers() {
  static const bool done = [] {
    auto add = [](const char* name, Fault fault) {
      SolverInfo info;
      info.name = name;
      info.summary = "test: breaks the solver contract";
      info.reference = "test";
      info.cost = "nothing";
      info.make = [fault](ParamBag&) -> std::unique_ptr<Solver> {
        return std::make_unique<BrokenSolver>(fault);
      };
      register_solver(info);
    };
    add("test-wrong-size", Fault::kWrongSize);
    add("test-wrong-channels", Fault::kWrongChannels);
    add("test-throws", Fault::kThrows);
    add("test-throws-in-init", Fault::kThrowsInInit);
    add("test-throws-when-written", Fault::kThrowsWhenWritten);
    return true;
  }();
  (void)done;
}

// A sweep of the broken solver `name` and gauss-seidel on a 24-element cube.
SweepReport sweep_with(const TempDir& dir, const std::string& name) {
  register_broken_solvers();
  const std::string toml = dir.write("e.toml",
                                     "name = \"contract\"\n"
                                     "scenes = [\"builtin:cube:rho=0.8\"]\n"
                                     "subdiv = 2\n"
                                     "solvers = [\"" +
                                         name +
                                         "\", \"gauss-seidel\"]\n"
                                         "[form_factors]\nrays = 4\n"
                                         "[budget]\nsteps = " +
                                         std::to_string(kBudgetSteps) + "\n");
  return run_sweep(read_experiment(toml), {dir.file("out"), 0, 1, "test"});
}

// The failed run is recorded with `message`, the other run completes, the sweep is complete and
// ends with exit 4 (numerical failure), not an internal error.
void expect_contained(const TempDir& dir, const SweepReport& report, const std::string& solver,
                      std::initializer_list<std::string> message) {
  ASSERT_EQ(report.failures.size(), 1u);
  EXPECT_EQ(report.failures[0].code, ExitCode::kNumerical);
  EXPECT_EQ(report.exit_code(), 4);
  for (const std::string& part : message)
    EXPECT_NE(report.failures[0].message.find(part), std::string::npos)
        << report.failures[0].message << " lacks " << part;
  EXPECT_NE(report.failures[0].message.find(solver), std::string::npos);
  const CsvTable summary = read_csv(dir.file("out/summary.csv"));
  ASSERT_EQ(summary.rows.size(), 2u);
  EXPECT_EQ(summary.rows[0][summary.column("stop_reason")], "failed: numerical error");
  EXPECT_EQ(summary.rows[1][summary.column("stop_reason")], "step budget");
  EXPECT_EQ(read_json_file(dir.file("out/sweep.json"))["status"], "complete");
}

TEST(SolverContract, ASolutionOfTheWrongSizeFailsItsRun) {
  TempDir dir;
  expect_contained(dir, sweep_with(dir, "test-wrong-size"), "test-wrong-size",
                   {"returned from solution() 29 elements x 1 channels", "the system has 24 x 1"});
}

TEST(SolverContract, ASolutionWithTheWrongChannelsFailsItsRun) {
  TempDir dir;
  expect_contained(dir, sweep_with(dir, "test-wrong-channels"), "test-wrong-channels",
                   {"returned from solution() 24 elements x 3 channels"});
}

TEST(SolverContract, AnExceptionFromStepFailsItsRunAndTheSweepGoesOn) {
  TempDir dir;
  expect_contained(dir, sweep_with(dir, "test-throws"), "test-throws",
                   {"threw from step(): deliberate failure at step 3"});
}

TEST(SolverContract, AnExceptionFromInitFailsItsRunAndTheSweepGoesOn) {
  TempDir dir;
  expect_contained(dir, sweep_with(dir, "test-throws-in-init"), "test-throws-in-init",
                   {"threw from init(): init refused on purpose"});
}

// The outputs written after the run (the radiosity file) read the solver through the same guard.
TEST(SolverContract, AnExceptionWhileTheResultIsWrittenFailsItsRun) {
  TempDir dir;
  expect_contained(dir, sweep_with(dir, "test-throws-when-written"), "test-throws-when-written",
                   {"threw from solution(): deliberate failure when the result is written"});
}

#ifdef CONTRACT_BREAKER_PLUGIN
using Result = testing::CommandResult;

Result radlab(const TempDir& dir, const std::string& arguments) {
  return testing::run_command("RADLAB_CACHE_DIR=" + dir.file("cache") + " timeout 300 " +
                              std::string(RADLAB_BINARY) + " --plugin " + CONTRACT_BREAKER_PLUGIN +
                              " " + arguments);
}

#define EXPECT_OUTPUT_HAS(result, text) \
  EXPECT_NE((result).output.find(text), std::string::npos) << (result).output

TEST(SolverContract, APluginReturningTheWrongSizeIsExit4NotAnOutOfBoundsRead) {
  TempDir dir;
  const Result r =
      radlab(dir, "solve builtin:cube:rho=0.8 --subdiv 2 --solver contract-wrong-size --steps 20");
  EXPECT_EQ(r.code, 4) << r.output;
  EXPECT_OUTPUT_HAS(r, "solver 'contract-wrong-size' returned from solution() 23 elements");
}

TEST(SolverContract, APluginsExceptionFailsItsRunAndRunJsonRecordsThePluginThatRan) {
  TempDir dir;
  const std::string toml = dir.write("e.toml", R"(name = "plugins"
scenes = ["builtin:cube:rho=0.8"]
subdiv = 2
solvers = ["contract-throws", "contract-ok", "gauss-seidel"]
[form_factors]
rays = 4
[budget]
steps = 20
)");
  const Result r = radlab(dir, "run " + toml + " --out " + dir.file("out"));
  EXPECT_EQ(r.code, 4) << r.output;  // not 1 ("internal error")
  EXPECT_OUTPUT_HAS(r, "1 of 3 runs failed");
  EXPECT_OUTPUT_HAS(r, "threw from step(): contract-throws: deliberate failure at step 3");
  EXPECT_EQ(read_json_file(dir.file("out/sweep.json"))["status"], "complete");
  // The plugin's runs name its file and digest; the built-in solver's run names no plugin.
  const std::string plugin = fs::canonical(CONTRACT_BREAKER_PLUGIN).string();
  for (const char* run :
       {"contract-ok_scene_cube_rho_0.8.run.json", "contract-throws_scene_cube_rho_0.8.run.json"}) {
    const Json json = read_json_file(dir.file(std::string("out/runs/") + run));
    ASSERT_EQ(json["plugins"].size(), 1u) << run;
    EXPECT_EQ(json["plugins"][0]["path"], plugin);
    EXPECT_EQ(json["plugins"][0]["sha256"], file_sha256(plugin));
  }
  const Json builtin =
      read_json_file(dir.file("out/runs/gauss-seidel_scene_cube_rho_0.8.run.json"));
  EXPECT_TRUE(builtin["plugins"].empty());
}
#endif

}  // namespace
}  // namespace radlab
