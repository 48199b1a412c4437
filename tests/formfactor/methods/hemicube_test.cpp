// The hemicube against its own error theory, on the catalogue and in occluded rooms.
//
// Tolerances are derived in the comments next to them, never tuned to the measured error.
#include "formfactor/methods/hemicube.h"

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
#include "formfactor/methods/raycast.h"
#include "formfactor/registry.h"
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
// Hemicube.

TEST(Hemicube, PixelWeights) {
  // Exact weights tile the hemisphere: they sum to 1 up to rounding (3 R^2 terms of ~1e-16
  // relative error each: 1e-12 is generous).
  for (int R : {2, 10, 150, 256}) {
    std::vector<double> w = hemicube_weights(R, HemicubeWeighting::kExact);
    EXPECT_EQ(w.size(), size_t(3 * R * R));
    EXPECT_NEAR(std::accumulate(w.begin(), w.end(), 0.0), 1.0, 1e-12) << R;
    EXPECT_GT(*std::min_element(w.begin(), w.end()), 0.0);
  }
  // Midpoint weights are the midpoint rule for the same integrals: their sum misses 1 by
  // O(h^2), h = 2/R, so doubling R divides the miss by 4 (to O(h^2) relative: within 2% here).
  auto miss = [](int R) {
    std::vector<double> w = hemicube_weights(R, HemicubeWeighting::kMidpoint);
    return std::accumulate(w.begin(), w.end(), 0.0) - 1.0;
  };
  for (int R : {50, 100, 200}) EXPECT_NEAR(miss(R) / miss(2 * R), 4.0, 0.08) << R;
}

// A differential receiver (a tiny square, so its centroid is the origin and its first edge runs
// along +x: the hemicube's axes are x, y, z) under a centred square of half-width w at height 1.
double hemicube_under_square(double w, int R, HemicubeWeighting weighting, double* exact) {
  const double e = 1e-3;
  std::vector<Vec3> receiver = {{-e, -e, 0}, {e, -e, 0}, {e, e, 0}, {-e, e, 0}};
  std::vector<Vec3> square = {{-w, -w, 1}, {-w, w, 1}, {w, w, 1}, {w, -w, 1}};  // faces down
  Scene scene = scene_of({receiver, square});
  Mesh mesh = build_mesh(scene, {});
  HemicubeOptions options;
  options.resolution = R;
  options.weights = weighting;
  HemicubeFormFactors ff(scene, mesh, options);
  std::vector<double> row(2);
  RowCost cost;
  ff.row(0, row, cost);
  std::vector<Vec3> scratch;
  *exact = point_to_polygon_form_factor(Vec3(0.0), Vec3(0, 0, 1), square, Vec3(0, 0, -1), scratch);
  return row[1];
}

TEST(Hemicube, DifferentialElementUnderSquareIsExactWhenPixelsAlign) {
  // The square (w = 1/2) projects onto s, t in [-1/2, 1/2] of the top face; with R a multiple of
  // 4 its edges fall on pixel boundaries, so the covered pixels tile it exactly and the exact
  // weights sum to its form factor up to rounding. Catalogue: 0.239456470 (9 digits).
  double exact = 0.0;
  for (int R : {4, 20, 160}) {
    const double f = hemicube_under_square(0.5, R, HemicubeWeighting::kExact, &exact);
    EXPECT_NEAR(f, exact, 1e-13) << R;
    EXPECT_NEAR(f, 0.239456470, 5e-10) << R;
  }
}

