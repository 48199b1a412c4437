// The coincident-overlap repair's bounds (scene/overlap.h): a polygon cut by many coincident
// polygons is refused past kMaxRepairPieces pieces, naming the polygon, instead of growing
// without bound; rounding slivers below kSliverFraction of the polygon are not kept.
#include "scene/overlap.h"

#include <gtest/gtest.h>

#include <string>

#include "core/error.h"
#include "scene/geometry.h"

namespace radlab {
namespace {

Scene one_material_scene() {
  Scene scene;
  scene.name = "test";
  scene.materials.push_back(Material{});
  scene.materials.back().name = "white";
  return scene;
}

std::vector<Vec3> square(double x, double y, double side) {
  return {{x, y, 0}, {x + side, y, 0}, {x + side, y + side, 0}, {x, y + side, 0}};
}

// k x k small squares, apart from each other, then one square covering them all, in the same
// plane facing the same way: the later square loses each small one as a hole. Cutting a hole out
// of a convex piece leaves up to 4 pieces (subtract_convex: one outside each edge of the hole);
// the cover ends in about 2 pieces per hole (900 holes: 1,831 pieces).
Scene holes_under_a_cover(int k) {
  Scene scene = one_material_scene();
  for (int j = 0; j < k; ++j)
    for (int i = 0; i < k; ++i)
      scene.polygons.push_back(
          Polygon{square(2.0 * i + 0.5, 2.0 * j + 0.5, 1.0), 0, "small " + std::to_string(i)});
  scene.polygons.push_back(Polygon{square(0, 0, 2.0 * k), 0, "cover.obj:7"});
  return scene;
}

TEST(OverlapRepair, RefusesAPolygonCutIntoTooManyPieces) {
  // 50^2 = 2,500 holes: about 5,000 pieces, above kMaxRepairPieces (4,096).
  Scene scene = holes_under_a_cover(50);
  try {
    resolve_coincident_polygons(scene, false);
    FAIL() << "expected an InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cover.obj:7"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("--keep-overlaps"), std::string::npos) << e.what();
  }
}

TEST(OverlapRepair, CutsAPolygonIntoFewerPiecesThanTheLimit) {
  // 30^2 = 900 holes: 1,831 pieces, below the limit; the area left is exact up to rounding
  // (a sum of ~2,000 areas of 1-3,600 m^2 with integer corners: 1e-9 relative is far above it).
  Scene scene = holes_under_a_cover(30);
  const OverlapReport report = resolve_coincident_polygons(scene, false);
  EXPECT_EQ(report.same_facing, 900);
  double cover = 0.0;
  for (const Polygon& p : scene.polygons)
    if (p.origin == "cover.obj:7") cover += geometry::area(p.vertices);
  EXPECT_NEAR(cover, 60.0 * 60.0 - 900.0, 1e-9 * 3600.0);
}

}  // namespace
}  // namespace radlab
