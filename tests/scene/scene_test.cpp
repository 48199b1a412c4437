// Scene input: OBJ/MTL reading, built-in scenes, validation and repair, and the mesher.
// Every bad input named in the foundation issue has a test here or in cli_test.
#include <gtest/gtest.h>

#include <cmath>
#include <glm/geometric.hpp>
#include <numeric>

#include "core/error.h"
#include "scene/builtin/builtin_scenes.h"
#include "scene/geometry.h"
#include "scene/mesh.h"
#include "scene/readers/obj_reader.h"
#include "scene/scene_loader.h"
#include "scene/validate.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

using testing::TempDir;

const char* kMtl =
    "newmtl white\nKd 0.5 0.5 0.5\n"
    "newmtl lamp\nKd 0.2 0.2 0.2\nKe 10 10 10\n";

const char* kTwoQuads =
    "mtllib m.mtl\n"
    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
    "v 0 0 1\nv 0 1 1\nv 1 1 1\nv 1 0 1\n"
    "usemtl white\nf 1 2 3 4\n"
    "usemtl lamp\nf 5/1/1 6//2 7 8\n";

using testing::expect_error;

TEST(ObjReader, ReadsPolygonsAndMaterials) {
  TempDir dir;
  dir.write("m.mtl", kMtl);
  Scene scene = read_obj(dir.write("s.obj", kTwoQuads));
  ASSERT_EQ(scene.polygons.size(), 2u);
  EXPECT_EQ(scene.materials.size(), 2u);
  EXPECT_EQ(scene.emitter_count(), 1);
  EXPECT_TRUE(scene.is_grey());
  EXPECT_DOUBLE_EQ(scene.materials[size_t(scene.polygons[1].material)].emission.x, 10.0);
  EXPECT_NE(scene.polygons[1].origin.find(":13"), std::string::npos);
}

TEST(ObjReader, NegativeIndicesAreRelative) {
  TempDir dir;
  dir.write("m.mtl", kMtl);
  Scene scene = read_obj(
      dir.write("s.obj", "mtllib m.mtl\nusemtl white\nv 0 0 0\nv 1 0 0\nv 1 1 0\nf -3 -2 -1\n"));
  ASSERT_EQ(scene.polygons.size(), 1u);
  EXPECT_EQ(scene.polygons[0].vertices[2], Vec3(1, 1, 0));
}

TEST(ObjReader, MissingFile) {
  expect_error<InputError>([] { load_scene("/nonexistent/radlab/scene.obj"); },
                           {"/nonexistent/radlab/scene.obj", "no such file"});
}

TEST(ObjReader, MalformedObjLineNamesFileAndLine) {
  TempDir dir;
  dir.write("m.mtl", kMtl);
  std::string path = dir.write("bad.obj", "mtllib m.mtl\nv 0 0 0\nv 1 zero 0\n");
  expect_error<InputError>([&] { read_obj(path); }, {"bad.obj:3", "zero"});
  path = dir.write("bad2.obj", "v 0 0 0\nv 1 0 0\nf 1 2 7\n");
  expect_error<InputError>([&] { read_obj(path); }, {"bad2.obj:3", "vertex 7"});
  path = dir.write("bad3.obj", "v 0 0 0\nbogus 1 2\n");
  expect_error<InputError>([&] { read_obj(path); }, {"bad3.obj:2", "bogus"});
  path = dir.write("bad4.obj", "mtllib m.mtl\nusemtl nosuch\n");
  expect_error<InputError>([&] { read_obj(path); }, {"bad4.obj:2", "nosuch"});
}

TEST(ObjReader, MalformedMtlLineNamesFileAndLine) {
  TempDir dir;
  dir.write("m.mtl", "newmtl a\nKd 0.5 0.5\n");
  std::string path = dir.write("s.obj", "mtllib m.mtl\n");
  expect_error<InputError>([&] { read_obj(path); }, {"m.mtl:2", "Kd"});
}