TEST(Hemicube, MidpointWeightsConvergeAtSecondOrderForAnAlignedReceiver) {
  // Aligned as above, the only error is the midpoint rule's on each covered pixel:
  //   sum (w_mid - w_exact) = -(h^2/24) * integral of the Laplacian of rho over the square
  //                         = -(h^2/24) * (closed integral of d rho/dn along its edges) + O(h^4)
  // with rho = 1/(pi (1+s^2+t^2)^2) and h = 2/R. On the edge s = w, d rho/dn =
  // -4w/(pi q^3), q = 1+w^2+t^2; the four edges are alike. Theory: second order, ratio 4 per
  // doubling, and the constant above; O(h^2) relative corrections make 1% ample at R >= 40.
  const double w = 0.5, a2 = 1.0 + w * w;
  // integral_{-w}^{w} dt / (a2 + t^2)^3 in closed form.
  const double a = std::sqrt(a2);
  auto F = [&](double t) {
    const double q = a2 + t * t;
    return t / (4 * a2 * q * q) + 3 * t / (8 * a2 * a2 * q) +
           3 * std::atan(t / a) / (8 * a2 * a2 * a);
  };
  const double loop = 4.0 * (-4.0 * w / std::numbers::pi) * (F(w) - F(-w));
  double previous = 0.0;
  for (int R : {40, 80, 160, 320}) {
    double exact = 0.0;
    const double error = hemicube_under_square(w, R, HemicubeWeighting::kMidpoint, &exact) - exact;
    const double h = 2.0 / R, predicted = -(h * h / 24.0) * loop;
    EXPECT_NEAR(error / predicted, 1.0, 0.01) << R;
    if (previous != 0.0) {
      EXPECT_NEAR(previous / error, 4.0, 0.04) << R;
    }
    previous = error;
  }
}

TEST(Hemicube, CoverageErrorIsFirstOrderWithThePredictedConstant) {
  // Now place the square's edges a quarter pixel inside a pixel column/row (its half-width w_R
  // depends on R): every pixel along an edge covers a strip 1/4 pixel wide but its centre lies
  // outside, so (exact weights) the hemicube misses a strip of width h/4 along all four edges:
  //   error = -(h/4) * (closed integral of rho along the edges) + O(h^2),   h = 2/R.
  // First order: the error halves when R doubles, with this constant (O(h) relative
  // corrections: 1% at R >= 48).
  double previous = 0.0;
  for (int R : {48, 96, 192, 384}) {
    const int m = int(std::floor(0.75 * R));
    const double w = 2.0 * (m + 0.25) / R - 1.0;
    double exact = 0.0;
    const double error = hemicube_under_square(w, R, HemicubeWeighting::kExact, &exact) - exact;
    const double a2 = 1.0 + w * w, a = std::sqrt(a2);
    // Closed integral of rho along the four edges: 4 * integral_{-w}^{w} dt / (pi (a2+t^2)^2).
    const double loop = 4.0 / std::numbers::pi * 2.0 *
                        (w / (2 * a2 * (a2 + w * w)) + std::atan(w / a) / (2 * a2 * a));
    const double predicted = -0.25 * (2.0 / R) * loop;
    EXPECT_NEAR(error / predicted, 1.0, 0.01) << R;
    if (previous != 0.0) {
      EXPECT_NEAR(previous / error, 2.0, 0.02) << R;
    }
    previous = error;
  }
}

