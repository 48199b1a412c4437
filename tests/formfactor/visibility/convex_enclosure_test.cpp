// is_convex_enclosure (formfactor/visibility/occlusion.h): its verdict equals the definition
// (every vertex on or in front of every polygon's plane, tested pair by pair here) on convex and
// non-convex scenes, including planes that share a normal at different offsets, where one scan
// per normal must keep the least offset rather than a verdict.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <string>
#include <vector>

#include "formfactor/visibility/occlusion.h"
#include "scene/builtin/builtin_scenes.h"
#include "tests/formfactor/visibility/convex_by_definition.h"

namespace radlab {
namespace {

// The rectangle o + s u + t v as m x m quads, front side along u x v.
void add_grid(Scene& scene, const Vec3& o, const Vec3& u, const Vec3& v, int m) {
  for (int j = 0; j < m; ++j)
    for (int i = 0; i < m; ++i) {
      auto at = [&](double a, double b) { return o + u * (a / m) + v * (b / m); };
      scene.polygons.push_back(
          Polygon{{at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)}, 0, "grid"});
    }
}

// The box [0, 2] x [0, 1] x [0, 3], every face split m x m, front sides inward (or outward).
Scene tessellated_box(int m, bool inward = true) {
  Scene scene;
  scene.materials.push_back(Material{"grey", Rgb(0.5), Rgb(0.0)});
  const Vec3 X(2, 0, 0), Y(0, 1, 0), Z(0, 0, 3), O(0.0);
  const std::vector<std::array<Vec3, 3>> faces = {
      {O, Z, X}, {O + Y, X, Z},   // floor (up), ceiling (down)
      {O, X, Y}, {O + Z, Y, X},   // z = 0 (+z), z = 3 (-z)
      {O, Y, Z}, {O + X, Z, Y}};  // x = 0 (+x), x = 2 (-x)
  for (const auto& [o, u, v] : faces)
    inward ? add_grid(scene, o, u, v, m) : add_grid(scene, o, v, u, m);
  return scene;
}

TEST(ConvexEnclosure, ATessellatedBoxSeenFromInsideIsConvex) {
  for (int m : {1, 3, 8}) {
    const Scene box = tessellated_box(m);
    ASSERT_EQ(box.polygons.size(), size_t(6 * m * m));
    EXPECT_TRUE(convex_by_definition(box));
    EXPECT_TRUE(is_convex_enclosure(box)) << m;
    const Scene outside = tessellated_box(m, false);
    EXPECT_FALSE(convex_by_definition(outside));
    EXPECT_FALSE(is_convex_enclosure(outside)) << m;
  }
}

TEST(ConvexEnclosure, AParallelPlaneFurtherInBreaksItInEitherOrder) {
  // A raised platform facing up at y = 0.5 shares the floor's normal: the floor's vertices lie
  // behind its plane. A cache of verdicts per normal would call this convex when the floor comes
  // first; the least offset per normal does not.
  Scene box = tessellated_box(3);
  Scene platform = box;
  add_grid(platform, Vec3(0.5, 0.5, 0.5), Vec3(0, 0, 1), Vec3(1, 0, 0), 2);
  EXPECT_FALSE(convex_by_definition(platform));
  EXPECT_FALSE(is_convex_enclosure(platform));
  Scene first = platform;
  std::rotate(first.polygons.begin(), first.polygons.end() - 4, first.polygons.end());
  EXPECT_FALSE(is_convex_enclosure(first));
  // A patch lying on the floor's own plane (in a hole's place) keeps it convex.
  Scene flush = box;
  add_grid(flush, Vec3(0.5, 0.0, 0.5), Vec3(0, 0, 1), Vec3(1, 0, 0), 2);
  EXPECT_TRUE(convex_by_definition(flush));
  EXPECT_TRUE(is_convex_enclosure(flush));
}

TEST(ConvexEnclosure, AgreesWithTheDefinitionOnBuiltInScenes) {
  for (const char* spec : {"cube", "furnace", "cornell", "floors:k=2,patch=2", "floors:k=1"}) {
    const Scene scene = make_builtin_scene(spec);
    EXPECT_EQ(is_convex_enclosure(scene), convex_by_definition(scene)) << spec;
  }
  EXPECT_TRUE(is_convex_enclosure(make_builtin_scene("cube")));
  EXPECT_FALSE(is_convex_enclosure(make_builtin_scene("floors:k=2,patch=2")));
}

}  // namespace
}  // namespace radlab
