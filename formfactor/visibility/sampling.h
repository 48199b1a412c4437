// Stratified, jittered sample points on an element, uniform in area. Used for visibility rays.
#pragma once

#include <glm/geometric.hpp>
#include <span>
#include <vector>

#include "core/random.h"
#include "scene/scene.h"

namespace radlab {

// The map from an m x m grid of strata on the unit square onto an element: bilinear on a quad
// (not area-uniform on a non-parallelogram: a point's density is then 1/area_weight, which an
// estimate of V must weigh it by — a trapezoid left by clipping a triangle made V 20% too high
// on RenderPark's cube), area-uniform on a triangle, and on an n-gon s picks a fan triangle by area
// and is rescaled within it. Points stay off the boundary by a relative `inset` so rays do not
// start on a neighbour's shared edge. Keeps a view of `corners`, which must outlive it.
class StratifiedSampler {
 public:
  StratifiedSampler(std::span<const Vec3> corners, int strata_per_side, double inset = 1e-4);

  // The point of stratum (column, row), jittered within it by 32 random bits (16 per axis, each
  // at the centre of its 1/65536 of the stratum: far finer than matters to V).
  // `count` points at once, in float (the precision of the rays they start or end): stratum
  // strata[k] (row-major, column = strata[k] mod m) jittered by bits[k], written to x, y, z. The
  // quad and triangle cases vectorise.
  void points(const uint32_t* strata, const uint32_t* bits, int count, float* x, float* y,
              float* z) const;

  // The area the map gives the point of stratum (column, row) with these bits, relative to the
  // mean: 1 except on a non-parallelogram quad, where it is the bilinear map's Jacobian over
  // the element's area (points are denser where it is small).
  bool uniform() const { return corners_.size() != 4 || twist_ == Vec3(0.0); }
  double area_weight(uint32_t stratum, uint32_t bits) const {
    if (uniform()) return 1.0;
    const double s = inset_ + scale_ * (stratum % side_ + (double(bits & 0xFFFFu) + 0.5) * 0x1p-16);
    const double t = inset_ + scale_ * (stratum / side_ + (double(bits >> 16) + 0.5) * 0x1p-16);
    return glm::length(glm::cross(e1_ + t * twist_, e3_ + s * twist_)) / jacobian_mean_;
  }

  Vec3 point(int column, int row, uint32_t bits) const {
    const double s = inset_ + scale_ * (column + (double(bits & 0xFFFFu) + 0.5) * 0x1p-16);
    const double t = inset_ + scale_ * (row + (double(bits >> 16) + 0.5) * 0x1p-16);
    if (corners_.size() == 4) return corners_[0] + s * e1_ + t * (e3_ + s * twist_);
    return on_triangles(s, t);
  }

 private:
  Vec3 on_triangles(double s, double t) const;

  std::span<const Vec3> corners_;
  uint32_t side_;
  double inset_, scale_;
  Vec3 e1_{0.0}, e3_{0.0}, twist_{0.0};  // a quad's bilinear map: c0 + s e1 + t (e3 + s twist)
  double jacobian_mean_ = 1.0;           // a quad's area (the Jacobian's mean over the square)
  std::vector<double> fan_;              // an n-gon's cumulative fan areas, ending at 1
};

// Points of a convex polygon seen from a point x, distributed uniformly in the solid angle the
// polygon subtends at x: Arvo's stratified sampling of spherical triangles (J. Arvo, "Stratified
// sampling of spherical triangles", SIGGRAPH 1995) on the polygon's fan triangles, each chosen
// with probability proportional to its solid angle (Van Oosterom & Strackee's formula). A point
// drawn this way has density cos_y / (r^2 Omega) on the polygon (y's cosine, r = |y - x|), so
// for the form-factor kernel cos_x cos_y / r^2 the estimate Omega cos_x of its integral over the
// polygon has weights bounded by Omega <= 2 pi, where uniform area sampling's A cos cos / r^2 is
// unbounded for a polygon close to x. Used by visibility for pairs close compared with their
// size. Fan triangles too small for the formula's precision (below 1e-12 sr) are sampled
// uniformly in area (their share of the solid angle is then negligible). Keeps a view of
// `corners` (at most kMaxCorners), which must outlive it; solid_angle() is 0 when x lies in the
// polygon's plane or behind it, and then point() returns the first corner.
class SolidAngleSampler {
 public:
  static constexpr size_t kMaxCorners = 32;
  // `normal`: the polygon's front normal (x must be in front of it to see anything).
  SolidAngleSampler(const Vec3& x, std::span<const Vec3> corners, const Vec3& normal);
  double solid_angle() const { return total_; }
  // The point for (u, v) in [0, 1)^2; stratifying (u, v) stratifies the directions.
  Vec3 point(double u, double v) const;

 private:
  Vec3 x_;
  std::span<const Vec3> corners_;
  double total_ = 0.0;
  Vec3 normal_;
  double cumulative_[kMaxCorners];  // solid angle up to and including each fan triangle
  Vec3 unit_[kMaxCorners];          // (corner - x) / |corner - x|, set when total_ > 0
};

// SolidAngleSampler for up to 16 points x_k at once, each toward the same polygon: in x, u, v
// (lanes 0..count-1), out the points y = SolidAngleSampler(x_k, corners, normal).point(u_k, v_k)
// and omega = its solid_angle(). Each lane takes the same operations in the same order as
// SolidAngleSampler (no fused multiply-adds in either; libm's sincos and atan2 where it calls
// them), so the results are the same bits; the loops run over the lanes, so they vectorise.
// Close pairs draw one such point per ray (visibility.cpp, trace_close).
struct SolidAngleLanes {
  static constexpr int kLanes = 16;
  alignas(64) double x[3][kLanes], u[kLanes], v[kLanes];  // in
  alignas(64) double y[3][kLanes], omega[kLanes];         // out
};
void sample_solid_angles(std::span<const Vec3> corners, const Vec3& normal, int count,
                         SolidAngleLanes& lanes);
// The same on a chosen instruction set (tests, benchmarks): false, doing nothing, where the
// processor lacks it. sample_solid_angles takes the widest it has.
enum class SamplerIsa { baseline, avx2, avx512 };
bool sample_solid_angles_on(SamplerIsa isa, std::span<const Vec3> corners, const Vec3& normal,
                            int count, SolidAngleLanes& lanes);

// The solid angle of the triangle of unit vectors (a, b, c): Van Oosterom & Strackee (1983),
// tan(Omega / 2) = |a . (b x c)| / (1 + a.b + b.c + c.a).
double spherical_triangle_area(const Vec3& a, const Vec3& b, const Vec3& c);

// `count` strata of an m x m grid (m = `side`, count <= m^2), row-major indices: all of them in
// order when count = m^2 (no random numbers drawn), else `count` distinct cells chosen at random.
void choose_strata(int count, int side, Pcg32& rng, std::vector<uint32_t>& out);

// `count` points: an m x m grid (m = ceil(sqrt(count))) of strata, `count` of its cells chosen
// without repetition (all of them, row by row, when count = m^2), one jittered point in each.
void stratified_points(std::span<const Vec3> corners, int count, Pcg32& rng, std::vector<Vec3>& out,
                       double inset = 1e-4);

}  // namespace radlab
