// `raycast` form factors (DESIGN §3), the default method.
//
//   F_ij = F^u_ij * V_ij
//
// F^u_ij, the unoccluded form factor, integrates Lambert's exact point-to-polygon formula over
// element i: a Gauss rule whose order follows from the pair's separation (Bernstein bound,
// polygon_integral.h), or adaptive subdivision for near and touching pairs. V_ij, the visibility
// fraction, is the share of `rays` Embree occlusion rays between stratified, jittered points on
// i and on j that arrive unblocked. The points depend only on (seed, min(i,j), max(i,j)), so
// V_ij = V_ji and reciprocity is kept up to the quadrature of F^u.
//
// Left out, and counted: pairs facing away or coplanar (no work); visibility rays everywhere
// when the scene is a convex enclosure.
//
// Parameters: tolerance (relative quadrature error per pair, 1e-4), rays (per occludable pair,
// 16), seed (0), max_order (largest fixed Gauss rule before going adaptive, 8).
#pragma once

#include <memory>

#include "formfactor/embree_scene.h"
#include "formfactor/form_factor_method.h"
#include "formfactor/polygon_integral.h"

namespace radlab {

struct RaycastOptions {
  double tolerance = 1e-4;  // relative quadrature error per pair; smaller costs more points
  int rays = 16;            // visibility rays per occludable pair; the noise in V falls as 1/sqrt
  uint64_t seed = 0;        // jitter of the visibility sample points
  int max_order = 8;        // largest fixed Gauss rule per axis before adaptive subdivision

  static RaycastOptions from(ParamBag& bag);
  void validate() const;
  std::string canonical() const;
};

class RaycastFormFactors final : public FormFactorMethod {
 public:
  RaycastFormFactors(const Scene& scene, const Mesh& mesh, RaycastOptions options);
  std::string name() const override { return "raycast"; }
  std::string parameters() const override { return options_.canonical(); }
  std::vector<std::string> left_out() const override;
  void row(size_t i, std::span<double> out, RowCost& cost) const override;

  // One pair, for tests and the catalogue comparisons.
  double pair(size_t i, size_t j, RowCost& cost) const;
  bool casts_rays() const { return !convex_enclosure_; }

 private:
  double unoccluded(size_t i, size_t j, RowCost& cost) const;
  double visibility(size_t i, size_t j, RowCost& cost) const;

  const Mesh& mesh_;
  RaycastOptions options_;
  FixedOrderRule order_rule_;
  bool convex_enclosure_ = false;
  double plane_epsilon_ = 0.0;
  std::vector<double> radius_;  // largest centroid-to-corner distance per element
  std::unique_ptr<EmbreeScene> embree_;
};

}  // namespace radlab
