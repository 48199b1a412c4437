#include "radlab/formfactor/sampling.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <glm/geometric.hpp>

#include "radlab/formfactor/fast_atan.h"

namespace radlab {

StratifiedSampler::StratifiedSampler(std::span<const Vec3> c, int strata_per_side, double inset)
    : corners_(c),
      side_(uint32_t(strata_per_side)),
      inset_(inset),
      scale_((1.0 - 2.0 * inset) / strata_per_side) {
  if (c.size() == 4) {
    e1_ = c[1] - c[0];
    e3_ = c[3] - c[0];
    twist_ = c[2] - c[1] - c[3] + c[0];
    // Exact mean of the bilinear Jacobian |(e1 + t w) x (e3 + s w)| over the unit square: it is
    // the quad's area (two triangles); 0 for a degenerate quad, where every point weighs the same.
    jacobian_mean_ = 0.5 * (glm::length(glm::cross(c[1] - c[0], c[2] - c[0])) +
                            glm::length(glm::cross(c[2] - c[0], c[3] - c[0])));
    if (!(jacobian_mean_ > 0.0)) twist_ = Vec3(0.0), jacobian_mean_ = 1.0;
  } else if (c.size() > 4) {
    double total = 0.0;
    for (size_t f = 1; f + 1 < c.size(); ++f) {
      total += glm::length(glm::cross(c[f] - c[0], c[f + 1] - c[0]));
      fan_.push_back(total);
    }
    for (double& a : fan_) a /= total;
  }
}

Vec3 StratifiedSampler::on_triangles(double s, double t) const {
  const std::span<const Vec3> c = corners_;
  size_t f = 0;  // fan triangle (c0, c[f+1], c[f+2]); s rescaled to its share of the area
  if (c.size() > 3) {
    f = size_t(std::upper_bound(fan_.begin(), fan_.end() - 1, s) - fan_.begin());
    const double before = f == 0 ? 0.0 : fan_[f - 1];
    const double share = fan_[f] - before;
    s = share > 0.0 ? std::clamp((s - before) / share, 0.0, 1.0) : 0.0;
  }
  // Area-uniform map of the unit square onto the triangle.
  const double r = std::sqrt(s);
  return (1.0 - r) * c[0] + r * (1.0 - t) * c[f + 1] + r * t * c[f + 2];
}

void StratifiedSampler::points(const uint32_t* strata, const uint32_t* bits, int count, float* x,
                               float* y, float* z) const {
  alignas(64) float s[16], t[16];
  const std::span<const Vec3> c = corners_;
  const bool power_of_two = (side_ & (side_ - 1)) == 0;
  const uint32_t mask = side_ - 1;
  const int shift = std::countr_zero(side_);
  const float inset = float(inset_), scale = float(scale_);
  for (int begin = 0; begin < count; begin += 16) {
    const int n = std::min(16, count - begin);
    for (int k = 0; k < n; ++k) {
      const uint32_t stratum = strata[begin + k], b = bits[begin + k];
      const uint32_t column = power_of_two ? stratum & mask : stratum % side_;
      const uint32_t row = power_of_two ? stratum >> shift : stratum / side_;
      s[k] = inset + scale * (float(column) + (float(b & 0xFFFFu) + 0.5f) * 0x1p-16f);
      t[k] = inset + scale * (float(row) + (float(b >> 16) + 0.5f) * 0x1p-16f);
    }
    float* px = x + begin;
    float* py = y + begin;
    float* pz = z + begin;
    if (c.size() == 4) {
      const glm::vec3 c0(c[0]), e1(e1_), e3(e3_), twist(twist_);
      for (int k = 0; k < n; ++k) {
        px[k] = c0.x + s[k] * e1.x + t[k] * (e3.x + s[k] * twist.x);
        py[k] = c0.y + s[k] * e1.y + t[k] * (e3.y + s[k] * twist.y);
        pz[k] = c0.z + s[k] * e1.z + t[k] * (e3.z + s[k] * twist.z);
      }
    } else if (c.size() == 3) {
      const glm::vec3 c0(c[0]), c1(c[1]), c2(c[2]);
      for (int k = 0; k < n; ++k) {
        const float r = std::sqrt(s[k]), w1 = r * (1.0f - t[k]), w2 = r * t[k];
        px[k] = c0.x + w1 * (c1.x - c0.x) + w2 * (c2.x - c0.x);
        py[k] = c0.y + w1 * (c1.y - c0.y) + w2 * (c2.y - c0.y);
        pz[k] = c0.z + w1 * (c1.z - c0.z) + w2 * (c2.z - c0.z);
      }
    } else {
      for (int k = 0; k < n; ++k) {
        const Vec3 p = on_triangles(double(s[k]), double(t[k]));
        px[k] = float(p.x), py[k] = float(p.y), pz[k] = float(p.z);
      }
    }
  }
}

void choose_strata(int count, int side, Pcg32& rng, std::vector<uint32_t>& out) {
  const uint32_t cells = uint32_t(side) * uint32_t(side);
  out.resize(cells);
  for (uint32_t k = 0; k < cells; ++k) out[k] = k;
  if (uint32_t(count) < cells)  // a partial Fisher-Yates shuffle: the first `count` cells
    for (uint32_t k = 0; k < uint32_t(count); ++k)
      std::swap(out[k], out[k + rng.next_below(cells - k)]);
  out.resize(size_t(count));
}

void stratified_points(std::span<const Vec3> c, int count, Pcg32& rng, std::vector<Vec3>& out,
                       double inset) {
  const int m = int(std::ceil(std::sqrt(double(count))));
  const StratifiedSampler sampler(c, m, inset);
  thread_local std::vector<uint32_t> strata;
  choose_strata(count, m, rng, strata);
  out.resize(size_t(count));
  for (size_t k = 0; k < strata.size(); ++k)
    out[k] =
        sampler.point(int(strata[k] % uint32_t(m)), int(strata[k] / uint32_t(m)), rng.next_u32());
}

}  // namespace radlab

