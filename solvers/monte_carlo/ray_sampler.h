// Ray origins and directions for the Monte Carlo solvers: a uniform point on a mesh element and
// a cosine-distributed direction about its normal, from five numbers in [0,1) each, and the
// streams of such numbers — pseudo-random (PCG32) or Sobol' points (Boost.Random's
// boost::random::sobol) shifted at random per dimension (Cranley & Patterson 1976), so that each
// point is uniform on the unit cube and the estimates stay unbiased for every seed.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <numbers>
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
// on the unit disc, by the concentric map, projected up onto the hemisphere).
Vec3 cosine_direction(const Vec3& n, double u1, double u2);

// The parts of cosine_direction, inline for the per-ray code of element_rays.cpp, which keeps
// each element's frame.

// An orthonormal frame (t, b, n) about unit normal n (Duff et al. 2017, branchless).
struct Frame {
  Vec3 t, b;
};
inline Frame frame_about(const Vec3& n) {
  const double sign = std::copysign(1.0, n.z);
  const double p = -1.0 / (sign + n.z);
  const double q = n.x * n.y * p;
  return {Vec3(1.0 + sign * n.x * n.x * p, sign * q, -sign * n.x),
          Vec3(q, sign + n.y * n.y * p, -n.y)};
}

// sin and cos of theta in [-pi/4, pi/4] by their Taylor series to the 13th and 14th powers
// (Estrin's scheme: short dependency chains). The first terms left out are below
// (pi/4)^15/15! = 2e-14, far under the float rounding of the directions Embree is given.
inline void sin_cos_quarter(double theta, double& sine, double& cosine) {
  const double t2 = theta * theta, t4 = t2 * t2, t8 = t4 * t4;
  // sin = theta (1 + t2 (s0 + s1 t2 + ... + s5 t2^5)), s_k = (-1)^(k+1) / (2k+3)!
  const double s01 = -1.0 / 6.0 + t2 * (1.0 / 120.0);
  const double s23 = -1.0 / 5040.0 + t2 * (1.0 / 362880.0);
  const double s45 = -1.0 / 39916800.0 + t2 * (1.0 / 6227020800.0);
  sine = theta + theta * t2 * (s01 + t4 * s23 + t8 * s45);
  // cos = 1 + t2 (c0 + c1 t2 + ... + c6 t2^6), c_k = (-1)^(k+1) / (2k+2)!
  const double c01 = -0.5 + t2 * (1.0 / 24.0);
  const double c23 = -1.0 / 720.0 + t2 * (1.0 / 40320.0);
  const double c45 = -1.0 / 3628800.0 + t2 * (1.0 / 479001600.0);
  const double c6 = -1.0 / 87178291200.0;
  cosine = 1.0 + t2 * (c01 + t4 * c23 + t8 * (c45 + t4 * c6));
}

// A cosine-distributed direction about +z. The disc point comes from Shirley & Chiu's
// concentric map (1997): the square [-1,1]^2 onto the unit disc, area-preserving, so the point is
// uniform (as with sqrt(u1), 2 pi u2) and Sobol' points stay well spread. Its angle lies within
// pi/4 of an axis, where sin and cos are the short polynomials above: no libm sincos, which was a
// tenth of a step's time beside Embree (bench_monte_carlo). No branch either: which of |x| and
// |y| is the larger is a coin toss from ray to ray, and a mispredicted branch cost more than the
// polynomials. m is 1 or 0, so m a + (1 - m) b is a or b exactly (both finite).
inline Vec3 cosine_direction_local(double u1, double u2) {
  const double x = 2.0 * u1 - 1.0, y = 2.0 * u2 - 1.0;
  const double m = std::abs(x) > std::abs(y) ? 1.0 : 0.0;
  const double r = m * x + (1.0 - m) * y;  // the larger in size (0 only at the centre)
  const double other = m * y + (1.0 - m) * x;
  // theta = pi/4 other/r, 0 at the centre, without a division by zero (nor a branch).
  const double safe_r = r != 0.0 ? r : 1.0;
  const double theta = r != 0.0 ? (std::numbers::pi / 4.0) * (other / safe_r) : 0.0;
  double sine = 0.0, cosine = 1.0;
  sin_cos_quarter(theta, sine, cosine);
  // At angle theta from the x axis when |x| is the larger, else pi/2 - theta (sin, cos swap).
  return {r * (m * cosine + (1.0 - m) * sine), r * (m * sine + (1.0 - m) * cosine),
          std::sqrt(std::max(0.0, 1.0 - r * r))};
}

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
