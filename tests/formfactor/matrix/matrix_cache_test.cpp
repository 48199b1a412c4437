// The form-factor matrix cache (keys, reuse, corruption) and symmetrising.
//
// Tolerances are derived in the comments next to them, never tuned to the measured error.
#include "formfactor/matrix/matrix_cache.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <glm/gtc/matrix_transform.hpp>
#include <numbers>
#include <numeric>

#include "core/error.h"
#include "experiments/problem/problem.h"
#include "formfactor/integrate/point_polygon.h"
#include "formfactor/integrate/polygon_integral.h"
#include "formfactor/integrate/quadrature.h"
#include "formfactor/matrix/diagnostics.h"
#include "formfactor/matrix/matrix.h"
#include "formfactor/methods/exact.h"
#include "formfactor/methods/hemicube.h"
#include "formfactor/methods/raycast.h"
#include "formfactor/visibility/shaft.h"
#include "formfactor/visibility/visibility.h"
#include "scene/builtin/builtin_scenes.h"
#include "scene/geometry.h"
#include "scene/validate.h"
#include "tests/formfactor_support.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

using testing::scene_of;
using testing::square_z;
using namespace radlab::testing;

// ---------------------------------------------------------------------------------------------
// The matrix cache.

FormFactorMatrix small_matrix(Precision precision) {
  FormFactorMatrix m(3, precision);
  for (size_t i = 0; i < 3; ++i)
    for (size_t j = 0; j < 3; ++j) m.set(i, j, 0.1 * double(i) + 0.01 * double(j) + 1e-9);
  return m;
}

Mesh cube_mesh() {
  Scene scene = make_builtin_scene("cube");
  validate_scene(scene);
  return build_mesh(scene, {});
}

TEST(MatrixCache, RoundTrip) {
  testing::TempDir dir;
  MatrixCache cache(dir.path() / "nested");
  const Mesh mesh = cube_mesh();
  for (Precision precision : {Precision::kFloat, Precision::kDouble}) {
    const MatrixCacheKey key = matrix_cache_key(mesh, "raycast", "rays=16", precision);
    EXPECT_FALSE(cache.load(key, nullptr).has_value());  // a miss, quietly
    FormFactorMatrix m = small_matrix(precision);
    BuildReport report;
    report.cost.rays = 1234;
    report.cost.pairs_unoccluded = 5;
    report.seconds = 2.5;
    report.threads = 2;
    ASSERT_TRUE(cache.store(key, m, report));
    BuildReport loaded_report;
    std::optional<FormFactorMatrix> loaded = cache.load(key, &loaded_report);
    ASSERT_TRUE(loaded.has_value());
    ASSERT_EQ(loaded->size(), m.size());
    EXPECT_EQ(loaded->precision(), precision);
    EXPECT_TRUE(identical_entries(*loaded, m));
    EXPECT_TRUE(loaded_report.cached);
    EXPECT_EQ(loaded_report.cost.rays, 1234u);
    EXPECT_EQ(loaded_report.cost.pairs_unoccluded, 5u);
    EXPECT_EQ(loaded_report.seconds, 2.5);
    EXPECT_EQ(loaded_report.cache_file, cache.path(key).string());
  }
  // Only the two final files remain (no temporaries).
  size_t files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(cache.folder())) {
    EXPECT_EQ(entry.path().extension(), ".ffm");
    ++files;
  }
  EXPECT_EQ(files, 2u);
}

TEST(MatrixCache, CorruptTruncatedOrStaleFilesAreDeletedNotTrusted) {
  testing::TempDir dir;
  MatrixCache cache(dir.path());
  const Mesh mesh = cube_mesh();
  const MatrixCacheKey key =
      matrix_cache_key(mesh, "hemicube", "resolution=150", Precision::kDouble);
  const std::string file = cache.path(key).string();
  auto fresh = [&] {
    ASSERT_TRUE(cache.store(key, small_matrix(Precision::kDouble), BuildReport{}));
  };
  auto patch = [&](std::streamoff offset, char value) {
    std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(offset);
    f.put(value);
  };
  const auto size = [&] { return std::filesystem::file_size(file); };

  fresh();
  patch(std::streamoff(size()) - 3, 'x');  // a payload byte
  EXPECT_FALSE(cache.load(key, nullptr).has_value());
  EXPECT_FALSE(std::filesystem::exists(file));

  fresh();
  std::filesystem::resize_file(file, size() - 8);  // truncated
  EXPECT_FALSE(cache.load(key, nullptr).has_value());
  EXPECT_FALSE(std::filesystem::exists(file));

  fresh();
  std::filesystem::resize_file(file, size() + 8);  // padded
  EXPECT_FALSE(cache.load(key, nullptr).has_value());

  fresh();
  patch(8, char(MatrixCache::kFormatVersion + 1));  // the version field: a stale format
  EXPECT_FALSE(cache.load(key, nullptr).has_value());
  EXPECT_FALSE(std::filesystem::exists(file));

  fresh();
  patch(40, 'y');  // inside the header (payload size): the header checksum catches it
  EXPECT_FALSE(cache.load(key, nullptr).has_value());

  fresh();
  std::filesystem::resize_file(file, 10);  // not even a header
  EXPECT_FALSE(cache.load(key, nullptr).has_value());
  EXPECT_FALSE(std::filesystem::exists(file));

  fresh();  // and a good file still loads
  EXPECT_TRUE(cache.load(key, nullptr).has_value());
}

