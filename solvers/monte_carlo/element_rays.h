// The one visibility path of the Monte Carlo solvers (stochastic-jacobi's power propagation and
// random-walk's walks): a ray from a uniform point on a mesh element in a cosine-distributed
// direction (ray_sampler.h), its closest hit found by Embree on the run's mesh. A ray from
// element i lands on the front face of element j with probability F_ij, the element-to-element
// form factor of the discretised system, so every estimator built on it estimates that system.
//
// Also the discrete distribution over elements by power that both solvers draw sources from.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "formfactor/visibility/embree_scene.h"
#include "scene/mesh.h"

namespace radlab::monte_carlo {

class ElementRays {
 public:
  static constexpr uint32_t kMiss = 0xFFFFFFFFu;

  // `mesh` must outlive this object.
  explicit ElementRays(const Mesh& mesh);

  // The element whose front face the ray from a point on `source` meets first, or kMiss (an
  // escape, or a back face: F_ij is zero where j faces away). u[1], u[2] place the origin,
  // u[3], u[4] the direction (ray_sampler.h's kDimensions numbers; u[0] is the caller's).
  uint32_t trace(size_t source, const double* u) const;

 private:
  const Mesh& mesh_;
  std::unique_ptr<EmbreeScene> embree_;
  double t_near_ = 0.0;
};

// Elements chosen with probability weight_i / sum_k weight_k (weights >= 0), by binary search in
// the cumulative weights: elements of weight zero have empty intervals and are never chosen.
class ElementDistribution {
 public:
  explicit ElementDistribution(std::span<const double> weights);
  double total() const { return cumulative_.empty() ? 0.0 : cumulative_.back(); }
  // The element for u in [0,1).
  size_t pick(double u) const;

 private:
  std::vector<double> cumulative_;
};

}  // namespace radlab::monte_carlo
