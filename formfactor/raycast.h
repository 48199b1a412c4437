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
// Left out, and counted: pairs facing away or coplanar (no work, pairs_culled); visibility rays
// everywhere when the scene is a convex enclosure, and for every pair whose shaft holds no
// polygon that could block it (shaft.h; pairs_unoccluded).
//
// Parameters: tolerance (relative quadrature error per pair, 1e-4), rays (per occludable pair,
// 16), seed (0), max_order (largest fixed Gauss rule before going adaptive, 8), shafts (shaft
// culling on or off, true; off only to measure what it saves).
#pragma once

#include <memory>

#include "formfactor/form_factor_method.h"
#include "formfactor/polygon_integral.h"
#include "formfactor/visibility.h"

namespace radlab {

struct RaycastOptions {
  double tolerance = 1e-4;  // relative quadrature error per pair; smaller costs more points
  int rays = 16;            // visibility rays per occludable pair; the noise in V falls as 1/sqrt
  uint64_t seed = 0;        // jitter of the visibility sample points
  int max_order = 8;        // largest fixed Gauss rule per axis before adaptive subdivision
  bool shafts = true;       // shaft culling: no rays for pairs nothing can block (same result,
                            // fewer rays; false only to measure the saving)

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
  bool casts_rays() const { return visibility_.casts_rays(); }

 private:
  double unoccluded(size_t i, size_t j, RowCost& cost) const;

  const Mesh& mesh_;
  RaycastOptions options_;
  FixedOrderRule order_rule_;
  double plane_epsilon_ = 0.0;
  std::vector<double> radius_;  // largest centroid-to-corner distance per element
  Visibility visibility_;
};

// False when j lies wholly behind or in i's plane, or i wholly behind or in j's (up to
// `epsilon` metres): such a pair exchanges no light and costs nothing.
bool pair_faces(const Mesh& mesh, size_t i, size_t j, double epsilon);

}  // namespace radlab
