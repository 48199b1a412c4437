// The hemicube's stated emitter sampling error (FormFactorMethod::row_emitter_sampling, issue 35.2)
// against its definition and its theory, on builtin:tiny-light: one small lamp hanging under the
// ceiling of an empty room, so every element that sees the lamp sees all of it (no occlusion), and
// a row's sampled footprint is exactly what the row gathers.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <vector>

#include "experiments/problem/problem.h"
#include "formfactor/integrate/point_polygon.h"
#include "formfactor/matrix/diagnostics.h"
#include "formfactor/matrix/matrix.h"
#include "formfactor/matrix/matrix_cache.h"
#include "formfactor/methods/hemicube.h"
#include "scene/builtin/builtin_scenes.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

struct LampRoom {
  explicit LampRoom(const std::string& size, int subdivisions = 4)
      : scene(make_builtin_scene("tiny-light:size=" + size)),
        mesh(build_mesh(scene, {subdivisions, 0.0})) {}
  Scene scene;
  Mesh mesh;

  double luminance(size_t j) const {
    const Rgb& e = scene.materials[size_t(scene.polygons[mesh.polygon[j]].material)].emission;
    return (e.x + e.y + e.z) / 3.0;
  }
};

// Computes every row and returns the method's report.
EmitterSamplingReport all_rows(const LampRoom& room, const HemicubeFormFactors& method) {
  std::vector<double> row(room.mesh.size());
  RowCost cost;
  for (size_t i = 0; i < room.mesh.size(); ++i) method.row(i, row, cost);
  return emitter_sampling_report(method, room.mesh);
}

// With one emitting polygon and no occluder, the stated error of row i is by definition
// |sum_j L_j (F_ij - F°_ij)|: the row's own entries against the point form factor from the same
// eye, computed here independently. Equal up to the float the method stores it in (2^-24
// relative, rounded up) and the order of summation (1e-12 of the exact value).
TEST(HemicubeEmitterSampling, EqualsTheRowsErrorOnAnUnoccludedLamp) {
  const LampRoom room("0.05");
  const HemicubeFormFactors method(room.scene, room.mesh, {150, HemicubeWeighting::kMidpoint});
  std::vector<double> row(room.mesh.size());
  std::vector<Vec3> corners, scratch;
  RowCost cost;
  size_t lit_rows = 0;
  for (size_t i = 0; i < room.mesh.size(); ++i) {
    method.row(i, row, cost);
    double sampled = 0.0, exact = 0.0;
    for (size_t j = 0; j < room.mesh.size(); ++j) {
      const double L = room.luminance(j);
      if (!(L > 0) || j == i) continue;
      corners.clear();
      for (uint32_t v : room.mesh.element_vertices(j)) corners.push_back(room.mesh.vertices[v]);
      sampled += L * row[j];
      exact += L * point_to_polygon_form_factor(room.mesh.centroid[i], room.mesh.normal[i], corners,
                                                room.mesh.normal[j], scratch);
    }
    const auto stated = method.row_emitter_sampling(i);
    ASSERT_TRUE(stated.has_value());
    const double actual = std::abs(sampled - exact);
    EXPECT_GE(stated->error, actual - 1e-12 * exact) << "row " << i;
    EXPECT_LE(stated->error, actual * (1 + 2e-7) + 1e-12 * exact) << "row " << i;
    EXPECT_NEAR(stated->exact, exact, 1e-7 * exact) << "row " << i;
    lit_rows += exact > 0;
  }
  EXPECT_GT(lit_rows, room.mesh.size() / 2);  // the room's walls, floor and ceiling see the lamp
}

