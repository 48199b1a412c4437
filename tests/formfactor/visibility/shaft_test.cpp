// Shaft culling's polygon-pair tier (formfactor/visibility/shaft.h): it never proves fewer pairs
// clear than the element-level test alone, what it proves clear is clear for traced rays, the
// decision is symmetric, and the per-thread cache of polygon pairs changes nothing but the cost.
// (tests/formfactor/closed_forms_test.cpp holds the element-level ShaftCulling tests.)
#include "formfactor/visibility/shaft.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "formfactor/methods/raycast.h"
#include "formfactor/visibility/visibility.h"
#include "scene/builtin/builtin_scenes.h"
#include "scene/geometry.h"
#include "scene/scene_loader.h"
#include "scene/validate.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

using testing::scene_of;
using testing::square_z;

std::vector<Vec3> shifted(std::vector<Vec3> v, const Vec3& by) {
  for (Vec3& p : v) p += by;
  return v;
}

// A plate between two facing squares, each square meshed 4 x 4 (enough elements for the polygon
// pair to be listed).
TEST(ShaftPolygonPairs, CandidatesOfTwoSquaresAndAPlate) {
  ASSERT_GE(16u, ShaftCuller::kMinElements);
  const std::vector<Vec3> plate = {
      {0.4, 0.4, 0.5}, {0.6, 0.4, 0.5}, {0.6, 0.6, 0.5}, {0.4, 0.6, 0.5}};
  for (double shift : {0.0, 2.0}) {
    Scene scene =
        scene_of({square_z(0.0, true), square_z(1.0, false), shifted(plate, {shift, 0, 0})});
    Mesh mesh = build_mesh(scene, {4, 0.0});
    ShaftCuller shafts(scene, mesh, 1e-9);
    const std::vector<uint32_t> candidates = shafts.polygon_pair_candidates(0, 1);
    EXPECT_EQ(candidates, shift == 0.0 ? std::vector<uint32_t>{2} : std::vector<uint32_t>{});
    EXPECT_EQ(shafts.polygon_pair_candidates(1, 0), candidates);
    // Element pairs: the plate moved aside clears them all with no element-level test; in the
    // middle it blocks pairs whose shafts reach it, and exactly those (the element-level test
    // then runs on the one candidate and finds the same as over all polygons).
    size_t clear = 0;
    for (size_t i = 0; i < 16; ++i)
      for (size_t j = 16; j < 32; ++j) {
        const int64_t blocker = shafts.first_blocker(i, j);
        EXPECT_EQ(blocker, shafts.first_blocker(j, i));
        EXPECT_EQ(blocker, shafts.element_level_blocker(i, j)) << i << " " << j;
        clear += blocker < 0 ? 1 : 0;
      }
    if (shift == 0.0) {
      EXPECT_GT(clear, 0u);    // corner to corner on the same side misses the plate
      EXPECT_LT(clear, 256u);  // the centre elements see each other through it
    } else {
      EXPECT_EQ(clear, 256u);
    }
  }
}

// A polygon that is not flat (off its plane by d, far above eps but within the validator's
// tolerance) does not rule out a neighbour lying in its plane: segments from its parts below that
// plane run through the neighbour. A flat one does.
TEST(ShaftPolygonPairs, ANonFlatPolygonsPlaneKeepsItsNeighbour) {
  for (double d : {0.0, 1e-5}) {
    // A twisted unit quad, a neighbour beyond its edge x = 1 in its plane (z = its centroid's z,
    // normal +z by symmetry), and a receiver above both, facing down.
    const std::vector<Vec3> twisted = {{0, 0, -d}, {1, 0, d}, {1, 1, -d}, {0, 1, d}};
    const double z = geometry::centroid(twisted).z;
    const std::vector<Vec3> neighbour = {{1, 0, z}, {2, 0, z}, {2, 1, z}, {1, 1, z}};
    const std::vector<Vec3> top = {{0, 0, 1}, {0, 1, 1}, {2, 1, 1}, {2, 0, 1}};
    Scene scene = scene_of({twisted, neighbour, top});
    EXPECT_LT(geometry::planarity_defect(twisted), kPlanarityTolerance);  // kept whole
    Mesh mesh = build_mesh(scene, {3, 0.0});
    ShaftCuller shafts(scene, mesh, 1e-9);
    const std::vector<uint32_t> candidates = shafts.polygon_pair_candidates(0, 2);
    EXPECT_EQ(candidates, d > 0 ? std::vector<uint32_t>{1} : std::vector<uint32_t>{}) << d;
  }
}