TEST(ObjReader, ReflectanceOutsideUnitIntervalNamesMaterial) {
  TempDir dir;
  dir.write("m.mtl", "newmtl shiny\nKd 1.2 0.5 0.5\n");
  std::string path = dir.write("s.obj", "mtllib m.mtl\n");
  expect_error<InputError>([&] { read_obj(path); }, {"shiny", "m.mtl:2"});
}

TEST(ObjReader, NegativeOrNanEmissionNamesMaterial) {
  TempDir dir;
  dir.write("m.mtl", "newmtl dark\nKe -1 0 0\n");
  std::string path = dir.write("s.obj", "mtllib m.mtl\n");
  expect_error<InputError>([&] { read_obj(path); }, {"dark", "emission"});
  dir.write("n.mtl", "newmtl nan\nKe nan 0 0\n");
  path = dir.write("t.obj", "mtllib n.mtl\n");
  expect_error<InputError>([&] { read_obj(path); }, {"nan", "emission"});
}

TEST(Validation, MaterialChecksNameTheMaterial) {
  Scene scene = testing::scene_of({testing::square_z(0, true)}, 0.5, 1.0);
  scene.materials[0].name = "glowing";
  scene.materials[0].reflectance = Rgb(0.5, std::nan(""), 0.5);
  expect_error<InputError>([&] { validate_scene(scene); }, {"glowing", "reflectance"});
  scene.materials[0].reflectance = Rgb(0.5);
  scene.materials[0].emission = Rgb(-0.1);
  expect_error<InputError>([&] { validate_scene(scene); }, {"glowing", "emission"});
}

TEST(Validation, ZeroAreaPolygonIsDroppedWithItsName) {
  Scene scene = testing::scene_of({testing::square_z(0, true),
                                   {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}},
                                   {{0, 0, 0}, {0, 0, 0}, {1, 1, 0}}});
  ValidationReport report = validate_scene(scene);
  EXPECT_EQ(scene.polygons.size(), 1u);
  EXPECT_EQ(report.dropped, 2);
  ASSERT_EQ(report.warnings.size(), 2u);
  EXPECT_NE(report.warnings[0].find("p1"), std::string::npos);
  EXPECT_NE(report.warnings[1].find("p2"), std::string::npos);
}

TEST(Validation, NonPlanarPolygonIsTriangulatedWithAWarning) {
  Scene scene = testing::scene_of({{{0, 0, 0}, {1, 0, 0}, {1, 1, 0.05}, {0, 1, 0}}});
  ValidationReport report = validate_scene(scene);
  EXPECT_EQ(scene.polygons.size(), 2u);
  EXPECT_EQ(report.triangulated, 1);
  EXPECT_NE(report.warnings.at(0).find("non-planar"), std::string::npos);
  for (const Polygon& p : scene.polygons) EXPECT_EQ(p.vertices.size(), 3u);
}

TEST(Validation, SlightlyNonPlanarWithinToleranceIsKept) {
  Scene scene = testing::scene_of({{{0, 0, 0}, {1, 0, 0}, {1, 1, 1e-6}, {0, 1, 0}}});
  ValidationReport report = validate_scene(scene);
  EXPECT_EQ(scene.polygons.size(), 1u);
  EXPECT_TRUE(report.warnings.empty());
}

TEST(Validation, NonConvexPolygonIsSplitPreservingArea) {
  // An L shape of area 3.
  std::vector<Vec3> l = {{0, 0, 0}, {2, 0, 0}, {2, 1, 0}, {1, 1, 0}, {1, 2, 0}, {0, 2, 0}};
  Scene scene = testing::scene_of({l});
  validate_scene(scene);
  double area = 0.0;
  for (const Polygon& p : scene.polygons) {
    area += geometry::area(p.vertices);
    EXPECT_TRUE(geometry::is_convex(p.vertices));
    EXPECT_GT(geometry::unit_normal(p.vertices).z, 0.0);  // orientation kept
  }
  EXPECT_NEAR(area, 3.0, 1e-12);
}

TEST(Validation, SceneWithoutEmitterIsRejectedClearly) {
  Scene scene = testing::scene_of({testing::square_z(0, true)}, 0.5, 0.0);
  validate_scene(scene);
  expect_error<InputError>([&] { require_emitter(scene); }, {"no emitter"});
}

