// The skipped-end prefilter (visibility.cpp, compute_end_neighbours): the pieces of unblocked
// segments next to their ends are traced again only where another polygon comes near. It must
// change the cost only: V and its standard error are the same with and without it. (The packets
// of pieces are the same either way, and only packets whose every piece is proven clear are left
// out: Embree's answer for a grazing ray depends on its packet, and leaving single pieces out
// changed V on 2 of hospital.mgf's 35 M traced pairs.)
#include <gtest/gtest.h>

#include <algorithm>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <random>
#include <string>
#include <vector>

#include "formfactor/methods/raycast.h"
#include "formfactor/visibility/embree_scene.h"
#include "formfactor/visibility/visibility.h"
#include "scene/builtin/builtin_scenes.h"
#include "scene/scene_loader.h"
#include "scene/validate.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

// Every facing pair's V and sigma with the prefilter (the default) and without it, as raycast
// draws its rays (16 a pair, up to 4,096 for large form factors, close pairs in solid angle).
// Counts the pairs compared in `pairs`.
// `max_neighbours`: the prefilter's per-element list limit (0: grids alone, as where the memory
// budget runs out).
void expect_same_visibility(const Scene& scene, const Mesh& mesh, uint64_t seed, size_t& pairs,
                            size_t max_neighbours = 128) {
  const double eps = plane_epsilon(mesh);
  Visibility filtered(scene, mesh, 16, seed, /*shaft_culling=*/true, 4096, true);
  filtered.limit_end_lists(max_neighbours);
  Visibility traced(scene, mesh, 16, seed, true, 4096, true);
  traced.set_end_prefilter(false);
  RowCost cost;
  pairs = 0;
  for (size_t i = 0; i < mesh.size(); ++i)
    for (size_t j = i + 1; j < mesh.size(); ++j) {
      if (!pair_faces(mesh, i, j, eps)) continue;
      ++pairs;
      double sigma_filtered = 0.0, sigma_traced = 0.0;
      ASSERT_EQ(filtered.fraction(i, j, cost, &sigma_filtered),
                traced.fraction(i, j, cost, &sigma_traced))
          << i << " " << j;
      ASSERT_EQ(sigma_filtered, sigma_traced) << i << " " << j;
    }
  // Without the prefilter every piece is traced; with it most are proven clear.
  EXPECT_EQ(traced.end_pieces_cleared(), 0u);
  EXPECT_EQ(filtered.end_pieces_cleared() + filtered.end_pieces_traced(),
            traced.end_pieces_traced());
  EXPECT_GT(filtered.end_pieces_cleared(),
            (max_neighbours > 0 ? 10 : 1) * filtered.end_pieces_traced());
}

// The Cornell box at --subdiv 6: blocks standing on the floor, walls meeting at every edge, so
// pieces next to the touching edges are traced again and the rest are not.
void expect_same_visibility_on_the_cornell_box(uint64_t seed, size_t max_neighbours) {
  Scene scene = make_builtin_scene("cornell");
  validate_scene(scene);
  const Mesh mesh = build_mesh(scene, {6, 0.0});
  size_t pairs = 0;
  expect_same_visibility(scene, mesh, seed, pairs, max_neighbours);
  EXPECT_GT(pairs, 10000u);
}

TEST(SkippedEnds, PrefilterChangesNoVisibilityOnTheCornellBox) {
  expect_same_visibility_on_the_cornell_box(3, 128);
}

// Grids alone (no element keeps its neighbour lists): pieces in marked cells are traced.
TEST(SkippedEnds, GridsWithoutListsChangeNoVisibility) {
  expect_same_visibility_on_the_cornell_box(5, 0);
}

// RenderPark's luminaire (examp1.mgf): louvres and reflector strips touching at shallow angles,
// close pairs of 4,096 rays. The prefilter's first version, whose grid left out the pieces'
// reach when it chose a neighbour's cells, changed V here and nowhere on the Cornell box.
TEST(SkippedEnds, PrefilterChangesNoVisibilityOnALuminaire) {
  std::string missing;
  const std::string path = testing::shared_scene("renderpark/examp1.mgf", missing);
  if (path.empty()) {
    RADLAB_SHARED_MISSING(missing);
  }
  Scene scene = load_scene(path, false).scene;
  const Mesh mesh = build_mesh(scene, {1, 0.0});
  size_t pairs = 0;
  expect_same_visibility(scene, mesh, 0, pairs);
  EXPECT_GT(pairs, 2000u);
}

// elements_near returns a superset of the elements that meet the sphere: every element with a
// corner inside it is there.
TEST(SkippedEnds, ElementsNearHoldsEveryElementWithACornerInTheSphere) {
  Scene scene = make_builtin_scene("cornell");
  validate_scene(scene);
  const Mesh mesh = build_mesh(scene, {4, 0.0});
  const EmbreeScene embree(mesh);
  Vec3 lo(1e300), hi(-1e300);
  for (const Vec3& v : mesh.vertices) lo = glm::min(lo, v), hi = glm::max(hi, v);
  const double diagonal = glm::length(hi - lo);
  std::mt19937_64 random(11);
  std::uniform_real_distribution<double> share(-0.05, 1.05), size(0.0, 0.15 * diagonal);
  size_t found_total = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const Vec3 center = lo + Vec3(share(random), share(random), share(random)) * (hi - lo);
    const double radius = size(random);
    std::vector<uint32_t> found;
    embree.elements_near(center, radius, found);
    std::sort(found.begin(), found.end());
    for (size_t e = 0; e < mesh.size(); ++e)
      for (uint32_t v : mesh.element_vertices(e))
        if (glm::distance(mesh.vertices[v], center) <= radius) {
          ASSERT_TRUE(std::binary_search(found.begin(), found.end(), uint32_t(e)))
              << "trial " << trial << " element " << e;
          ++found_total;
        }
  }
  EXPECT_GT(found_total, 100u);
}

}  // namespace
}  // namespace radlab