// A footprint's outline is sampled by pixel centres, so the error falls as 1/R (the outline's
// pixels) relative to the footprint: 4x the resolution should divide it by about 4. Asserting a
// factor 2 leaves room for the outline's pixel phases, which do not average out on 112 rows.
TEST(HemicubeEmitterSampling, FallsWithTheResolution) {
  const LampRoom room("0.3");
  const double coarse =
      all_rows(room, HemicubeFormFactors(room.scene, room.mesh, {150, HemicubeWeighting::kExact}))
          .relative;
  const double fine =
      all_rows(room, HemicubeFormFactors(room.scene, room.mesh, {600, HemicubeWeighting::kExact}))
          .relative;
  EXPECT_GT(coarse, 0.0);
  EXPECT_LT(fine, coarse / 2);
}

// Issue 35.2: at lamp sizes 0.02, 0.05 and 0.1 m (R 150, subdivision 4) the room's power is
// 24%, 2.3% and 13.5% off, and the old check (gathered against sent power) warned at the first
// and the last only. The stated error must not depend on where the size falls: a lamp a few
// pixels across is sampled to tens of percent in every row that sees it. Each is above the 1%
// that warns; and a smaller lamp is never stated as better sampled than a larger one.
TEST(HemicubeEmitterSampling, SmallLampsAreStatedWhateverTheirSize) {
  double previous = std::numeric_limits<double>::infinity();
  for (const char* size : {"0.02", "0.05", "0.1"}) {
    const LampRoom room(size);
    const EmitterSamplingReport report =
        all_rows(room, HemicubeFormFactors(room.scene, room.mesh, {}));
    ASSERT_TRUE(report.stated);
    EXPECT_GT(report.relative, 0.01) << "size " << size;
    EXPECT_LT(report.relative, previous) << "size " << size;
    previous = report.relative;
  }
}

// A problem prepared with on-the-fly hemicube rows and a reference (the command) carries
// the statement, so run.json and the warning have it.
TEST(HemicubeEmitterSampling, APreparedProblemCarriesIt) {
  ProblemSpec spec;
  spec.scene = "builtin:tiny-light:size=0.05";
  spec.mesh.subdivisions = 4;
  spec.ff_method = "hemicube";
  spec.row_mode = RowMode::kOnTheFly;
  spec.use_cache = false;
  const auto problem = prepare_problem(spec);
  EXPECT_TRUE(problem->emitter_sampling.stated);
  EXPECT_GT(problem->emitter_sampling.relative, 0.01);
}

// The side file restores the statement with a cached matrix; a missing one makes the matrix
// unusable (rebuilt), never a matrix without its statement.
TEST(HemicubeEmitterSampling, SideFileRoundTrips) {
  const LampRoom room("0.05");
  const HemicubeFormFactors built(room.scene, room.mesh, {});
  BuildReport report;
  const FormFactorMatrix matrix = build_matrix(built, room.mesh.size(), Precision::kFloat, report);
  const EmitterSamplingReport before = emitter_sampling_report(built, room.mesh);
  ASSERT_TRUE(before.stated);  // a build computes every row
  testing::TempDir dir;
  const MatrixCache cache(dir.path());
  const MatrixCacheKey key =
      matrix_cache_key(room.mesh, "hemicube", built.parameters(), Precision::kFloat);
  ASSERT_TRUE(cache.store(key, matrix, report));
  const std::string file = cache.path(key).string();
  built.save_side_files(file);

  const HemicubeFormFactors loaded(room.scene, room.mesh, {});
  EXPECT_FALSE(emitter_sampling_report(loaded, room.mesh).stated);   // nothing computed yet
  EXPECT_FALSE(loaded.load_side_files(file, room.mesh.size() + 1));  // wrong size
  ASSERT_TRUE(loaded.load_side_files(file, room.mesh.size()));
  const EmitterSamplingReport after = emitter_sampling_report(loaded, room.mesh);
  EXPECT_TRUE(after.stated);
  EXPECT_EQ(after.relative, before.relative);
  EXPECT_EQ(after.worst_element, before.worst_element);

  std::filesystem::remove(file + ".emitters");
  EXPECT_FALSE(
      HemicubeFormFactors(room.scene, room.mesh, {}).load_side_files(file, room.mesh.size()));
}

}  // namespace
}  // namespace radlab