TEST(Hemicube, SmallDistantElementsAreHitOrMissedByWholePixels) {
  // A receiver 0.4 pixel wide at the centre of the top face, swept over one pixel on a 10 x 10
  // grid of positions: the hemicube gives it either nothing or the whole weight of the pixel
  // whose centre it covers (real hemicube aliasing). It covers the centre at exactly 4 of the 10
  // offsets along each axis, so the hit fraction is 0.16 = (0.4)^2 = area / pixel area, and the
  // mean over the sweep matches the mean exact form factor to the variation of rho across one
  // pixel (relative ~h^2 = 2e-4 at R = 150; 1% allowed).
  const int R = 150;
  const double h = 2.0 / R, sigma = 0.4 * h;
  const std::vector<double> weights = hemicube_weights(R, HemicubeWeighting::kExact);
  const double pixel_weight = weights[size_t(R / 2) * size_t(R) + size_t(R / 2)];
  const double e = 1e-3;
  std::vector<Vec3> receiver = {{-e, -e, 0}, {e, -e, 0}, {e, e, 0}, {-e, e, 0}};
  int hits = 0;
  double mean_hemicube = 0.0, mean_exact = 0.0;
  for (int ky = 0; ky < 10; ++ky)
    for (int kx = 0; kx < 10; ++kx) {
      // Pixel (R/2, R/2) spans s, t in [0, h]; the receiver's centre moves over it.
      const double x = (kx + 0.5) * h / 10, y = (ky + 0.5) * h / 10, r = 0.5 * sigma;
      std::vector<Vec3> small = {
          {x - r, y - r, 1}, {x - r, y + r, 1}, {x + r, y + r, 1}, {x + r, y - r, 1}};
      Scene scene = scene_of({receiver, small});
      Mesh mesh = build_mesh(scene, {});
      HemicubeOptions options;
      options.weights = HemicubeWeighting::kExact;
      HemicubeFormFactors ff(scene, mesh, options);
      std::vector<double> row(2);
      RowCost cost;
      ff.row(0, row, cost);
      EXPECT_TRUE(row[1] == 0.0 || row[1] == pixel_weight) << row[1];
      hits += row[1] > 0 ? 1 : 0;
      mean_hemicube += row[1] / 100;
      std::vector<Vec3> scratch;
      mean_exact +=
          point_to_polygon_form_factor(Vec3(0.0), Vec3(0, 0, 1), small, Vec3(0, 0, -1), scratch) /
          100;
    }
  EXPECT_EQ(hits, 16);
  EXPECT_NEAR(mean_hemicube, mean_exact, 0.01 * mean_exact);
}

TEST(Hemicube, OccludersAndBackFaces) {
  // A receiver at height 2 hidden exactly behind a plate at height 1 of half its size (both
  // centred over the eye): the plate takes the receiver's whole solid angle. Turned round, the
  // plate still hides the receiver but adds nothing (a back face).
  const double e = 1e-3;
  std::vector<Vec3> eye = {{-e, -e, 0}, {e, -e, 0}, {e, e, 0}, {-e, e, 0}};
  std::vector<Vec3> far = {{-1, -1, 2}, {-1, 1, 2}, {1, 1, 2}, {1, -1, 2}};
  std::vector<Vec3> plate = {{-0.5, -0.5, 1}, {-0.5, 0.5, 1}, {0.5, 0.5, 1}, {0.5, -0.5, 1}};
  std::vector<Vec3> flipped(plate.rbegin(), plate.rend());
  HemicubeOptions options;
  options.weights = HemicubeWeighting::kExact;
  options.resolution = 160;  // edges at s = +-1/2 on pixel boundaries: no coverage error
  std::vector<Vec3> scratch;
  const double f_plate =
      point_to_polygon_form_factor(Vec3(0.0), Vec3(0, 0, 1), plate, Vec3(0, 0, -1), scratch);
  for (bool front : {true, false}) {
    Scene scene = scene_of({eye, far, front ? plate : flipped});
    Mesh mesh = build_mesh(scene, {});
    HemicubeFormFactors ff(scene, mesh, options);
    std::vector<double> row(3);
    RowCost cost;
    ff.row(0, row, cost);
    EXPECT_EQ(row[1], 0.0);
    EXPECT_NEAR(row[2], front ? f_plate : 0.0, 1e-13);
  }
}

// Closed scenes: a room, a floating block (closed, 6 faces) and a block standing on the floor
// (5 faces, open at the bottom where the floor hides it), meshed with T-junctions between
// polygons (element_size), optionally rotated.
std::vector<std::vector<Vec3>> box_faces(const Vec3& lo, const Vec3& hi, bool inward) {
  Vec3 c[8];
  for (int k = 0; k < 8; ++k)
    c[k] = Vec3(k & 1 ? hi.x : lo.x, k & 2 ? hi.y : lo.y, k & 4 ? hi.z : lo.z);
  std::vector<std::vector<Vec3>> faces = {{c[0], c[2], c[3], c[1]}, {c[4], c[5], c[7], c[6]},
                                          {c[0], c[1], c[5], c[4]}, {c[2], c[6], c[7], c[3]},
                                          {c[0], c[4], c[6], c[2]}, {c[1], c[3], c[7], c[5]}};
  if (inward)
    for (auto& f : faces) std::reverse(f.begin(), f.end());
  return faces;
}

