// Ray origins and directions for the Monte Carlo solvers: a uniform point on a mesh element and
// a cosine-distributed direction about its normal, from five numbers in [0,1) each, and the
// streams of such numbers — pseudo-random (PCG32) or Sobol' points (Boost.Random's
// boost::random::sobol) shifted at random per dimension (Cranley & Patterson 1976), so that each
// point is uniform on the unit cube and the estimates stay unbiased for every seed.
#pragma once

#include <cstdint>
#include <memory>
#include <span>

#include "scene/mesh.h"

namespace radlab::monte_carlo {

// The five numbers a ray takes: u[0] picks the element, u[1], u[2] the point on it, u[3], u[4]
// the direction.
inline constexpr int kDimensions = 5;

// A uniform point on element e (a fan of triangles from its first corner, the triangle chosen in
// proportion to its area; u1 is reused after the choice, rescaled to [0,1)).
Vec3 point_on_element(const Mesh& mesh, size_t element, double u1, double u2);

// A direction about unit normal n with density cos(theta)/pi (Malley's method: a uniform point
// on the unit disc, projected up onto the hemisphere).
Vec3 cosine_direction(const Vec3& n, double u1, double u2);

// Fills count x kDimensions numbers in [0,1), ray after ray. Pseudo: an independent PCG32 stream
// per (seed, block), so a block's numbers do not depend on what came before. Sobol: the next
// `count` points of one sequence (continuing across calls), shifted by the seed's random shift.
class UniformStream {
 public:
  virtual ~UniformStream() = default;
  virtual void fill(uint64_t block, std::span<double> out) = 0;
};

std::unique_ptr<UniformStream> make_pseudo_stream(uint64_t seed);
std::unique_ptr<UniformStream> make_sobol_stream(uint64_t seed);

}  // namespace radlab::monte_carlo