TEST(MatrixCache, KeysSeparateEverythingThatChangesTheMatrix) {
  const Mesh mesh = cube_mesh();
  Mesh moved = mesh;
  moved.vertices[3].x = std::nextafter(moved.vertices[3].x, 2.0);  // one ulp
  Scene scene = make_builtin_scene("cube");
  validate_scene(scene);
  const Mesh finer = build_mesh(scene, {2, 0.0});
  const MatrixCacheKey base =
      matrix_cache_key(mesh, "raycast", "rays=16,seed=0", Precision::kFloat);
  const std::vector<MatrixCacheKey> others = {
      matrix_cache_key(mesh, "raycast", "rays=16,seed=1", Precision::kFloat),
      matrix_cache_key(mesh, "raycast", "rays=16,seed=0", Precision::kDouble),
      matrix_cache_key(mesh, "hemicube", "rays=16,seed=0", Precision::kFloat),
      matrix_cache_key(moved, "raycast", "rays=16,seed=0", Precision::kFloat),
      matrix_cache_key(finer, "raycast", "rays=16,seed=0", Precision::kFloat),
  };
  for (const MatrixCacheKey& other : others) {
    EXPECT_NE(other.file_name(), base.file_name()) << other.text;
    EXPECT_NE(other.text, base.text);
  }
  EXPECT_EQ(matrix_cache_key(mesh, "raycast", "rays=16,seed=0", Precision::kFloat).file_name(),
            base.file_name());

  // A file stored under one key is not handed out for another that happens to share its name.
  testing::TempDir dir;
  MatrixCache cache(dir.path());
  ASSERT_TRUE(cache.store(base, small_matrix(Precision::kFloat), BuildReport{}));
  MatrixCacheKey impostor = others[0];
  impostor.hash = base.hash;
  EXPECT_FALSE(cache.load(impostor, nullptr).has_value());
}

TEST(MatrixCache, UnwritableFolderIsAWarningNotAnError) {
  testing::TempDir dir;
  const std::string blocker = dir.write("file", "not a folder");
  MatrixCache cache(std::filesystem::path(blocker) / "cache");
  const Mesh mesh = cube_mesh();
  const MatrixCacheKey key = matrix_cache_key(mesh, "raycast", "", Precision::kFloat);
  EXPECT_FALSE(cache.store(key, small_matrix(Precision::kFloat), BuildReport{}));
  EXPECT_FALSE(cache.load(key, nullptr).has_value());
}

TEST(PrepareProblem, CachesTheMatrixAndSymmetrisesOnRequest) {
  testing::TempDir dir;
  ProblemSpec spec;
  spec.scene = "builtin:cornell";
  spec.mesh.subdivisions = 2;
  spec.ff_method = "hemicube";
  spec.ff_set = {"resolution=40", "symmetrise=false"};
  spec.need_reference = false;
  spec.cache_dir = dir.path().string();
  auto first = prepare_problem(spec);
  EXPECT_FALSE(first->build.cached);
  EXPECT_FALSE(first->build.cache_file.empty());
  auto second = prepare_problem(spec);
  EXPECT_TRUE(second->build.cached);
  ASSERT_EQ(second->matrix.size(), first->matrix.size());
  EXPECT_TRUE(identical_entries(second->matrix, first->matrix));
  EXPECT_EQ(second->build.cost.kernel_evaluations, first->build.cost.kernel_evaluations);

  // The default with a dense matrix is symmetrise=true: the same cached matrix, symmetrised after
  // loading, named in the parameters.
  spec.ff_set = {"resolution=40"};
  auto symmetrised = prepare_problem(spec);
  EXPECT_TRUE(symmetrised->build.cached);
  EXPECT_EQ(symmetrised->ff_parameters, "resolution=40,weights=midpoint,symmetrise=true");
  EXPECT_GT(first->diagnostics.reciprocity_defect_relative, 1e-3);
  EXPECT_LT(symmetrised->diagnostics.reciprocity_defect_relative, 1e-6);  // float storage

  spec.use_cache = false;
  auto uncached = prepare_problem(spec);
  EXPECT_FALSE(uncached->build.cached);
  EXPECT_TRUE(uncached->build.cache_file.empty());

  // Rows on the fly cannot be symmetrised: the default turns off, an explicit request is an error.
  spec.row_mode = RowMode::kOnTheFly;
  EXPECT_EQ(prepare_problem(spec)->ff_parameters, "resolution=40,weights=midpoint");
  spec.ff_set.push_back("symmetrise=true");
  EXPECT_THROW(prepare_problem(spec), UsageError);
}

}  // namespace
}  // namespace radlab