Scene room_with_blocks(double angle) {
  std::vector<std::vector<Vec3>> polygons = box_faces(Vec3(0.0), Vec3(1.2, 1.0, 0.9), true);
  for (auto& f : box_faces(Vec3(0.3, 0.2, 0.25), Vec3(0.6, 0.5, 0.7), false)) polygons.push_back(f);
  auto standing = box_faces(Vec3(0.8, 0.0, 0.1), Vec3(1.0, 0.3, 0.3), false);
  for (size_t f = 0; f < standing.size(); ++f)
    if (f != 2) polygons.push_back(standing[f]);  // face 2 is its bottom (y = 0)
  const glm::dmat4 rotation = glm::rotate(glm::dmat4(1.0), angle, glm::normalize(Vec3(1, 2, 3)));
  for (auto& p : polygons)
    for (Vec3& v : p) v = Vec3(rotation * glm::dvec4(v, 1.0));
  Scene scene = scene_of(polygons);
  validate_scene(scene);
  return scene;
}

TEST(Hemicube, ClosedScenesRowsSumToExactlyOneWithExactWeights) {
  // With exact weights every pixel of a closed scene's hemicube holds a front face, so every row
  // sums to the sum of all the weights: 1 up to rounding (3 R^2 terms: 1e-12). With midpoint
  // weights it sums to the sum of the midpoint weights instead. This needs a watertight item
  // buffer: no pixel may fall between two elements, even where pixel centres lie exactly on
  // shared edges (the cube is symmetric, so they do) or on T-junctions.
  struct Case {
    Scene scene;
    MeshOptions mesh;
    int resolution;
    double angle;  // rotation of room_with_blocks; < 0 for other scenes
  };
  std::vector<Case> cases;
  Scene cube = make_builtin_scene("cube");
  validate_scene(cube);
  for (int k : {1, 3}) cases.push_back({cube, {k, 0.0}, 150, -1.0});
  cases.push_back({room_with_blocks(0.0), {0, 0.11}, 38, 0.0});
  cases.push_back({room_with_blocks(0.7), {0, 0.13}, 64, 0.7});
  cases.push_back({room_with_blocks(0.3), {2, 0.0}, 150, 0.3});
  for (const Case& c : cases) {
    Mesh mesh = build_mesh(c.scene, c.mesh);
    const glm::dmat4 back =
        glm::inverse(glm::rotate(glm::dmat4(1.0), c.angle, glm::normalize(Vec3(1, 2, 3))));
    for (HemicubeWeighting weighting : {HemicubeWeighting::kExact, HemicubeWeighting::kMidpoint}) {
      HemicubeOptions options;
      options.resolution = c.resolution;
      options.weights = weighting;
      HemicubeFormFactors ff(c.scene, mesh, options);
      const std::vector<double>& w = ff.weights();
      const double total = std::accumulate(w.begin(), w.end(), 0.0);
      BuildReport report;
      FormFactorMatrix m = build_matrix(ff, mesh.size(), Precision::kDouble, report);
      size_t checked = 0;
      for (size_t i = 0; i < mesh.size(); ++i) {
        // Floor elements (polygon 2, y = 0 before rotation) reaching under the standing block
        // (x in [0.8, 1], z in [0.1, 0.3]) may have their centre inside it and see only its back
        // faces: left out.
        if (c.angle >= 0 && mesh.polygon[i] == 2) {
          Vec3 lo(1e300), hi(-1e300);
          for (uint32_t v : mesh.element_vertices(i)) {
            const Vec3 p = Vec3(back * glm::dvec4(mesh.vertices[v], 1.0));
            lo = glm::min(lo, p);
            hi = glm::max(hi, p);
          }
          if (hi.x > 0.8 && lo.x < 1.0 && hi.z > 0.1 && lo.z < 0.3) continue;
        }
        double sum = 0.0;
        for (size_t j = 0; j < mesh.size(); ++j) sum += m.at(i, j);
        EXPECT_NEAR(sum, total, 1e-12) << "element " << i << " of " << mesh.size();
        ++checked;
      }
      EXPECT_GT(checked, mesh.size() / 2);
      if (weighting == HemicubeWeighting::kExact) {
        EXPECT_NEAR(total, 1.0, 1e-12);
      }
    }
  }
}

