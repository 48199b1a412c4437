// Faces that are not convex loops (scene/triangulate.h) and the loader's area account
// (AreaAccount in scene/validate.h): a face with a hole joined by a seam, a corner visited
// twice, a non-planar face that is not convex in projection. The shapes are RenderPark's own
// (office3/office.mgf:41, soda.mgf:983), whose areas follow from their corners exactly.
#include "scene/triangulate.h"

#include <gtest/gtest.h>

#include <cmath>
#include <glm/geometric.hpp>

#include "scene/geometry.h"
#include "scene/validate.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

// office3/office.mgf:41 (before its 0.0762 scale): the wall 60 x 35.5 at z = 30 with the
// window 47 x 17 cut out, the window's outline joined to the wall's by a seam from v4, which
// the face visits twice: f v0 v1 v2 v3 v4 v5 v6 v7 v8 v4.
const std::vector<Vec3> kWallWithWindow = {
    {30, 15.5, 30}, {-30, 15.5, 30}, {-30, 51, 30},   {30, 51, 30},    {30, 26, 30},
    {23.5, 26, 30}, {23.5, 43, 30},  {-23.5, 43, 30}, {-23.5, 26, 30}, {30, 26, 30}};
constexpr double kWallArea = 60 * 35.5 - 47 * 17;  // 1,331

// soda.mgf:983: a frame around a menu board in the plane x = 119.9, the board's corners
// v199..v202 visited as the frame's inner outline, v203 twice.
const std::vector<Vec3> kMenuFrame = {
    {119.9, 87, 80},      {119.9, 87, 134},    {119.9, 58.5, 134},  {119.9, 58.5, 135.5},
    {119.9, 88.5, 135.5}, {119.9, 88.5, 78.5}, {119.9, 58.5, 78.5}, {119.9, 58.5, 134},
    {119.9, 60, 134},     {119.9, 60, 80}};
// The outer rectangle 30 x 57 less the board 27 x 54.
constexpr double kFrameArea = 30 * 57 - 27 * 54;  // 252

double total_area(const std::vector<std::vector<Vec3>>& pieces) {
  double sum = 0.0;
  for (const auto& piece : pieces) sum += geometry::area(piece);
  return sum;
}

// Rounding only: corners of size ~100 in double, a few dozen operations per triangle.
constexpr double kRounding = 1e-12;

TEST(Triangulate, WallWithAWindowKeepsTheWallAndNotTheWindow) {
  const auto triangles = triangulate_polygon(kWallWithWindow);
  EXPECT_NEAR(total_area(triangles), kWallArea, kRounding * kWallArea);
  const Vec3 normal = geometry::unit_normal(kWallWithWindow);
  for (const auto& t : triangles) {
    ASSERT_EQ(t.size(), 3u);
    EXPECT_GT(glm::dot(geometry::unit_normal(t), normal), 0.0);  // wound as the face
    const Vec3 c = geometry::centroid(t);
    EXPECT_FALSE(c.x > -23.5 && c.x < 23.5 && c.y > 26 && c.y < 43) << "a triangle in the window";
  }
}

TEST(Triangulate, FrameAroundABoardKeepsTheFrame) {
  EXPECT_NEAR(total_area(triangulate_polygon(kMenuFrame)), kFrameArea, kRounding * kFrameArea);
}

TEST(Triangulate, NonConvexOutlineIsCoveredOnce) {
  // An L of area 3 and a comb (three teeth) of area 5.
  const std::vector<Vec3> l = {{0, 0, 0}, {2, 0, 0}, {2, 1, 0}, {1, 1, 0}, {1, 2, 0}, {0, 2, 0}};
  EXPECT_NEAR(total_area(triangulate_polygon(l)), 3.0, 1e-14);
  const std::vector<Vec3> comb = {{0, 0, 0}, {5, 0, 0}, {5, 2, 0}, {4, 2, 0}, {4, 1, 0}, {3, 1, 0},
                                  {3, 2, 0}, {2, 2, 0}, {2, 1, 0}, {1, 1, 0}, {1, 2, 0}, {0, 2, 0}};
  EXPECT_NEAR(total_area(triangulate_polygon(comb)), 8.0, 1e-14);
}

