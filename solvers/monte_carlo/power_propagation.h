// One Monte Carlo propagation of power through the scene (Neumann et al. 1994; Bekaert 1999,
// ch. 4): the matrix-free estimate of R x = diag(rho) F x on which stochastic Jacobi rests.
//
// Given per-element values x (one or three channels, any sign), element i holds power
// P_i = A_i x_i. N rays are cast: each picks a source element with probability
// p_i = |P_i| / sum_k |P_k| (|P| summed over channels), a uniform point on it and a
// cosine-distributed direction, and carries P_i / (N p_i) in every channel. The closest hit j
// (Embree), when it is the front face of an element, receives rho_j P_i / (N p_i A_j) into y_j.
// A ray from i lands on j with probability F_ij, so E[y_j] = rho_j sum_i P_i F_ij / A_j
// = rho_j sum_i F_ji x_i (reciprocity, A_i F_ij = A_j F_ji): E[y] = R x, exactly, for any x.
// Rays that escape (open scenes), hit a back face or nothing deposit nothing, as F is zero
// there.
//
// Determinism: the rays are traced in parallel (TBB) in blocks of 2,048. Every ray's numbers come
// from the stream in ray order; within a block the rays are then reordered by their first number
// (the one that picks the source, so rays from one element run together: cheaper memory access,
// bench_monte_carlo) and cast in batches, and the deposits are summed serially in that order.
// The order depends on the numbers alone, so the result is the same bits on any number of
// threads (tests/solvers/monte_carlo/power_propagation_test.cpp).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "core/radiosity.h"
#include "scene/mesh.h"
#include "solvers/monte_carlo/element_rays.h"
#include "solvers/monte_carlo/ray_sampler.h"

namespace radlab::monte_carlo {

class PowerPropagation {
 public:
  // `mesh` must outlive this object (the reflectance is read here); `rays` casts the rays
  // (element_rays.h).
  PowerPropagation(const Mesh& mesh, const Radiosity& reflectance, const ElementRays& rays);

  // y = an estimate of R x with `rays` rays, numbers from `stream` (blocks numbered from
  // `*block`, which advances). Returns the rays cast (0 when x carries no power). One call at a
  // time per object (it reuses its buffers).
  uint64_t propagate(const Radiosity& x, uint64_t rays, UniformStream& stream, uint64_t* block,
                     Radiosity& y) const;

  // For each element j, the fraction of `rays_per_element` cosine-distributed rays from it
  // that land on the front face of an element: an unbiased estimate of sum_i F_ji (1 in a
  // closed scene, where every ray lands). Returns the rays cast.
  uint64_t landing_fraction(uint64_t rays_per_element, UniformStream& stream, uint64_t* block,
                            std::vector<double>& out) const;

 private:
  const Mesh& mesh_;
  const ElementRays& rays_;
  size_t channels_;
  std::vector<double> gain_;  // rho_jc / A_j, element-major (channels of j together)
  // The buffers of propagate(), kept from call to call: allocated afresh each step, their pages
  // were faulted in and cleared by the kernel every time (3% of bench_monte_carlo's time). So
  // propagate() must not run on one object from two threads at once (the solvers call it from
  // one).
  struct Scratch {
    std::vector<double> weight, carried, received, u;
    std::vector<uint32_t> order, scratch, key, sorted_source, hit;
  };
  mutable Scratch scratch_;
};

}  // namespace radlab::monte_carlo