TEST(Hemicube, CubeClosure) {
  // One element a face: each row is a full hemicube of a closed scene, so 4 F_adj + F_opp equals
  // the sum of the weights (1 for exact weights, within 1e-12; 1 + O(1/R^2) for midpoint).
  Scene scene = make_builtin_scene("cube");
  validate_scene(scene);
  Mesh mesh = build_mesh(scene, {});
  for (HemicubeWeighting weighting : {HemicubeWeighting::kExact, HemicubeWeighting::kMidpoint}) {
    HemicubeOptions options;
    options.weights = weighting;
    HemicubeFormFactors ff(scene, mesh, options);
    const double total = std::accumulate(ff.weights().begin(), ff.weights().end(), 0.0);
    std::vector<double> row(mesh.size());
    RowCost cost;
    ff.row(0, row, cost);
    EXPECT_EQ(row[0], 0.0);
    EXPECT_NEAR(row[2] + row[3] + row[4] + row[5] + row[1], total, 1e-12);
    EXPECT_EQ(cost.rays, 0u);
  }
}

// The closed integral of the hemicube's weight density rho along the projection of a polygon's
// boundary, seen from x with the hemicube frame (u, v, n): rho = 1/(pi(1+s^2+t^2)^2) on the top
// face, t/(pi(1+s^2+t^2)^2) on the sides, arc length in face coordinates. Trapezoid rule on 4000
// points an edge (relative error ~1e-6 for these smooth curves); pieces below the horizon and
// the short steps across face boundaries are left out (the latter contribute O(1/4000)).
double boundary_weight(const Vec3& x, const Vec3& u, const Vec3& v, const Vec3& n,
                       std::span<const Vec3> polygon) {
  auto project = [&](const Vec3& p, int& face, double& s, double& t) {
    const Vec3 d = p - x;
    const double lx = glm::dot(d, u), ly = glm::dot(d, v), lz = glm::dot(d, n);
    if (lz < 0) {
      face = -1;
      return 0.0;
    }
    double q;
    if (lz >= std::abs(lx) && lz >= std::abs(ly)) {
      face = 0;
      s = lx / lz;
      t = ly / lz;
      q = 1 + s * s + t * t;
      return 1.0 / (std::numbers::pi * q * q);
    }
    const bool along_u = std::abs(lx) >= std::abs(ly);
    const double depth = along_u ? std::abs(lx) : std::abs(ly);
    face = along_u ? (lx > 0 ? 1 : 2) : (ly > 0 ? 3 : 4);
    s = (along_u ? ly : lx) / depth;
    t = lz / depth;
    q = 1 + s * s + t * t;
    return t / (std::numbers::pi * q * q);
  };
  const int N = 4000;
  double total = 0.0;
  for (size_t k = 0; k < polygon.size(); ++k) {
    const Vec3 a = polygon[k], b = polygon[(k + 1) % polygon.size()];
    int previous_face = -2;
    double ps = 0, pt = 0, prho = 0;
    for (int i = 0; i <= N; ++i) {
      int face;
      double s = 0, t = 0;
      const double rho = project(a + (b - a) * (double(i) / N), face, s, t);
      if (face >= 0 && face == previous_face)
        total += 0.5 * (rho + prho) * std::hypot(s - ps, t - pt);
      previous_face = face;
      ps = s, pt = t, prho = rho;
    }
  }
  return total;
}

