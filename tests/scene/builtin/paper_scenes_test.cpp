// The built-in reconstructions of the papers' scenes (builtin:office, builtin:room,
// builtin:computer-room): element counts at the documented mesh near the papers', closed
// enclosures whose every polygon faces the free space, an emitter and a camera each.
#include "scene/builtin/paper_scenes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <glm/geometric.hpp>
#include <limits>
#include <numbers>
#include <random>

#include "core/error.h"
#include "scene/builtin/builtin_scenes.h"
#include "scene/geometry.h"
#include "scene/mesh.h"
#include "scene/scene_loader.h"

namespace radlab {
namespace {

struct PaperScene {
  const char* name;
  int subdiv;        // the documented mesh
  size_t patches;    // polygons (exact: the scenes are deterministic)
  double elements;   // the paper's element count
  double tolerance;  // relative deviation allowed from it
  Vec3 room;         // the enclosure [0, room]
};

void PrintTo(const PaperScene& s, std::ostream* out) {
  *out << s.name;
}

const PaperScene kScenes[] = {
    {"office", kOfficeSubdiv, 438, 7000, 0.03, {5.4, 2.6, 4.2}},
    {"room", kRoomSubdiv, 340, 1336, 0.03, {5.0, 3.0, 4.0}},
    {"computer-room", kComputerRoomSubdiv, 540, 4953, 0.03, {8.0, 3.0, 6.0}},
};

class PaperSceneTest : public ::testing::TestWithParam<PaperScene> {};

TEST_P(PaperSceneTest, ElementCountNearThePapersAtTheDocumentedMesh) {
  LoadedScene loaded = load_scene(std::string("builtin:") + GetParam().name, false);
  EXPECT_EQ(loaded.report.dropped, 0);
  EXPECT_EQ(loaded.report.triangulated, 0);
  EXPECT_EQ(loaded.scene.polygons.size(), GetParam().patches);
  Mesh mesh = build_mesh(loaded.scene, MeshOptions{GetParam().subdiv, 0.0});
  EXPECT_NEAR(double(mesh.size()) / GetParam().elements, 1.0, GetParam().tolerance)
      << mesh.size() << " elements";
  EXPECT_GE(loaded.scene.emitter_count(), 1);
  EXPECT_FALSE(loaded.scene.is_grey());
  EXPECT_TRUE(loaded.scene.camera.has_value());
  for (const Polygon& p : loaded.scene.polygons) {
    EXPECT_EQ(p.vertices.size(), 4u) << p.origin;
    EXPECT_TRUE(geometry::is_convex(p.vertices)) << p.origin;
  }
}

constexpr double kNone = std::numeric_limits<double>::infinity();

// Ray against a convex planar polygon: the distance along the ray, or infinity.
double hit(const Vec3& origin, const Vec3& dir, const Polygon& p, bool& front) {
  const Vec3 n = geometry::unit_normal(p.vertices);
  const double denom = glm::dot(n, dir);
  if (std::abs(denom) < 1e-12) return kNone;
  const double t = glm::dot(n, p.vertices[0] - origin) / denom;
  if (t <= 1e-9) return kNone;
  const Vec3 x = origin + t * dir;
  const size_t k = p.vertices.size();
  for (size_t i = 0; i < k; ++i) {
    const Vec3& a = p.vertices[i];
    const Vec3& b = p.vertices[(i + 1) % k];
    if (glm::dot(glm::cross(b - a, x - a), n) < -1e-12) return kNone;
  }
  front = denom < 0;
  return t;
}

TEST_P(PaperSceneTest, ClosedAndEveryVisibleSideIsAFrontSide) {
  // Rays from points in the free space above the furniture (y in [1.75, 2.45]; the tallest
  // piece, a partition, ends at 1.6 m) never escape and always meet a polygon's front side.
  Scene scene = make_builtin_scene(GetParam().name);
  const Vec3 room = GetParam().room;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int rays = 0;
  for (int s = 0; s < 150; ++s) {
    const Vec3 origin(0.05 + 0.9 * room.x * unit(rng), 1.75 + 0.7 * unit(rng),
                      0.05 + 0.9 * room.z * unit(rng));
    for (int d = 0; d < 8; ++d) {
      const double z = 2 * unit(rng) - 1, phi = 2 * std::numbers::pi * unit(rng);
      const double r = std::sqrt(1 - z * z);
      const Vec3 dir(r * std::cos(phi), z, r * std::sin(phi));
      double nearest = kNone;
      bool front = false;
      for (const Polygon& p : scene.polygons) {
        bool f = false;
        const double t = hit(origin, dir, p, f);
        if (t < nearest) {
          nearest = t;
          front = f;
        }
      }
      ASSERT_TRUE(std::isfinite(nearest))
          << "a ray escapes from " << origin.x << " " << origin.y << " " << origin.z;
      EXPECT_TRUE(front) << "a ray meets a back side";
      ++rays;
    }
  }
  EXPECT_EQ(rays, 1200);
}

TEST_P(PaperSceneTest, ParametersScaleLightAndReflectance) {
  const std::string name = GetParam().name;
  Scene base = make_builtin_scene(name);
  Scene scaled = make_builtin_scene(name + ":light_scale=2,rho_scale=0.5");
  ASSERT_EQ(base.materials.size(), scaled.materials.size());
  for (size_t m = 0; m < base.materials.size(); ++m) {
    EXPECT_EQ(scaled.materials[m].emission, 2.0 * base.materials[m].emission);
    EXPECT_EQ(scaled.materials[m].reflectance, 0.5 * base.materials[m].reflectance);
  }
  // A coarser patch size makes fewer patches.
  EXPECT_LT(make_builtin_scene(name + ":patch=1.2").polygons.size(), base.polygons.size());
  EXPECT_THROW(make_builtin_scene(name + ":rho_scale=2"), UsageError);
  EXPECT_THROW(make_builtin_scene(name + ":light_scale=0"), UsageError);
  EXPECT_THROW(make_builtin_scene(name + ":patch=-1"), UsageError);
  EXPECT_THROW(make_builtin_scene(name + ":nosuch=1"), UsageError);
}

INSTANTIATE_TEST_SUITE_P(Builtin, PaperSceneTest, ::testing::ValuesIn(kScenes),
                         [](const ::testing::TestParamInfo<PaperScene>& param) {
                           std::string n = param.param.name;
                           for (char& c : n)
                             if (c == '-') c = '_';
                           return n;
                         });

}  // namespace
}  // namespace radlab