TEST(BuiltinScenes, UnknownNameOrKeyListsTheValidOnes) {
  expect_error<UsageError>([] { make_builtin_scene("nosuch"); }, {"nosuch", "cornell", "cube"});
  expect_error<UsageError>([] { make_builtin_scene("cube:rhoo=0.5"); }, {"rhoo", "rho"});
  expect_error<UsageError>([] { make_builtin_scene("cube:rho=abc"); }, {"rho", "abc"});
}

TEST(BuiltinScenes, CornellBoxIsHonestAboutItsData) {
  LoadedScene loaded = load_scene("builtin:cornell", false);
  // The red wall (~0.8 mm out of plane) is split into two triangles, with a warning.
  EXPECT_EQ(loaded.report.triangulated, 1);
  ASSERT_EQ(loaded.report.warnings.size(), 1u);
  EXPECT_NE(loaded.report.warnings[0].find("left-wall"), std::string::npos);
  EXPECT_FALSE(loaded.scene.is_grey());
  EXPECT_EQ(loaded.scene.emitter_count(), 1);
  ASSERT_TRUE(loaded.scene.camera.has_value());
  // Floor area of the published box: a quadrilateral 552.8/549.6 x 559.2 mm.
  EXPECT_NEAR(geometry::area(loaded.scene.polygons[0].vertices), 0.5 * (0.5528 + 0.5496) * 0.5592,
              1e-6);
  // Every wall faces into the room; the light faces down.
  EXPECT_LT(geometry::unit_normal(loaded.scene.polygons[1].vertices).y, -0.999);
}

TEST(BuiltinScenes, CubeFacesPointInward) {
  Scene scene = make_builtin_scene("cube:size=2");
  validate_scene(scene);
  for (const Polygon& p : scene.polygons) {
    Vec3 c = geometry::centroid(p.vertices);
    EXPECT_GT(glm::dot(Vec3(1.0) - c, geometry::unit_normal(p.vertices)), 0.0) << p.origin;
  }
}

class MeshTest : public ::testing::TestWithParam<int> {};

TEST_P(MeshTest, SubdivisionKeepsAreaAndCounts) {
  const int k = GetParam();
  LoadedScene loaded = load_scene("builtin:cornell", false);
  Mesh mesh = build_mesh(loaded.scene, {k, 0.0});
  size_t expected = 0;
  double polygon_area = 0.0;
  for (const Polygon& p : loaded.scene.polygons) {
    expected += size_t(k * k);
    polygon_area += geometry::area(p.vertices);
  }
  EXPECT_EQ(mesh.size(), expected);
  EXPECT_NEAR(mesh.total_area, polygon_area, 1e-12 * polygon_area);
  for (size_t p = 0; p < loaded.scene.polygons.size(); ++p) {
    double sum = 0.0;
    for (uint32_t e = mesh.first_element_of_polygon[p]; e < mesh.first_element_of_polygon[p + 1];
         ++e) {
      EXPECT_EQ(mesh.polygon[e], p);
      EXPECT_GT(glm::dot(mesh.normal[e], geometry::unit_normal(loaded.scene.polygons[p].vertices)),
                0.999999);
      sum += mesh.area[e];
    }
    EXPECT_NEAR(sum, geometry::area(loaded.scene.polygons[p].vertices), 1e-12);
  }
}

INSTANTIATE_TEST_SUITE_P(Subdivisions, MeshTest, ::testing::Values(1, 2, 5));

TEST(Mesh, ElementSizeBoundsEdges) {
  Scene scene = make_builtin_scene("furnace:lx=1,ly=0.3,lz=2");
  validate_scene(scene);
  Mesh mesh = build_mesh(scene, {1, 0.25});
  std::vector<Vec3> corners;
  for (size_t e = 0; e < mesh.size(); ++e) {
    mesh.corners(e, corners);
    for (size_t k = 0; k < corners.size(); ++k)
      EXPECT_LE(glm::distance(corners[k], corners[(k + 1) % corners.size()]), 0.25 + 1e-12);
  }
}

}  // namespace
}  // namespace radlab