TEST(Validation, FaceWithAHoleSeamIsSplitAndKeepsItsArea) {
  Scene scene = testing::scene_of({kWallWithWindow, kMenuFrame});
  const ValidationReport report = validate_scene(scene);
  EXPECT_EQ(report.triangulated, 2);
  EXPECT_EQ(report.dropped, 0);
  double kept = 0.0;
  for (const Polygon& p : scene.polygons) kept += geometry::area(p.vertices);
  EXPECT_NEAR(kept, kWallArea + kFrameArea, kRounding * kWallArea);
  EXPECT_NEAR(report.area.read, kWallArea + kFrameArea, kRounding * kWallArea);
  EXPECT_NEAR(report.area.kept, kept, kRounding * kWallArea);
  EXPECT_EQ(report.area.split_lost, 0.0);
  EXPECT_NEAR(report.area.unaccounted(), 0.0, kRounding * kWallArea);
  for (const std::string& w : report.warnings) EXPECT_EQ(w.find("lost"), std::string::npos) << w;
}

TEST(Validation, NonPlanarFaceNotConvexInProjectionIsNotFanned) {
  // The L again, one corner lifted beyond the planarity tolerance; a fan from corner 0 would
  // cover the notch (1,1)-(2,2) too, area 4 instead of 3.
  const std::vector<Vec3> l = {{0, 0, 0}, {2, 0, 0}, {2, 1, 0}, {1, 1, 0.01}, {1, 2, 0}, {0, 2, 0}};
  Scene scene = testing::scene_of({l});
  const ValidationReport report = validate_scene(scene);
  EXPECT_EQ(report.triangulated, 1);
  double projected = 0.0;
  for (const Polygon& p : scene.polygons) projected += 0.5 * geometry::newell_vector(p.vertices).z;
  EXPECT_NEAR(projected, 3.0, 1e-12);
  EXPECT_NEAR(report.area.unaccounted(), 0.0, 1e-12);
}

TEST(Validation, AreaASplitCannotCoverIsNamedWithTheArea) {
  // A figure eight touching itself at (1,1): a unit square lobe wound counter-clockwise and a
  // 2 x 2 lobe wound clockwise. Newell's area is their difference (3, facing -z); triangles
  // facing one way cannot cover that (they cover both lobes, 5): the warning names the polygon
  // and the difference, and the account still balances.
  const std::vector<Vec3> eight = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {1, 3, 0},
                                   {3, 3, 0}, {3, 1, 0}, {1, 1, 0}, {0, 1, 0}};
  Scene scene = testing::scene_of({testing::square_z(0, true), eight});
  const ValidationReport report = validate_scene(scene);
  bool named = false;
  for (const std::string& w : report.warnings)
    named |=
        w.find("p1") != std::string::npos && w.find("covering 5 of its 3 m^2") != std::string::npos;
  EXPECT_TRUE(named);
  EXPECT_NEAR(report.area.split_lost, -2.0, 1e-12);
  EXPECT_NEAR(report.area.unaccounted(), 0.0, 1e-12);
}

// A non-planar face from a fuzzed OBJ (fuzz/corpus/obj/finding_cgal_3b06dc3b), one corner 2.6e6 m
// out and others visited three times: in its best plane its edges overlap and cross. With
// inexact intersections CGAL's constraint hierarchy lost track of a piece of an edge and
// number_of_enclosing_constraints dereferenced a null list (UBSan; a crash without it). Exact
// constructions keep every piece: the triangles exist, have finite corners and the even-odd
// region they cover is at most the area the edges span.
TEST(Triangulate, OverlappingAndCrossingEdgesOfANonPlanarFace) {
  const std::vector<Vec3> face = {{0, 2621474, -3}, {0, 0, 1}, {1, 1, 1},  {1, 0, 0}, {0, 0, 1},
                                  {0, 1, 0},        {5, 1, 0}, {0, 26, 4}, {1, 1, 1}, {0, 0, 1},
                                  {0, 1, 0},        {5, 1, 0}, {0, 26, 4}, {1, 1, 1}, {0, 0, 1}};
  const auto triangles = triangulate_polygon(face);
  ASSERT_FALSE(triangles.empty());
  for (const auto& t : triangles)
    for (const Vec3& p : t)
      EXPECT_TRUE(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z));
}

}  // namespace
}  // namespace radlab
