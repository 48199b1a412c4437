// The MGF primitives' tessellation without MGF text (scene/tessellate.h): areas
// against the chord factors of docs/scenes.md's table, and orientation (closed surfaces close,
// normals outward for positive radii, inward for negative ones).
#include "scene/tessellate.h"

#include <gtest/gtest.h>

#include <cmath>
#include <glm/geometric.hpp>
#include <numbers>

#include "scene/geometry.h"

namespace radlab {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr int kSegments = 16;  // MGF's default: 4 per quarter circle

double total_area(const tessellate::Polygons& polygons) {
  double a = 0.0;
  for (const auto& p : polygons) a += geometry::area(p);
  return a;
}

// Sum of the area-weighted normals: zero for a closed surface.
Vec3 total_vector_area(const tessellate::Polygons& polygons) {
  Vec3 s(0.0);
  for (const auto& p : polygons) s += geometry::area(p) * geometry::unit_normal(p);
  return s;
}

// Divergence theorem: (1/3) sum over faces of (centroid . n) A is the enclosed volume for outward
// normals of a closed surface, minus it for inward ones.
double signed_volume(const tessellate::Polygons& polygons) {
  double v = 0.0;
  for (const auto& p : polygons)
    v += glm::dot(geometry::centroid(p), geometry::unit_normal(p)) * geometry::area(p) / 3.0;
  return v;
}

TEST(Tessellate, CylinderAreaIsTheChordFactorExactly) {
  const double r = 0.3, h = 2.0;
  const auto quads = tessellate::cone(Vec3(1, 2, 3), r, Vec3(1, 2, 3 + h), r, kSegments);
  ASSERT_EQ(quads.size(), 16u);
  // 16 rectangles of width 2 r sin(pi/16): the true area times sin(pi/16)/(pi/16), -0.64%.
  const double factor = std::sin(kPi / 16) / (kPi / 16);
  EXPECT_NEAR(factor - 1, -0.0064, 5e-5);
  EXPECT_NEAR(total_area(quads), 2 * kPi * r * h * factor, 1e-12);
  // Outward: every quad faces away from the axis (x = 1, y = 2); inward for a negative radius.
  for (const auto& q : quads) {
    const Vec3 c = geometry::centroid(q);
    EXPECT_GT(glm::dot(geometry::unit_normal(q), Vec3(c.x - 1, c.y - 2, 0)), 0);
  }
  for (const auto& q : tessellate::cone(Vec3(0), -r, Vec3(0, 0, h), -r, kSegments)) {
    const Vec3 c = geometry::centroid(q);
    EXPECT_LT(glm::dot(geometry::unit_normal(q), Vec3(c.x, c.y, 0)), 0);
  }
}

TEST(Tessellate, ConeWithAZeroRadiusMakesTriangles) {
  const auto tris = tessellate::cone(Vec3(0), 1.0, Vec3(0, 0, 1), 0.0, kSegments);
  ASSERT_EQ(tris.size(), 16u);
  for (const auto& t : tris) EXPECT_EQ(t.size(), 3u);
  // Each triangle: base chord 2 sin(pi/16), slant height to the chord's midpoint.
  const double chord = 2 * std::sin(kPi / 16), apothem = std::cos(kPi / 16);
  EXPECT_NEAR(total_area(tris), 16 * 0.5 * chord * std::sqrt(1 + apothem * apothem), 1e-12);
}

TEST(Tessellate, SphereIsClosedOutwardAnd3Point2PercentSmall) {
  const double r = 1.5;
  const auto polygons = tessellate::sphere(Vec3(0.5, -1, 2), r, kSegments);
  ASSERT_EQ(polygons.size(), 8u * 16u);  // 96 quads and 32 pole triangles
  int triangles = 0;
  for (const auto& p : polygons) triangles += p.size() == 3;
  EXPECT_EQ(triangles, 32);
  // docs/scenes.md: -3.2% (rounded to 0.1%).
  EXPECT_NEAR(total_area(polygons) / (4 * kPi * r * r) - 1, -0.032, 0.0005);
  EXPECT_LT(glm::length(total_vector_area(polygons)), 1e-12);
  EXPECT_GT(signed_volume(polygons), 0.9 * 4.0 / 3.0 * kPi * r * r * r);
  EXPECT_LT(signed_volume(tessellate::sphere(Vec3(0), -r, kSegments)), 0);
}

TEST(Tessellate, RingAndDiscFaceAlongTheNormal) {
  const Vec3 n = glm::normalize(Vec3(1, 1, 0));
  const auto disc = tessellate::ring(Vec3(0), n, 0.0, 2.0, kSegments);
  ASSERT_EQ(disc.size(), 16u);
  // 16 triangles: (16/2) sin(2 pi/16) r^2, i.e. -2.6% of pi r^2 (docs/scenes.md).
  EXPECT_NEAR(total_area(disc), 8 * std::sin(2 * kPi / 16) * 4.0, 1e-12);
  EXPECT_NEAR(total_area(disc) / (kPi * 4.0) - 1, -0.026, 0.0005);
  const auto ring = tessellate::ring(Vec3(0), n, 1.0, 2.0, kSegments);
  EXPECT_NEAR(total_area(ring), 8 * std::sin(2 * kPi / 16) * (4.0 - 1.0), 1e-12);
  for (const auto& p : ring) EXPECT_NEAR(glm::dot(geometry::unit_normal(p), n), 1.0, 1e-12);
}

TEST(Tessellate, TorusIsClosedOutwardAnd2Point2PercentSmall) {
  const double rmin = 1.0, rmax = 2.0;  // tube centre radius 1.5, tube radius 0.5
  const auto quads = tessellate::torus(Vec3(0), Vec3(0, 0, 1), rmin, rmax, kSegments);
  ASSERT_EQ(quads.size(), 256u);
  const double exact = 4 * kPi * kPi * 1.5 * 0.5;
  EXPECT_NEAR(total_area(quads) / exact - 1, -0.022, 0.0005);  // docs/scenes.md: -2.2%
  EXPECT_LT(glm::length(total_vector_area(quads)), 1e-12);
  EXPECT_GT(signed_volume(quads), 0.9 * 2 * kPi * kPi * 1.5 * 0.25);
  EXPECT_LT(signed_volume(tessellate::torus(Vec3(0), Vec3(0, 0, 1), -rmin, -rmax, kSegments)), 0);
}

TEST(Tessellate, PrismIsClosedWithExactArea) {
  // A right triangle base in z = 0 wound counter-clockwise (normal +z), length 3: the far end
  // lies at -z, so the prism is outward.
  const std::vector<Vec3> base = {Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(0, 1, 0)};
  const auto polygons = tessellate::prism(base, 3.0);
  ASSERT_EQ(polygons.size(), 5u);
  const double perimeter = 2 + 1 + std::sqrt(5.0);
  EXPECT_NEAR(total_area(polygons), 2 * 1.0 + perimeter * 3.0, 1e-12);
  EXPECT_LT(glm::length(total_vector_area(polygons)), 1e-12);
  EXPECT_NEAR(signed_volume(polygons), 1.0 * 3.0, 1e-12);
  EXPECT_NEAR(signed_volume(tessellate::prism(base, -3.0)), -3.0, 1e-12);
}

}  // namespace
}  // namespace radlab
