// The scaling family builtin:floors (scene/builtin/building_scenes.h): polygon count and area
// exactly linear in the number of storeys, the mesh keeping the area, a closed building (rays
// never escape, and the raycast matrix's rows sum to 1 within the method's stated error, so the
// furnace gives E / (1 - rho)), and storeys that see one another through the atrium.
#include "scene/builtin/building_scenes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <limits>
#include <numbers>
#include <random>

#include "core/error.h"
#include "formfactor/matrix/matrix.h"
#include "formfactor/methods/raycast.h"
#include "scene/builtin/builtin_scenes.h"
#include "scene/geometry.h"
#include "scene/mesh.h"
#include "scene/scene_loader.h"
#include "scene/validate.h"

namespace radlab {
namespace {

double total_area(const Scene& scene) {
  double a = 0.0;
  for (const Polygon& p : scene.polygons) a += geometry::area(p.vertices);
  return a;
}

bool starts_with(const std::string& s, const std::string& prefix) {
  return s.rfind(prefix, 0) == 0;
}

TEST(FloorsScene, CountAndAreaGrowExactlyLinearlyInTheStoreys) {
  // The header's closed forms: 1,856 k + 96 polygons, 464 k + 24 m^2. At the default patch
  // (0.5 m) every coordinate is a multiple of 0.5, every patch an axis-aligned rectangle of
  // dyadic sides, so each area and their sum are exact in double: asserted with ==.
  for (int k = 1; k <= 6; ++k) {
    LoadedScene loaded = load_scene("builtin:floors:k=" + std::to_string(k), false);
    const Scene& scene = loaded.scene;
    EXPECT_EQ(loaded.report.dropped, 0);
    EXPECT_EQ(loaded.report.triangulated, 0);
    EXPECT_EQ(scene.polygons.size(), size_t(1856 * k + 96)) << "k " << k;
    EXPECT_EQ(total_area(scene), 464.0 * k + 24.0) << "k " << k;
    size_t lamps = 0;
    for (const Polygon& p : scene.polygons) {
      EXPECT_EQ(p.vertices.size(), 4u) << p.origin;
      EXPECT_TRUE(geometry::is_convex(p.vertices)) << p.origin;
      lamps += scene.materials[size_t(p.material)].emission.x > 0 ? 1 : 0;
    }
    EXPECT_EQ(lamps, size_t(32 * k));  // eight 1 m^2 luminaires of four patches per storey
    EXPECT_FALSE(scene.is_grey());
    EXPECT_TRUE(scene.camera.has_value());
  }
  // Every patch size has its luminaires: each lamp's 1 m^2 square (x0 + 0.5 .. x0 + 1.5,
  // z0 .. z0 + 1 over each desk) has its centre on an emitting ceiling patch of every storey (at
  // coarse patches one patch may hold two lamps, so patches are not counted).
  for (const char* patch : {"0.5", "1", "2", "3", "5"}) {
    const Scene scene = make_builtin_scene(std::string("floors:k=2,patch=") + patch);
    for (int storey = 0; storey < 2; ++storey)
      for (double x0 : {1.0, 9.0})
        for (double z0 : {1.0, 4.5, 8.0, 10.5}) {
          const Vec3 centre(x0 + 1.0, storey * 3.5 + 3.0, z0 + 0.5);
          bool lit = false;
          for (const Polygon& p : scene.polygons) {
            if (!(scene.materials[size_t(p.material)].emission.x > 0)) continue;
            Vec3 lo = p.vertices[0], hi = p.vertices[0];
            for (const Vec3& v : p.vertices) {
              lo = glm::min(lo, v);
              hi = glm::max(hi, v);
            }
            lit |= lo.y == centre.y && hi.y == centre.y && lo.x <= centre.x && centre.x <= hi.x &&
                   lo.z <= centre.z && centre.z <= hi.z;
          }
          EXPECT_TRUE(lit) << "patch " << patch << ", storey " << storey << ", lamp at " << x0
                           << " " << z0;
        }
  }
  // 200,000 polygons at k = 108 (the family's top, issue 33), counted without the scene.
  EXPECT_GE(1856 * 108 + 96, 200000);
}

TEST(FloorsScene, TheMeshKeepsTheArea) {
  // Every element lies in one polygon and the elements tile it, so the mesh's total area is the
  // polygons' (to rounding: the sums run in different orders, 1e-12 relative).
  const Scene scene = make_builtin_scene("floors:k=2");
  const double polygons = total_area(scene);
  for (int subdiv : {1, 2, 3}) {
    const Mesh mesh = build_mesh(scene, {subdiv, 0.0});
    double elements = 0.0;
    for (double a : mesh.area) elements += a;
    EXPECT_NEAR(elements, polygons, 1e-12 * polygons) << "subdiv " << subdiv;
    EXPECT_EQ(mesh.size(), scene.polygons.size() * size_t(subdiv * subdiv));
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

TEST(FloorsScene, ClosedAndEveryVisibleSideIsAFrontSide) {
  // Rays from points of the free space of every storey (above the desks, which end at 1 m; in the
  // atrium too) never escape and always meet a polygon's front side. A building with a missing
  // wall, a slab edge or a hole in the roof fails the first; a face turned the wrong way, the
  // second.
  const int k = 3;
  const Scene scene = make_builtin_scene("floors:k=" + std::to_string(k));
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int rays = 0;
  for (int s = 0; s < 120; ++s) {
    const double storey = double(s % k) * 3.5;
    const Vec3 origin(0.05 + 11.9 * unit(rng), storey + 1.2 + 1.7 * unit(rng),
                      0.05 + 11.9 * unit(rng));
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
  EXPECT_EQ(rays, 960);
}

struct CoarseBuilding {
  Scene scene;
  Mesh mesh;
  FormFactorMatrix matrix;
  std::unique_ptr<RaycastFormFactors> method;
};

// Three storeys at patch 2 m (504 polygons), one element per polygon, the raycast matrix in double.
CoarseBuilding coarse_building() {
  CoarseBuilding b;
  b.scene = make_builtin_scene("floors:k=3,patch=2");
  validate_scene(b.scene);
  b.mesh = build_mesh(b.scene, {1, 0.0});
  b.method = std::make_unique<RaycastFormFactors>(b.scene, b.mesh, RaycastOptions{});
  BuildReport report;
  b.matrix = build_matrix(*b.method, b.mesh.size(), Precision::kDouble, report);
  return b;
}

TEST(FloorsScene, FurnaceGivesEOverOneMinusRho) {
  // Every polygon emitting E = 1 and reflecting rho = 0.5: in a closed scene every row of F sums
  // to 1, so B = E / (1 - rho) = 2 everywhere. The raycast matrix states each row's error (its
  // quadrature tolerance and its visibility sampling, form_factor_method.h); B solves
  // B = E + rho F B exactly (100 Jacobi sweeps: 2^-100), so |B - 2| <= rho / (1 - rho) * the
  // largest row error = the largest row error. An opening (a missing wall, a hole in the roof)
  // makes its neighbours' rows short by their view of it: 0.05 and more here.
  CoarseBuilding b = coarse_building();
  const size_t n = b.mesh.size();
  double worst_row_error = 0.0;
  for (size_t i = 0; i < n; ++i) {
    const double allowance = b.method->row_sum_error_common() + b.method->row_sum_allowance(i);
    double sum = 0.0;
    for (size_t j = 0; j < n; ++j) sum += b.matrix.at(i, j);
    EXPECT_NEAR(sum, 1.0, allowance) << b.scene.polygons[b.mesh.polygon[i]].origin;
    worst_row_error = std::max(worst_row_error, allowance);
  }
  EXPECT_LT(worst_row_error, 0.05);  // the check above is tighter than any opening
  std::vector<double> B(n, 1.0), next(n);
  for (int sweep = 0; sweep < 100; ++sweep) {
    for (size_t i = 0; i < n; ++i) {
      double gathered = 0.0;
      for (size_t j = 0; j < n; ++j) gathered += b.matrix.at(i, j) * B[j];
      next[i] = 1.0 + 0.5 * gathered;
    }
    B.swap(next);
  }
  for (size_t i = 0; i < n; ++i) EXPECT_NEAR(B[i], 2.0, worst_row_error + 1e-12);
}

TEST(FloorsScene, StoreysSeeEachOtherThroughTheAtrium) {
  // The ground floor under the atrium sees the ceiling of the storey above through the hole in
  // the slab, and the roof through two: F between storeys is not zero. (Without the atrium every
  // storey is a closed box of its own and these are exactly 0.)
  CoarseBuilding b = coarse_building();
  const size_t n = b.mesh.size();
  auto exchange = [&](const std::string& from, const std::string& to) {
    double sum = 0.0;  // sum of A_i F_ij: the power-weighted exchange
    for (size_t i = 0; i < n; ++i) {
      if (!starts_with(b.scene.polygons[b.mesh.polygon[i]].origin, from)) continue;
      for (size_t j = 0; j < n; ++j)
        if (starts_with(b.scene.polygons[b.mesh.polygon[j]].origin, to))
          sum += b.mesh.area[i] * b.matrix.at(i, j);
    }
    return sum;
  };
  EXPECT_GT(exchange("floors/s0/floor", "floors/s1/ceiling"), 0.0);
  EXPECT_GT(exchange("floors/s0/floor", "floors/s2/ceiling"), 0.0);
  EXPECT_GT(exchange("floors/s1/atrium-edge", "floors/s0/atrium-edge"), 0.0);
  // Floors face up and the ceilings below them face down: those never exchange.
  EXPECT_EQ(exchange("floors/s1/floor", "floors/s0/ceiling"), 0.0);
}

TEST(FloorsScene, BadParametersNameTheKey) {
  for (const char* bad : {"floors:k=0", "floors:k=-2", "floors:patch=0", "floors:patch=-1",
                          "floors:light_scale=0", "floors:nosuch=1"})
    EXPECT_THROW(make_builtin_scene(bad), UsageError) << bad;
}

}  // namespace
}  // namespace radlab
