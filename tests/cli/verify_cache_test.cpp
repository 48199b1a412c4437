// `radlab formfactors SCENE --sample-rows N --verify-cache`: sampled rows computed now against the
// cached matrix of the same key, bit for bit. A matrix this radlab computes verifies; one entry
// moved by one ulp in a cache file that is otherwise valid (its key and checksums rewritten by the
// cache itself) is named by row and column, exit 3; no cached matrix, exit 3; no --sample-rows,
// exit 2.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "experiments/problem/problem.h"
#include "formfactor/matrix/matrix_cache.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

using radlab::testing::TempDir;

testing::CommandResult formfactors(const TempDir& cache, const std::string& arguments) {
  return testing::run_command("RADLAB_CACHE_DIR=" + cache.path().string() + " timeout 300 " +
                              RADLAB_BINARY + " -q formfactors builtin:cornell --subdiv 2 " +
                              arguments);
}

TEST(VerifyCache, SampledRowsAgainstTheCachedMatrix) {
  TempDir cache;
  const auto missing = formfactors(cache, "--sample-rows 5 --verify-cache");
  EXPECT_EQ(missing.code, 3) << missing.output;
  EXPECT_NE(missing.output.find("found no cached matrix"), std::string::npos) << missing.output;
  EXPECT_EQ(formfactors(cache, "--verify-cache").code, 2);

  ASSERT_EQ(formfactors(cache, "").code, 0);  // the build, into the cache
  // Every row (80 of 80): the whole cached matrix is this process's bits.
  const auto same = formfactors(cache, "--sample-rows 80 --verify-cache");
  EXPECT_EQ(same.code, 0) << same.output;
  EXPECT_NE(same.output.find("all 6400 entries of the sampled rows the same bits"),
            std::string::npos)
      << same.output;

  // The cached matrix with one non-zero entry one ulp up, stored under its own key.
  ProblemSpec spec;
  spec.scene = "builtin:cornell";
  spec.mesh.subdivisions = 2;
  spec.row_mode = RowMode::kOnTheFly;
  spec.need_reference = false;
  spec.require_emitter = false;
  spec.cache_dir = cache.path().string();
  const auto problem = prepare_problem(spec);
  const MatrixCache folder(cache.path());
  const MatrixCacheKey key = matrix_cache_key(problem->mesh, problem->method->name(),
                                              problem->method->parameters(), Precision::kDouble);
  BuildReport report;
  std::optional<FormFactorMatrix> m = folder.load(key, &report);
  ASSERT_TRUE(m.has_value());
  const size_t row = 17;
  size_t column = 0;
  while (m->at(row, column) == 0.0) ++column;
  m->set(row, column, std::nextafter(m->at(row, column), 1.0));
  ASSERT_TRUE(folder.store(key, *m, report));
  const auto moved = formfactors(cache, "--sample-rows 80 --verify-cache");
  EXPECT_EQ(moved.code, 3) << moved.output;
  EXPECT_NE(moved.output.find("1 of the 6400 entries of the sampled rows differ"),
            std::string::npos)
      << moved.output;
  EXPECT_NE(moved.output.find("row 17, column " + std::to_string(column)), std::string::npos)
      << moved.output;
}

}  // namespace
}  // namespace radlab