TEST(Hemicube, CatalogueWithinTheCentroidRuleAndPixelBounds) {
  // One hemicube at each element centre estimates the point form factor there, so for a pair of
  // squares the hemicube computes the centroid (midpoint) rule over the emitter's K x K elements,
  // Q = sum_e (A_e/A) F_{c_e -> receiver}, with each point value approximated by pixels. Errors:
  //  1. |Q - catalogue|: the centroid rule's, computed here exactly with Lambert's formula;
  //  2. pixel coverage (exact weights): a pixel is misjudged only if the receiver's projected
  //     boundary passes within half a pixel diagonal (h/sqrt2, h = 2/R) of its centre, so the
  //     misjudged region lies in a band of that half-width around the boundary: its weight is
  //     at most sqrt2 h (closed integral of rho along the boundary) + (pi h^2/2) rho_max per
  //     piece (Steiner's formula; <= 5 pieces a face, rho_max = 1/pi: 2.5 h^2);
  //  3. midpoint weights: at most sum over all pixels of |w_mid - w_exact| more.
  // When every projected edge falls on pixel boundaries (d = 1, 2 with K = 4 and R = 160: the
  // edges lie at s = -(2k+1)/8d, (7-2k)/8d on the top face) term 2 vanishes: exact weights then
  // reproduce Q to rounding.
  const int K = 4;
  for (const CatalogueCase& c : catalogue()) {
    Scene scene = scene_of({c.emitter, c.receiver});
    Mesh mesh = build_mesh(scene, {K, 0.0});
    const bool aligned =
        c.name == std::string("parallel_d1") || c.name == std::string("parallel_d2");
    const int R = aligned ? 160 : 150;
    const double h = 2.0 / R;
    double Q = 0.0, band = 0.0, area = 0.0;
    std::vector<Vec3> corners, scratch;
    for (size_t e = 0; e < mesh.size(); ++e) {
      if (mesh.polygon[e] != 0) continue;
      mesh.corners(e, corners);
      const Vec3 n = mesh.normal[e];
      Vec3 u = corners[1] - corners[0];
      u = glm::normalize(u - glm::dot(u, n) * n);
      const Vec3 v = glm::cross(n, u);
      const Vec3 normal = geometry::unit_normal(c.receiver);
      Q += mesh.area[e] *
           point_to_polygon_form_factor(mesh.centroid[e], n, c.receiver, normal, scratch);
      band += mesh.area[e] *
              (std::sqrt(2.0) * h * boundary_weight(mesh.centroid[e], u, v, n, c.receiver) +
               2.5 * h * h);
      area += mesh.area[e];
    }
    Q /= area;
    band /= area;
    const double quadrature = std::abs(Q - c.value);
    for (HemicubeWeighting weighting : {HemicubeWeighting::kExact, HemicubeWeighting::kMidpoint}) {
      HemicubeOptions options;
      options.resolution = R;
      options.weights = weighting;
      HemicubeFormFactors ff(scene, mesh, options);
      double weight_error = 0.0;
      if (weighting == HemicubeWeighting::kMidpoint) {
        const std::vector<double> exact = hemicube_weights(R, HemicubeWeighting::kExact);
        for (size_t p = 0; p < exact.size(); ++p)
          weight_error += std::abs(ff.weights()[p] - exact[p]);
      }
      RowCost cost;
      const double f = polygon_pair(ff, mesh, cost);
      const double pixels = aligned ? 1e-13 : band;
      EXPECT_NEAR(f, Q, pixels + weight_error) << c.name;
      EXPECT_NEAR(f, c.value, quadrature + pixels + weight_error) << c.name;
      if (aligned && weighting == HemicubeWeighting::kExact) {
        EXPECT_NEAR(f, Q, 1e-13) << c.name;
      }
    }
  }
}

