// The stability scenes (scene/builtin/stability_scenes.h): each is the extreme its documentation
// promises — the area ratio, the sliver aspect, the lamp's size and emission, the gap, the
// coplanar overlap — and loads without repairs; bad parameters are usage errors naming the key.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>

#include "core/error.h"
#include "scene/builtin/builtin_scenes.h"
#include "scene/geometry.h"
#include "scene/validate.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

const Polygon& find(const Scene& scene, const std::string& origin) {
  for (const Polygon& p : scene.polygons)
    if (p.origin == origin) return p;
  throw std::runtime_error("no polygon " + origin);
}

double area(const Polygon& p) {
  return geometry::area(p.vertices);
}

// Loads a built-in and validates it; the stability scenes must need no repair (a repair would
// change the extreme they are built to show).
Scene load(const std::string& spec) {
  Scene scene = make_builtin_scene(spec);
  ValidationReport report = validate_scene(scene);
  EXPECT_TRUE(report.warnings.empty()) << spec << ": " << report.warnings.front();
  EXPECT_EQ(report.dropped + report.triangulated, 0) << spec;
  return scene;
}

double total_area(const Scene& scene) {
  double a = 0.0;
  for (const Polygon& p : scene.polygons) a += area(p);
  return a;
}

TEST(StabilityScenes, AreaRatioBetweenNeighbours) {
  for (double ratio : {1e6, 1e4}) {
    Scene s = load("area-ratio:ratio=" + std::to_string(ratio));
    const double corner = area(find(s, "area-ratio/floor-corner"));
    const double main = area(find(s, "area-ratio/floor-main"));
    // The two share the edge x = c, 0 <= z <= c; areas 1/ratio and 1 - c (rounding only).
    EXPECT_NEAR(main / corner, ratio * (1 - 1 / std::sqrt(ratio)), 1e-9 * ratio);
    EXPECT_NEAR(total_area(s), 6.0, 1e-12);  // the floor is covered once: the cube is closed
  }
}

TEST(StabilityScenes, SliversHaveTheRequestedAspect) {
  Scene s = load("slivers:aspect=1e-4,count=3");
  int slivers = 0;
  for (const Polygon& p : s.polygons) {
    if (p.origin.find("floor-sliver") == std::string::npos) continue;
    ++slivers;
    ASSERT_EQ(p.vertices.size(), 3u);
    double longest = 0.0;
    for (size_t k = 0; k < 3; ++k)
      longest = std::max(longest, glm::length(p.vertices[k] - p.vertices[(k + 1) % 3]));
    const double altitude = 2 * area(p) / longest;  // the shortest altitude
    EXPECT_NEAR(altitude / longest, 1e-4, 1e-6) << p.origin;
    EXPECT_GT(glm::dot(geometry::unit_normal(p.vertices), Vec3(0, 1, 0)), 0.99) << "faces up";
  }
  EXPECT_EQ(slivers, 3);
  EXPECT_NEAR(total_area(s), 6.0, 1e-12);
}

TEST(StabilityScenes, TinyLightIsTinyBrightAndFacesTheRoom) {
  Scene s = load("tiny-light");
  const Polygon& lamp = find(s, "tiny-light/lamp");
  EXPECT_NEAR(area(lamp), 1e-6, 1e-15);
  EXPECT_EQ(s.materials[size_t(lamp.material)].emission, Rgb(1e6));
  EXPECT_EQ(s.emitter_count(), 1);
  EXPECT_NEAR(geometry::centroid(lamp.vertices).y, 2.99, 1e-12);
  EXPECT_LT(glm::dot(geometry::unit_normal(lamp.vertices), Vec3(0, 1, 0)), -0.99) << "faces down";
  EXPECT_NEAR(total_area(s), 2 * (4 * 3 + 4 * 5 + 3 * 5) + 1e-6, 1e-9);
  EXPECT_TRUE(s.is_grey());
}

TEST(StabilityScenes, OverlapIsCoplanarWithTheFloor) {
  // Not validated: overlap detection may warn or split; the generator's own output is the case.
  Scene s = make_builtin_scene("overlap");
  const Polygon& rug = find(s, "overlap/rug");
  const Polygon& floor = find(s, "overlap/floor");
  for (const Vec3& v : rug.vertices) EXPECT_EQ(v.y, 0.0);
  for (const Vec3& v : floor.vertices) EXPECT_EQ(v.y, 0.0);
  EXPECT_NEAR(area(rug), 0.25, 1e-12);
  EXPECT_NEAR(total_area(s), 6.25, 1e-12);  // the rug's area counted twice: the overlap
  Scene lifted = make_builtin_scene("overlap:lift=0.01");
  for (const Vec3& v : find(lifted, "overlap/rug").vertices) EXPECT_EQ(v.y, 0.01);
}

TEST(StabilityScenes, NearPairFacesAcrossTheGap) {
  Scene s = load("near-pair:gap=0.001");
  ASSERT_EQ(s.polygons.size(), 2u);
  const Polygon& lower = find(s, "near-pair/lower");
  const Polygon& upper = find(s, "near-pair/upper");
  EXPECT_GT(geometry::unit_normal(lower.vertices).y, 0.99);
  EXPECT_LT(geometry::unit_normal(upper.vertices).y, -0.99);
  EXPECT_EQ(geometry::centroid(upper.vertices).y - geometry::centroid(lower.vertices).y, 0.001);
  EXPECT_TRUE(s.materials[size_t(lower.material)].emits());
  EXPECT_FALSE(s.materials[size_t(upper.material)].emits());
}

TEST(StabilityScenes, BadParametersAreUsageErrorsNamingTheKey) {
  using radlab::testing::expect_error;
  expect_error<UsageError>([] { make_builtin_scene("area-ratio:ratio=0.5"); }, {"'ratio'"});
  expect_error<UsageError>([] { make_builtin_scene("slivers:aspect=0"); }, {"'aspect'"});
  expect_error<UsageError>([] { make_builtin_scene("slivers:count=0"); }, {"'count'"});
  expect_error<UsageError>([] { make_builtin_scene("tiny-light:rho=1.5"); }, {"'rho'"});
  expect_error<UsageError>([] { make_builtin_scene("near-pair:gap=-1"); }, {"'gap'"});
  expect_error<UsageError>([] { make_builtin_scene("overlap:colour=3"); }, {"colour"});
}

}  // namespace
}  // namespace radlab
