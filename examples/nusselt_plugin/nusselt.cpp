// nusselt-mc — Nusselt's analogue sampled by Monte Carlo at each element's centre (Malley's
// method), written as an out-of-tree form-factor method plugin.
//
// Method: Nusselt's analogue says the form factor from a point x (normal n) to a surface is the
//   fraction of the unit disk under x covered by the surface's projection onto the hemisphere
//   and then onto the disk. Row i takes x = element i's centroid and shoots N = strata^2 rays
//   through jittered points of that disk, stratified on a strata x strata grid of (u1, u2) in
//   [0,1)^2, each lifted to the hemisphere (r = sqrt(u1), phi = 2 pi u2, cos theta =
//   sqrt(1 - u1): directions with density cos theta / pi, Malley 1988). Embree finds each ray's
//   first element; F_ij = k_j / N with k_j the rays that reach the front of element j. Occlusion
//   is the ray's own: a ray blocked by k reaches k, never j. Rays meeting a back face or nothing
//   are lost (they add to no entry).
// Paper: T. J. V. Malley, "A Shading Method for Computer Generated Images", MSc thesis,
//   University of Utah, 1988; Nusselt 1928 (the analogue); Cohen & Wallace 1993, §4.9.
// Parameters: strata (rays per row = strata^2), seed (of the jitter; row i draws from the
//   stream (seed, i), so rows are the same bits on any thread count and alone or in a build).
// Cost per row: strata^2 Embree rays.
// Stated errors (radlab's FormFactorMethod):
//   row sums: sum_j F_ij = sum_j k_j / N, with sum_j k_j <= N (each ray is counted at most
//     once), so a row sums to at most 1 up to the rounding of n quotients (each within 2^-53 of
//     k_j / N) and their sum in double (n - 1 additions, each within 2^-53 of a partial sum
//     <= 1): 1 + (2n - 1) 2^-53, plus float storage (1e-7). In a closed scene whose faces all
//     face inward every ray meets a front face and the row sums to 1 within that error.
//   reciprocity: none stated. Row i is one point's view with sampling noise: A_i F_ij and
//     A_j F_ji differ by the point rule's error (O((size / distance)^2) for near pairs) and by
//     the noise (sqrt(F (1 - F) / N) per entry, less with stratification).
// Rows at a point: row_at_point(x, e) is the same rule at any point x in element e's plane and
//   frame; at e's centroid it is row(e) (two levels' patch rows "centre" work with it).
// Left out: importance of nearby pairs (near pairs get few rays for their share of F, so their
//   entries are noisy); the quadrature over element i (use radlab's raycast for that).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <glm/geometric.hpp>
#include <memory>
#include <numbers>
#include <vector>

#include "core/error.h"
#include "core/random.h"
#include "formfactor/visibility/embree_scene.h"
#include "solvers/plugin.h"

namespace {

using radlab::FormFactorMethod;
using radlab::Mesh;
using radlab::ParamBag;
using radlab::RowCost;
using radlab::Scene;
using radlab::Vec3;

struct NusseltOptions {
  int strata = 32;
  uint64_t seed = 0;

  // The registry reads the defaults from here (an empty bag): they are not typed anywhere else.
  static NusseltOptions from(ParamBag& bag) {
    NusseltOptions o;
    o.strata = int(bag.get_int("strata", o.strata, 1, 1024));
    o.seed = uint64_t(bag.get_int("seed", static_cast<long long>(o.seed), 0, radlab::kInt64Max));
    return o;
  }
  std::string canonical() const {
    return "seed=" + std::to_string(seed) + ",strata=" + std::to_string(strata);
  }
};

class NusseltFormFactors final : public FormFactorMethod {
 public:
  NusseltFormFactors(const Scene& /*scene*/, const Mesh& mesh, NusseltOptions options)
      : mesh_(mesh), options_(options), embree_(mesh) {
    // The rays start on the element's plane; t_near skips the rounding of Embree's single
    // precision there (1e-6 of the scene's size).
    Vec3 low(1e300), high(-1e300);
    for (const Vec3& p : mesh.vertices) low = glm::min(low, p), high = glm::max(high, p);
    t_near_ = 1e-6 * glm::length(high - low);
  }
  std::string name() const override { return "nusselt-mc"; }
  std::string parameters() const override { return options_.canonical(); }
  std::vector<std::string> left_out() const override {
    return {"no quadrature over the source element: one point's view per row"};
  }
  void row(size_t i, std::span<double> out, RowCost& cost) const override {
    shoot(mesh_.centroid[i], i, out, cost);
  }
  bool row_at_point(const Vec3& eye, size_t element, std::span<double> out,
                    RowCost& cost) const override {
    shoot(eye, element, out, cost);
    return true;
  }
  double stated_row_sum_error(std::string* basis) const override {
    const double rounding = double(2 * mesh_.size()) * 0x1p-53;
    if (basis)
      *basis = "nusselt-mc: rays counted once each, so a row is at most 1 + the rounding of its " +
               std::to_string(mesh_.size()) + " quotients and their sum + float storage 1e-7";
    return rounding + radlab::kFloatStorageRowError;
  }

 private:
  // Strata^2 cosine-distributed rays from `eye` above element e's plane, in e's frame (its
  // first edge as the first axis), counted per element reached from the front.
  void shoot(const Vec3& eye, size_t e, std::span<double> out, RowCost& cost) const {
    const Vec3 n = mesh_.normal[e];
    const auto corners = mesh_.element_vertices(e);
    const Vec3 u = glm::normalize(mesh_.vertices[corners[1]] - mesh_.vertices[corners[0]]);
    const Vec3 v = glm::cross(n, u);
    thread_local std::vector<uint32_t> hits;
    hits.assign(mesh_.size(), 0);
    radlab::Pcg32 rng(radlab::hash_combine(options_.seed, e));
    const int m = options_.strata;
    for (int a = 0; a < m; ++a)
      for (int b = 0; b < m; ++b) {
        const double u1 = (a + rng.next_double()) / m, u2 = (b + rng.next_double()) / m;
        const double r = std::sqrt(u1), phi = 2.0 * std::numbers::pi * u2;
        const Vec3 d = r * std::cos(phi) * u + r * std::sin(phi) * v + std::sqrt(1.0 - u1) * n;
        const radlab::RayHit hit = embree_.intersect(eye, d, t_near_, 1e30);
        if (hit.hit && hit.element != e && glm::dot(d, mesh_.normal[hit.element]) < 0.0)
          ++hits[hit.element];
      }
    const double rays = double(m) * double(m);
    for (size_t j = 0; j < out.size(); ++j) out[j] = double(hits[j]) / rays;
    cost.rays += uint64_t(rays);
  }

  const Mesh& mesh_;
  NusseltOptions options_;
  radlab::EmbreeScene embree_;
  double t_near_ = 0.0;
};

radlab::FormFactorMethodInfo nusselt_info() {
  return {"nusselt-mc",
          "plugin example: Nusselt's analogue by Monte Carlo at each element's centre (Malley's "
          "cosine-distributed Embree rays)",
          {{"strata", "", "rays per row = strata^2, jittered on a strata x strata grid"},
           {"seed", "", "seed of the jitter (row i draws from the stream (seed, i))"}},
          radlab::configure_from_options<NusseltFormFactors, NusseltOptions>(),
          /*rows_at_points=*/true};
}

void register_nusselt() {
  radlab::register_form_factor_method(nusselt_info());
}

}  // namespace

RADLAB_PLUGIN(register_nusselt)