TEST(Hemicube, SymmetrisingRestoresReciprocity) {
  // A hemicube matrix is far from reciprocal (each row samples one point of its element);
  // symmetrise() makes A_i F_ij = A_j F_ji to rounding, each entry becoming
  // A_j (A_j F_ij + A_i F_ji) / (A_i^2 + A_j^2) (matrix.h).
  Scene scene = make_builtin_scene("cornell");
  validate_scene(scene);
  Mesh mesh = build_mesh(scene, {2, 0.0});
  HemicubeFormFactors ff(scene, mesh, {});
  BuildReport report;
  FormFactorMatrix m = build_matrix(ff, mesh.size(), Precision::kDouble, report);
  MatrixDiagnostics before = diagnose(m, mesh.area);
  EXPECT_GT(before.reciprocity_defect_relative, 1e-3);
  const size_t n = mesh.size();
  std::vector<double> expected(n, 0.0);
  for (size_t i = 0; i < n; ++i)
    for (size_t j = 0; j < n; ++j)
      expected[i] += mesh.area[j] * (mesh.area[j] * m.at(i, j) + mesh.area[i] * m.at(j, i)) /
                     (mesh.area[i] * mesh.area[i] + mesh.area[j] * mesh.area[j]);
  symmetrise(m, mesh.area);
  MatrixDiagnostics after = diagnose(m, mesh.area);
  EXPECT_LT(after.reciprocity_defect_relative, 1e-15);
  for (size_t i = 0; i < n; ++i) {
    double sum = 0.0;
    for (size_t j = 0; j < n; ++j) sum += m.at(i, j);
    EXPECT_NEAR(sum, expected[i], 1e-14);
  }
  EXPECT_EQ(after.negative_entries, 0u);
}

TEST(Symmetrise, TrustsTheSmallerElementsRow) {
  // A large element (A = 100) whose hemicube hits a tiny one (A = 1) with a whole pixel reports
  // F_01 = 0.05, 100 times the truth; the tiny element's row has the accurate F_10 = 0.05
  // (truth: A_0 F_01 = A_1 F_10 = 0.05). The inverse-variance rule recovers G within 1%; a plain
  // average would make F_10 = 2.525, a row sum far above 1.
  FormFactorMatrix m(2, Precision::kDouble);
  m.set(0, 1, 0.05);
  m.set(1, 0, 0.05);
  const std::vector<double> area = {100.0, 1.0};
  symmetrise(m, area);
  EXPECT_DOUBLE_EQ(area[0] * m.at(0, 1), area[1] * m.at(1, 0));
  EXPECT_NEAR(m.at(1, 0), 0.05, 0.05 * 0.01 + 1e-3);
  EXPECT_LE(m.at(1, 0), 0.1);
  // Equal areas: the plain average.
  FormFactorMatrix e(2, Precision::kDouble);
  e.set(0, 1, 0.2);
  e.set(1, 0, 0.3);
  symmetrise(e, std::vector<double>{2.0, 2.0});
  EXPECT_DOUBLE_EQ(e.at(0, 1), 0.25);
  EXPECT_DOUBLE_EQ(e.at(1, 0), 0.25);
}

TEST(Hemicube, RejectsBadOptions) {
  Scene scene = make_builtin_scene("cube");
  validate_scene(scene);
  Mesh mesh = build_mesh(scene, {});
  for (const char* bad : {"resolution=151", "resolution=0", "weights=bilinear", "rays=4"}) {
    ParamBag bag = ParamBag::from_list(bad, "hemicube");
    EXPECT_THROW(make_form_factor_method("hemicube", bag, scene, mesh), UsageError) << bad;
  }
  ParamBag good = ParamBag::from_list("resolution=64,weights=exact", "hemicube");
  auto method = make_form_factor_method("hemicube", good, scene, mesh);
  EXPECT_EQ(method->parameters(), "resolution=64,weights=exact");
}

}  // namespace
}  // namespace radlab
