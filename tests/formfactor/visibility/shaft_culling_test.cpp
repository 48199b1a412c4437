// Shaft culling: pairs it proves clear or blocked agree with traced rays.
//
// Tolerances are derived in the comments next to them, never tuned to the measured error.
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
#include "formfactor/matrix/matrix_cache.h"
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
// Shaft culling.

TEST(ShaftCulling, FindsTheBlockerBetweenTwoSquaresAndOnlyThen) {
  // A plate between two facing squares blocks them; moved aside (out of the shaft) it does not.
  std::vector<Vec3> plate = {{0.4, 0.4, 0.5}, {0.6, 0.4, 0.5}, {0.6, 0.6, 0.5}, {0.4, 0.6, 0.5}};
  for (double shift : {0.0, 0.45, 2.0}) {
    std::vector<Vec3> moved = plate;
    for (Vec3& p : moved) p.x += shift;
    Scene scene = scene_of({square_z(0.0, true), square_z(1.0, false), moved});
    Mesh mesh = build_mesh(scene, {});
    ShaftCuller shafts(scene, mesh, 1e-9);
    const bool inside = shift < 0.5;  // the plate reaches x < 1: inside the shaft's box
    EXPECT_EQ(shafts.first_blocker(0, 1), inside ? 2 : -1) << shift;
    EXPECT_EQ(shafts.first_blocker(1, 0), shafts.first_blocker(0, 1));
  }
}

TEST(ShaftCulling, ConnectingPlanesCutTheCornersOfTheBox) {
  // Squares at opposite corners of a box: a plate in the box's corner but outside the hull of
  // the two squares is left out by a connecting plane (the union box alone would keep it).
  std::vector<Vec3> low = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};   // faces +z
  std::vector<Vec3> high = {{3, 0, 3}, {3, 1, 3}, {4, 1, 3}, {4, 0, 3}};  // faces -z
  std::vector<Vec3> corner = {{3.5, 0.2, 0.5}, {3.8, 0.2, 0.5}, {3.8, 0.8, 0.5}, {3.5, 0.8, 0.5}};
  std::vector<Vec3> middle = {{1.8, 0.2, 1.5}, {2.2, 0.2, 1.5}, {2.2, 0.8, 1.5}, {1.8, 0.8, 1.5}};
  Scene clear = scene_of({low, high, corner});
  Mesh clear_mesh = build_mesh(clear, {});
  EXPECT_EQ(ShaftCuller(clear, clear_mesh, 1e-9).first_blocker(0, 1), -1);
  Scene blocked = scene_of({low, high, middle});
  Mesh blocked_mesh = build_mesh(blocked, {});
  EXPECT_EQ(ShaftCuller(blocked, blocked_mesh, 1e-9).first_blocker(0, 1), 2);
}

TEST(ShaftCulling, APolygonWhollyBehindAnElementsPlaneCannotBlock) {
  // i is tilted (plane z = x/2); a plate inside the shaft's box but below i's plane cannot meet
  // a segment from i to j, which lies wholly above that plane.
  std::vector<Vec3> tilted = {{0, 0, 0}, {1, 0, 0.5}, {1, 1, 0.5}, {0, 1, 0}};
  std::vector<Vec3> top = square_z(2.0, false);
  std::vector<Vec3> below = {{0.8, 0.4, 0.2}, {0.95, 0.4, 0.2}, {0.95, 0.6, 0.2}, {0.8, 0.6, 0.2}};
  std::vector<Vec3> above = below;
  for (Vec3& p : above) p.z = 1.0;
  for (bool behind : {true, false}) {
    Scene scene = scene_of({tilted, top, behind ? below : above});
    Mesh mesh = build_mesh(scene, {});
    ShaftCuller shafts(scene, mesh, 1e-9);
    EXPECT_EQ(shafts.unoccluded(0, 1), behind);
  }
}

TEST(ShaftCulling, SoundSymmetricAndWorthIt) {
  // Cornell box at subdiv 3: every pair the shafts prove unoccluded is also unblocked for 64
  // rays traced without shafts (soundness), the decision is symmetric, and it spares rays.
  Scene scene = make_builtin_scene("cornell");
  validate_scene(scene);
  Mesh mesh = build_mesh(scene, {3, 0.0});
  const double eps = plane_epsilon(mesh);
  ShaftCuller shafts(scene, mesh, eps);
  Visibility traced(scene, mesh, 64, 7, /*shaft_culling=*/false);
  size_t proven = 0, facing = 0;
  RowCost cost;
  for (size_t i = 0; i < mesh.size(); ++i)
    for (size_t j = i + 1; j < mesh.size(); ++j) {
      if (!pair_faces(mesh, i, j, eps)) continue;
      ++facing;
      const bool clear = shafts.unoccluded(i, j);
      ASSERT_EQ(clear, shafts.unoccluded(j, i));
      if (!clear) continue;
      ++proven;
      ASSERT_EQ(traced.fraction(i, j, cost), 1.0) << i << " " << j;
    }
  EXPECT_GT(proven, facing / 4);  // the blocks stand in the way of a minority of pairs
  EXPECT_LT(proven, facing);

  RaycastOptions with, without;
  without.shafts = false;
  with.max_rays = without.max_rays = with.rays;  // a fixed count, so that rays count pairs
  BuildReport a, b;
  RaycastFormFactors culled(scene, mesh, with), plain(scene, mesh, without);
  const FormFactorMatrix culled_m = build_matrix(culled, mesh.size(), Precision::kFloat, a);
  const FormFactorMatrix plain_m = build_matrix(plain, mesh.size(), Precision::kFloat, b);
  // The same pairs reach the visibility stage either way; culling moves some of them from
  // traced to proven-unoccluded, and every one it moves saves exactly `rays` rays. (Pairs are
  // counted per row, twice; a build of every row casts each unordered pair's rays once.)
  EXPECT_EQ(a.cost.pairs_unoccluded + a.cost.pairs_traced,
            b.cost.pairs_unoccluded + b.cost.pairs_traced);
  EXPECT_EQ(b.cost.pairs_unoccluded, 0u);
  EXPECT_GT(a.cost.pairs_unoccluded, b.cost.pairs_traced / 4);  // as in the pair count above
  EXPECT_EQ(b.cost.rays - a.cost.rays, a.cost.pairs_unoccluded / 2 * uint64_t(with.rays));
  // Culling changes cost, not results: a proven-clear pair is one the rays find clear.
  for (size_t i = 0; i < mesh.size(); ++i)
    for (size_t j = 0; j < mesh.size(); ++j)
      ASSERT_EQ(culled_m.at(i, j), plain_m.at(i, j)) << i << " " << j;
}

}  // namespace
}  // namespace radlab
