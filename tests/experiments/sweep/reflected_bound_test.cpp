// The reflected bound in sweeps (issue 11): the experiment file's `[budget] tol_of` (as
// `radlab solve --tol-of`) and summary.csv's `bound_relative_reflected` column. On the tiny
// light (a 1 mm lamp of radiosity ~1e6 in a room of radiosities ~0.01) max B* is the lamp's, so a
// tolerance of max B* says little about the room; the sweep must be able to ask for, and report,
// the bound relative to the reflected light max(B* - E).
#include <gtest/gtest.h>

#include <string>

#include "core/csv_reader.h"
#include "core/error.h"
#include "experiments/sweep/experiment_spec.h"
#include "experiments/sweep/sweep.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

using testing::expect_error;
using testing::TempDir;

std::string experiment(const std::string& budget) {
  return "name = \"reflected\"\nscenes = [\"builtin:tiny-light\"]\nsolvers = "
         "[\"gauss-seidel\"]\n[budget]\n" +
         budget;
}

TEST(SweepReflected, TolOfIsReadAndValidated) {
  TempDir dir;
  EXPECT_FALSE(
      read_experiment(dir.write("a.toml", experiment("tol = 1e-6\n"))).budget.tol_of_reflected);
  EXPECT_FALSE(read_experiment(dir.write("b.toml", experiment("tol = 1e-6\ntol_of = \"max-b\"\n")))
                   .budget.tol_of_reflected);
  EXPECT_TRUE(
      read_experiment(dir.write("c.toml", experiment("tol = 1e-6\ntol_of = \"reflected\"\n")))
          .budget.tol_of_reflected);
  // Errors name the file, the line and the key, like the other budget keys.
  expect_error<InputError>(
      [&] { read_experiment(dir.write("d.toml", experiment("tol = 1e-6\ntol_of = \"room\"\n"))); },
      {"d.toml:6", "budget.tol_of", "reflected", "room"});
  expect_error<InputError>(
      [&] { read_experiment(dir.write("e.toml", experiment("tol = 1e-6\ntol_of = 1\n"))); },
      {"e.toml:6", "budget.tol_of", "string"});
  // Without a tolerance the key would silently mean nothing.
  expect_error<InputError>(
      [&] {
        read_experiment(dir.write("f.toml", experiment("rows = 100\ntol_of = \"reflected\"\n")));
      },
      {"f.toml:6", "budget.tol_of", "budget.tol"});
}

// A sweep asked for 1e-6 of the reflected light stops on that bound, and summary.csv says it:
// bound_relative_reflected <= 1e-6 (plus rounding of the one rescaling), and it is the same
// absolute bound as bound_relative, rescaled by max B* / max(B* - E) > 1e4 on this scene.
TEST(SweepReflected, SummaryHasTheReflectedBound) {
  TempDir dir;
  const ExperimentSpec spec = read_experiment(
      dir.write("g.toml", experiment("tol = 1e-6\ntol_of = \"reflected\"\nrows = 2000000\n")));
  run_sweep(spec, {dir.file("out"), 0, 1, "test"});
  const CsvTable table = read_csv(dir.file("out/summary.csv"));
  ASSERT_EQ(table.rows.size(), 1u);
  const auto& row = table.rows[0];
  EXPECT_EQ(row[table.column("error")], "");
  EXPECT_EQ(row[table.column("tolerance_reached")], "true");
  const double reflected = std::stod(row[table.column("bound_relative_reflected")]);
  const double of_max_b = std::stod(row[table.column("bound_relative")]);
  EXPECT_GT(reflected, 0.0);
  EXPECT_LE(reflected, 1e-6 * (1 + 1e-12));
  EXPECT_GT(reflected / of_max_b, 1e4);
}

}  // namespace
}  // namespace radlab