// Two cullers with the same polygon pairs share a thread's cache: the second must not see the
// first's candidates (here none, which would wrongly clear the second's blocked pairs).
TEST(ShaftPolygonPairs, CullersDoNotShareCandidates) {
  const std::vector<Vec3> plate = {
      {0.4, 0.4, 0.5}, {0.6, 0.4, 0.5}, {0.6, 0.6, 0.5}, {0.4, 0.6, 0.5}};
  Scene aside = scene_of({square_z(0.0, true), square_z(1.0, false), shifted(plate, {2, 0, 0})});
  Scene middle = scene_of({square_z(0.0, true), square_z(1.0, false), plate});
  Mesh aside_mesh = build_mesh(aside, {4, 0.0}), middle_mesh = build_mesh(middle, {4, 0.0});
  // A fresh thread: a fresh cache, which earlier tests on this thread have not filled.
  std::thread([&] {
    for (int round = 0; round < 3; ++round) {
      ShaftCuller clear(aside, aside_mesh, 1e-9);
      ShaftCuller blocked(middle, middle_mesh, 1e-9);
      // Element 5 (x, y in [0.25, 0.5]) to element 16 + 10 (x in [0.5, 0.75], y in [0.25, 0.5]):
      // through the plate.
      EXPECT_EQ(clear.first_blocker(5, 26), -1);
      EXPECT_EQ(blocked.first_blocker(5, 26), 2);
    }
  }).join();
}

struct Pair {
  uint32_t i, j;
};

// Facing pairs of every `step`-th row.
std::vector<Pair> facing_pairs(const Mesh& mesh, double eps, size_t step) {
  std::vector<Pair> pairs;
  for (size_t i = 0; i < mesh.size(); i += step)
    for (size_t j = 0; j < mesh.size(); ++j)
      if (i != j && pair_faces(mesh, i, j, eps)) pairs.push_back({uint32_t(i), uint32_t(j)});
  return pairs;
}

// The office (438 polygons, 9 elements each at subdiv 3: listed pairs, pairs over the candidate
// limit, more polygon pairs than cache slots): never fewer pairs proven clear than by the
// element-level test, symmetric, and the pairs proven clear only thanks to the polygon tier are
// clear for 64 traced rays.
TEST(ShaftPolygonPairs, NeverLessThanTheElementLevelTestAndSound) {
  Scene scene = make_builtin_scene("office");
  validate_scene(scene);
  Mesh mesh = build_mesh(scene, {3, 0.0});
  const double eps = plane_epsilon(mesh);
  ShaftCuller shafts(scene, mesh, eps);
  Visibility traced(scene, mesh, 64, 7, /*shaft_culling=*/false);
  RowCost cost;
  size_t clear = 0, element_clear = 0, gained = 0;
  for (const auto& [i, j] : facing_pairs(mesh, eps, 61)) {
    const bool is_clear = shafts.unoccluded(i, j);
    const bool element_level = shafts.element_level_blocker(i, j) < 0;
    ASSERT_EQ(is_clear, shafts.unoccluded(j, i)) << i << " " << j;
    ASSERT_EQ(element_level, shafts.element_level_blocker(j, i) < 0) << i << " " << j;
    ASSERT_TRUE(is_clear || !element_level) << i << " " << j;
    clear += is_clear ? 1 : 0;
    element_clear += element_level ? 1 : 0;
    if (is_clear && !element_level) {
      ++gained;
      ASSERT_EQ(traced.fraction(i, j, cost), 1.0) << i << " " << j;
    }
  }
  EXPECT_GT(element_clear, 0u);
  EXPECT_GE(clear, element_clear);
  EXPECT_EQ(clear - element_clear, gained);
}