namespace radlab {

double spherical_triangle_area(const Vec3& a, const Vec3& b, const Vec3& c) {
  const double triple = std::abs(glm::dot(a, glm::cross(b, c)));
  const double denominator = 1.0 + glm::dot(a, b) + glm::dot(b, c) + glm::dot(c, a);
  // The inline atan2 (fast_atan.h, ~2.5 ulp; libm's was ~10% of hospital.mgf's raycast build,
  // one sampler per close-pair ray); it needs y > 0 or x != 0, so a flat triangle takes libm's.
  return 2.0 * (triple > 0.0 ? atan2_upper(triple, denominator) : std::atan2(triple, denominator));
}

SolidAngleSampler::SolidAngleSampler(const Vec3& x, std::span<const Vec3> corners,
                                     const Vec3& normal)
    : x_(x), corners_(corners), normal_(normal) {
  if (corners.size() < 3 || corners.size() > kMaxCorners) return;
  // Only the front (the side the winding faces) is seen; x on the plane sees nothing.
  if (!(glm::dot(x - corners[0], normal) > 0.0)) return;
  for (size_t k = 0; k < corners.size(); ++k) unit_[k] = glm::normalize(corners[k] - x);
  for (size_t f = 1; f + 1 < corners.size(); ++f) {
    total_ += spherical_triangle_area(unit_[0], unit_[f], unit_[f + 1]);
    cumulative_[f - 1] = total_;
  }
}

Vec3 SolidAngleSampler::point(double u, double v) const {
  const std::span<const Vec3> c = corners_;
  if (!(total_ > 0.0)) return c[0];
  // The fan triangle (c0, c[f+1], c[f+2]) whose share of the solid angle holds u; u rescaled.
  const size_t triangles = c.size() - 2;
  size_t f =
      size_t(std::upper_bound(cumulative_, cumulative_ + triangles - 1, u * total_) - cumulative_);
  const double before = f == 0 ? 0.0 : cumulative_[f - 1];
  const double area = cumulative_[f] - before;
  const Vec3 &p0 = c[0], &p1 = c[f + 1], &p2 = c[f + 2];
  if (!(area > 1e-12)) {  // too small for the formulas below to be accurate: area-uniform
    const double r = std::sqrt(u);
    return (1.0 - r) * p0 + r * (1.0 - v) * p1 + r * v * p2;
  }
  const double area_hat = std::clamp(u * total_ - before, 0.0, area);
  // Arvo 1995, with A = p0, B = p1, C = p2 as unit vectors from x: alpha is the angle at A, c
  // the side AB. A sub-triangle of area area_hat with vertex C_hat on the arc AC is cut off, and
  // the point is placed on the arc B C_hat so that the solid angle is uniform.
  const Vec3 &A = unit_[0], &B = unit_[f + 1], &C = unit_[f + 2];
  const Vec3 ab = glm::cross(A, B), ac = glm::cross(A, C);
  const double lengths = glm::length(ab) * glm::length(ac);
  if (!(lengths > 0.0)) return p0;
  // alpha from its sine and cosine (both over `lengths`): atan2 keeps it accurate near 0 and pi,
  // where acos of the cosine loses half its digits.
  const double triple = std::abs(glm::dot(A, glm::cross(B, C))), dot = glm::dot(ab, ac);
  const double alpha = triple > 0.0 ? atan2_upper(triple, dot) : (dot < 0.0 ? M_PI : 0.0);
  const double cos_alpha = std::clamp(dot / lengths, -1.0, 1.0);
  const double sin_alpha = triple / lengths;
  const double cos_c = glm::dot(A, B);
  double s, t;  // sin and cos of area_hat - alpha, in one libm call
  ::sincos(area_hat - alpha, &s, &t);
  const double uu = t - cos_alpha, vv = s + sin_alpha * cos_c;
  const double denominator = (vv * s + uu * t) * sin_alpha;
  const double q = denominator != 0.0
                       ? std::clamp(((vv * t - uu * s) * cos_alpha - vv) / denominator, -1.0, 1.0)
                       : 1.0;
  Vec3 towards_c = C - glm::dot(C, A) * A;
  const double towards_c_length = glm::length(towards_c);
  if (!(towards_c_length > 0.0)) return p0;
  towards_c /= towards_c_length;
  const Vec3 c_hat = q * A + std::sqrt(std::max(0.0, 1.0 - q * q)) * towards_c;
  const double z = 1.0 - v * (1.0 - glm::dot(c_hat, B));
  Vec3 towards_c_hat = c_hat - glm::dot(c_hat, B) * B;
  const double towards_length = glm::length(towards_c_hat);
  const Vec3 direction = towards_length > 0.0 ? z * B + std::sqrt(std::max(0.0, 1.0 - z * z)) *
                                                            (towards_c_hat / towards_length)
                                              : B;
  // Where the direction meets the triangle's plane (it lies in the triangle's cone).
  const double along = glm::dot(direction, normal_);
  if (!(along < 0.0)) return (p0 + p1 + p2) / 3.0;  // rounding at a grazing edge
  return x_ + direction * (glm::dot(p0 - x_, normal_) / along);
}

}  // namespace radlab
