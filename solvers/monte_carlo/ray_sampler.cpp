// Ray sampling for the Monte Carlo solvers (ray_sampler.h).
#include "solvers/monte_carlo/ray_sampler.h"

#include <algorithm>
#include <array>
#include <boost/random/sobol.hpp>
#include <cmath>
#include <glm/geometric.hpp>

#include "core/random.h"

namespace radlab::monte_carlo {

namespace {

// The largest double below 1: where rounding would otherwise give exactly 1.
constexpr double kBelowOne = 0x1.fffffffffffffp-1;

double triangle_area(const Vec3& a, const Vec3& b, const Vec3& c) {
  return 0.5 * glm::length(glm::cross(b - a, c - a));
}

class PseudoStream final : public UniformStream {
 public:
  explicit PseudoStream(uint64_t seed) : seed_(seed) {}
  void fill(uint64_t block, std::span<double> out) override {
    // One stream per block, derived from the seed and the block's index (core/random.h).
    Pcg32 rng(hash_combine(seed_, block), hash_combine(seed_ ^ 0x5bd1e995u, block));
    for (double& u : out) u = rng.next_double();
  }

 private:
  uint64_t seed_;
};

class SobolStream final : public UniformStream {
 public:
  explicit SobolStream(uint64_t seed) : engine_(kDimensions) {
    // The random shift: one uniform number per dimension, from the seed. Seed 0 is shifted too,
    // so no seed gives the unshifted sequence (whose first point is the origin, a corner).
    Pcg32 rng(hash_combine(seed, 0x50b01u));
    for (double& s : shift_) s = rng.next_double();
  }
  void fill(uint64_t /*block*/, std::span<double> out) override {
    // The engine yields the coordinates of one point after the other, dimension by dimension.
    for (size_t k = 0; k < out.size(); ++k) {
      const double u = double(engine_() >> 11) * 0x1p-53;
      double v = u + shift_[k % kDimensions];
      if (v >= 1.0) v -= 1.0;
      out[k] = std::min(v, kBelowOne);
    }
  }

 private:
  boost::random::sobol engine_;
  std::array<double, kDimensions> shift_{};
};

}  // namespace

Vec3 point_on_element(const Mesh& mesh, size_t element, double u1, double u2) {
  const std::span<const uint32_t> v = mesh.element_vertices(element);
  const Vec3& a = mesh.vertices[v[0]];
  // The fan's triangles (a, v[k], v[k+1]); quads have two, triangles one. Each area is computed
  // once (this runs for every ray: the Monte Carlo solvers' hottest code beside Embree).
  constexpr size_t kCached = 8;
  double areas[kCached];
  const size_t triangles = v.size() - 2;
  double total = 0.0;
  for (size_t k = 1; k + 1 < v.size(); ++k) {
    const double area = triangle_area(a, mesh.vertices[v[k]], mesh.vertices[v[k + 1]]);
    if (k - 1 < kCached) areas[k - 1] = area;
    total += area;
  }
  const auto area_of = [&](size_t t) {
    return t < kCached ? areas[t]
                       : triangle_area(a, mesh.vertices[v[t + 1]], mesh.vertices[v[t + 2]]);
  };
  const double target = u1 * total;
  double before = 0.0;
  size_t t = 0;
  for (; t + 1 < triangles; ++t) {
    const double area = area_of(t);
    if (target < before + area) break;
    before += area;
  }
  const Vec3& b = mesh.vertices[v[t + 1]];
  const Vec3& c = mesh.vertices[v[t + 2]];
  const double area = area_of(t);
  // u1 rescaled to [0,1) within the chosen triangle.
  const double s = area > 0.0 ? std::clamp((target - before) / area, 0.0, kBelowOne) : 0.0;
  // Uniform on the triangle: sqrt warps the first coordinate so area is preserved.
  const double r = std::sqrt(s);
  return a * (1.0 - r) + b * (r * (1.0 - u2)) + c * (r * u2);
}

Vec3 cosine_direction(const Vec3& n, double u1, double u2) {
  const Frame f = frame_about(n);
  const Vec3 d = cosine_direction_local(u1, u2);
  return f.t * d.x + f.b * d.y + n * d.z;
}

std::unique_ptr<UniformStream> make_pseudo_stream(uint64_t seed) {
  return std::make_unique<PseudoStream>(seed);
}

std::unique_ptr<UniformStream> make_sobol_stream(uint64_t seed) {
  return std::make_unique<SobolStream>(seed);
}

}  // namespace radlab::monte_carlo