// office2 (RenderPark; 430 polygons, 16 elements each at subdiv 4) has pairs that only the polygon
// tier proves clear: they must be clear for traced rays.
TEST(ShaftPolygonPairs, PairsClearedByThePolygonTierAreClearInOffice2) {
  std::string missing;
  const std::string path = testing::shared_scene("renderpark/office2/office2.mgf", missing);
  if (path.empty()) {
    RADLAB_SHARED_MISSING(missing);
  }
  Scene scene = load_scene(path, false).scene;
  Mesh mesh = build_mesh(scene, {4, 0.0});
  const double eps = plane_epsilon(mesh);
  ShaftCuller shafts(scene, mesh, eps);
  Visibility traced(scene, mesh, 64, 7, /*shaft_culling=*/false);
  RowCost cost;
  size_t gained = 0;
  for (const auto& [i, j] : facing_pairs(mesh, eps, 53)) {
    if (!shafts.unoccluded(i, j)) continue;
    if (shafts.element_level_blocker(i, j) < 0) continue;
    ++gained;
    ASSERT_EQ(traced.fraction(i, j, cost), 1.0) << i << " " << j;
  }
  EXPECT_GT(gained, 0u);
}

// The decisions do not depend on the order of the questions, on the thread that asks, or on
// another culler sharing the thread's cache.
TEST(ShaftPolygonPairs, TheCacheChangesNothingButTheCost) {
  Scene scene = make_builtin_scene("office");
  validate_scene(scene);
  Mesh mesh = build_mesh(scene, {3, 0.0});
  const double eps = plane_epsilon(mesh);
  std::vector<Pair> pairs = facing_pairs(mesh, eps, 97);
  std::vector<int64_t> in_order(pairs.size());
  {
    ShaftCuller shafts(scene, mesh, eps);
    for (size_t k = 0; k < pairs.size(); ++k)
      in_order[k] = shafts.first_blocker(pairs[k].i, pairs[k].j);
  }
  // Shuffled, with a second culler of another scene interleaved on the same thread.
  ShaftCuller shafts(scene, mesh, eps);
  Scene cornell = make_builtin_scene("cornell");
  validate_scene(cornell);
  Mesh cornell_mesh = build_mesh(cornell, {3, 0.0});
  ShaftCuller other(cornell, cornell_mesh, plane_epsilon(cornell_mesh));
  std::vector<size_t> order(pairs.size());
  for (size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::shuffle(order.begin(), order.end(), std::mt19937(5));
  for (size_t k : order) {
    const bool clear = in_order[k] < 0;
    ASSERT_EQ(shafts.unoccluded(pairs[k].i, pairs[k].j), clear) << pairs[k].i << " " << pairs[k].j;
    other.first_blocker(k % cornell_mesh.size(), (7 * k + 1) % cornell_mesh.size());
  }
  // Two threads at once, each with its own cache, over the pairs in reverse row order.
  std::vector<char> mismatch(pairs.size(), 0);
  auto work = [&](size_t parity) {
    for (size_t k = pairs.size(); k-- > 0;)
      if (k % 2 == parity)
        mismatch[k] = (shafts.unoccluded(pairs[k].j, pairs[k].i) != (in_order[k] < 0)) ? 1 : 0;
  };
  std::thread a(work, 0), b(work, 1);
  a.join();
  b.join();
  EXPECT_EQ(std::count(mismatch.begin(), mismatch.end(), 1), 0);
}

}  // namespace
}  // namespace radlab
