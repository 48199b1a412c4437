#include "formfactor/visibility/sampling.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <glm/geometric.hpp>

#include "formfactor/integrate/fast_atan.h"

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

namespace radlab {

namespace {

constexpr int kLanes = SolidAngleLanes::kLanes;
using Lane = double[kLanes];

// std::clamp's and std::max's comparisons, as value selects.
inline double clamped(double v, double lo, double hi) {
  return v < lo ? lo : (hi < v ? hi : v);
}
inline double at_least_zero(double v) {
  return 0.0 < v ? v : 0.0;
}

}  // namespace

// Lane k repeats SolidAngleSampler(x_k, corners, normal) and point(u_k, v_k) operation for
// operation; every branch of theirs becomes a select at the end (all paths computed, the
// divisions too: a lane whose divisor is 0 takes another path). glm's dot is (x x' + y y') +
// z z', normalize multiplies by 1 / sqrt, cross is (y z' - y' z, z x' - z' x, x y' - x' y).
[[gnu::always_inline]] inline void sample_lanes(std::span<const Vec3> c, const Vec3& n, int count,
                                                SolidAngleLanes& L) {
  const size_t corners = c.size();
  const int lanes = std::clamp(count, 1, kLanes);
  for (int k = lanes; k < kLanes; ++k) {  // unused lanes repeat lane 0
    for (int a = 0; a < 3; ++a) L.x[a][k] = L.x[a][0];
    L.u[k] = L.u[0], L.v[k] = L.v[0];
  }
  if (corners < 3 || corners > SolidAngleSampler::kMaxCorners) {  // sees nothing
    for (int k = 0; k < lanes; ++k) {
      L.omega[k] = 0.0;
      for (int a = 0; a < 3; ++a) L.y[a][k] = corners ? c[0][a] : 0.0;
    }
    return;
  }
  // The constructor: unit vectors towards the corners, the fan triangles' solid angles.
  alignas(64) Lane ux[SolidAngleSampler::kMaxCorners], uy[SolidAngleSampler::kMaxCorners],
      uz[SolidAngleSampler::kMaxCorners];
  alignas(64) Lane cumulative[SolidAngleSampler::kMaxCorners];
  alignas(64) Lane total, front;
  for (int k = 0; k < kLanes; ++k) {
    const double dx = L.x[0][k] - c[0].x, dy = L.x[1][k] - c[0].y, dz = L.x[2][k] - c[0].z;
    front[k] = (dx * n.x + dy * n.y) + dz * n.z > 0.0 ? 1.0 : 0.0;
    total[k] = 0.0;
  }
  for (size_t i = 0; i < corners; ++i)
    for (int k = 0; k < kLanes; ++k) {
      const double dx = c[i].x - L.x[0][k], dy = c[i].y - L.x[1][k], dz = c[i].z - L.x[2][k];
      const double inverse = 1.0 / std::sqrt((dx * dx + dy * dy) + dz * dz);
      ux[i][k] = dx * inverse, uy[i][k] = dy * inverse, uz[i][k] = dz * inverse;
    }
  for (size_t f = 1; f + 1 < corners; ++f) {
    alignas(64) Lane triple, denominator, area;
    const Lane &ax = ux[0], &ay = uy[0], &az = uz[0];
    const Lane &bx = ux[f], &by = uy[f], &bz = uz[f];
    const Lane &cx = ux[f + 1], &cy = uy[f + 1], &cz = uz[f + 1];
    for (int k = 0; k < kLanes; ++k) {
      const double wx = by[k] * cz[k] - cy[k] * bz[k], wy = bz[k] * cx[k] - cz[k] * bx[k],
                   wz = bx[k] * cy[k] - cx[k] * by[k];
      triple[k] = std::abs((ax[k] * wx + ay[k] * wy) + az[k] * wz);
      const double ab = (ax[k] * bx[k] + ay[k] * by[k]) + az[k] * bz[k];
      const double bc = (bx[k] * cx[k] + by[k] * cy[k]) + bz[k] * cz[k];
      const double ca = (cx[k] * ax[k] + cy[k] * ay[k]) + cz[k] * az[k];
      denominator[k] = ((1.0 + ab) + bc) + ca;
      area[k] = 2.0 * atan2_upper(triple[k], denominator[k]);
    }
    // spherical_triangle_area takes libm's atan2 for a flat triangle (rare): redo those lanes.
    for (int k = 0; k < kLanes; ++k)
      if (!(triple[k] > 0.0)) area[k] = 2.0 * std::atan2(triple[k], denominator[k]);
    for (int k = 0; k < kLanes; ++k) {
      total[k] += area[k];
      cumulative[f - 1][k] = total[k];
    }
  }
  // point(u, v): the fan triangle f whose share holds u (upper_bound over the first
  // triangles - 1 cumulative values: how many are at most u Omega), its corners gathered.
  const size_t triangles = corners - 2;
  alignas(64) Lane value, fan, before, upto;
  alignas(64) Lane bx, by, bz, cx, cy, cz, p1x, p1y, p1z, p2x, p2y, p2z;
  for (int k = 0; k < kLanes; ++k) {
    value[k] = L.u[k] * total[k];
    fan[k] = 0.0, before[k] = 0.0, upto[k] = cumulative[0][k];
    bx[k] = ux[1][k], by[k] = uy[1][k], bz[k] = uz[1][k];
    cx[k] = ux[2][k], cy[k] = uy[2][k], cz[k] = uz[2][k];
    p1x[k] = c[1].x, p1y[k] = c[1].y, p1z[k] = c[1].z;
    p2x[k] = c[2].x, p2y[k] = c[2].y, p2z[k] = c[2].z;
  }
  for (size_t t = 0; t + 1 < triangles; ++t)
    for (int k = 0; k < kLanes; ++k) fan[k] += cumulative[t][k] <= value[k] ? 1.0 : 0.0;
  for (size_t t = 1; t < triangles; ++t) {
    const double index = double(t);
    const Vec3 p1 = c[t + 1], p2 = c[t + 2];  // loaded once: the selects below then vectorise
    const Lane &before_t = cumulative[t - 1], &upto_t = cumulative[t];
    const Lane &bx_t = ux[t + 1], &by_t = uy[t + 1], &bz_t = uz[t + 1];
    const Lane &cx_t = ux[t + 2], &cy_t = uy[t + 2], &cz_t = uz[t + 2];
    for (int k = 0; k < kLanes; ++k) {
      const bool here = fan[k] == index;
      before[k] = here ? before_t[k] : before[k];
      upto[k] = here ? upto_t[k] : upto[k];
      bx[k] = here ? bx_t[k] : bx[k], by[k] = here ? by_t[k] : by[k];
      bz[k] = here ? bz_t[k] : bz[k];
      cx[k] = here ? cx_t[k] : cx[k], cy[k] = here ? cy_t[k] : cy[k];
      cz[k] = here ? cz_t[k] : cz[k];
      p1x[k] = here ? p1.x : p1x[k], p1y[k] = here ? p1.y : p1y[k];
      p1z[k] = here ? p1.z : p1z[k];
      p2x[k] = here ? p2.x : p2x[k], p2y[k] = here ? p2.y : p2y[k];
      p2z[k] = here ? p2.z : p2z[k];
    }
  }
  alignas(64) Lane angle, area, lengths, triple, dot_ab_ac;
  for (int k = 0; k < kLanes; ++k) {
    area[k] = upto[k] - before[k];
    const double area_hat = clamped(value[k] - before[k], 0.0, area[k]);
    const double ax = ux[0][k], ay = uy[0][k], az = uz[0][k];
    const double abx = ay * bz[k] - by[k] * az, aby = az * bx[k] - bz[k] * ax,
                 abz = ax * by[k] - bx[k] * ay;
    const double acx = ay * cz[k] - cy[k] * az, acy = az * cx[k] - cz[k] * ax,
                 acz = ax * cy[k] - cx[k] * ay;
    lengths[k] = std::sqrt((abx * abx + aby * aby) + abz * abz) *
                 std::sqrt((acx * acx + acy * acy) + acz * acz);
    const double wx = by[k] * cz[k] - cy[k] * bz[k], wy = bz[k] * cx[k] - cz[k] * bx[k],
                 wz = bx[k] * cy[k] - cx[k] * by[k];
    triple[k] = std::abs((ax * wx + ay * wy) + az * wz);
    dot_ab_ac[k] = (abx * acx + aby * acy) + abz * acz;
    const double alpha =
        triple[k] > 0.0 ? atan2_upper(triple[k], dot_ab_ac[k]) : (dot_ab_ac[k] < 0.0 ? M_PI : 0.0);
    angle[k] = area_hat - alpha;
  }
  alignas(64) Lane sine, cosine;
  for (int k = 0; k < lanes; ++k) ::sincos(angle[k], &sine[k], &cosine[k]);
  for (int k = lanes; k < kLanes; ++k) sine[k] = 0.0, cosine[k] = 1.0;
  const Vec3 c0 = c[0];
  for (int k = 0; k < kLanes; ++k) {
    const double s = sine[k], t = cosine[k];
    const double cos_alpha = clamped(dot_ab_ac[k] / lengths[k], -1.0, 1.0);
    const double sin_alpha = triple[k] / lengths[k];
    const double ax = ux[0][k], ay = uy[0][k], az = uz[0][k];
    const double cos_c = (ax * bx[k] + ay * by[k]) + az * bz[k];
    const double uu = t - cos_alpha, vv = s + sin_alpha * cos_c;
    const double denominator = (vv * s + uu * t) * sin_alpha;
    const double q = denominator != 0.0
                         ? clamped(((vv * t - uu * s) * cos_alpha - vv) / denominator, -1.0, 1.0)
                         : 1.0;
    const double ca = (cx[k] * ax + cy[k] * ay) + cz[k] * az;
    double tx = cx[k] - ca * ax, ty = cy[k] - ca * ay, tz = cz[k] - ca * az;
    const double towards_c_length = std::sqrt((tx * tx + ty * ty) + tz * tz);
    tx /= towards_c_length, ty /= towards_c_length, tz /= towards_c_length;
    const double root_q = std::sqrt(at_least_zero(1.0 - q * q));
    const double hx = q * ax + root_q * tx, hy = q * ay + root_q * ty, hz = q * az + root_q * tz;
    const double hb = (hx * bx[k] + hy * by[k]) + hz * bz[k];
    const double z = 1.0 - L.v[k] * (1.0 - hb);
    const double gx = hx - hb * bx[k], gy = hy - hb * by[k], gz = hz - hb * bz[k];
    const double towards_length = std::sqrt((gx * gx + gy * gy) + gz * gz);
    const double root_z = std::sqrt(at_least_zero(1.0 - z * z));
    const bool turn = towards_length > 0.0;
    const double dx = turn ? z * bx[k] + root_z * (gx / towards_length) : bx[k];
    const double dy = turn ? z * by[k] + root_z * (gy / towards_length) : by[k];
    const double dz = turn ? z * bz[k] + root_z * (gz / towards_length) : bz[k];
    const double along = (dx * n.x + dy * n.y) + dz * n.z;
    const double x0 = L.x[0][k], x1 = L.x[1][k], x2 = L.x[2][k];
    const double height = ((c0.x - x0) * n.x + (c0.y - x1) * n.y) + (c0.z - x2) * n.z;
    const double scale = height / along;
    const double r = std::sqrt(L.u[k]), w1 = r * (1.0 - L.v[k]), w2 = r * L.v[k];
    // The paths of point(), in its order of tests.
    const bool sees = (front[k] > 0.0) & (total[k] > 0.0);  // no && or ||: no branches
    const bool by_area = !(area[k] > 1e-12);
    const bool degenerate = !(lengths[k] > 0.0) | !(towards_c_length > 0.0);
    const bool grazing = !(along < 0.0);
    const auto pick = [&](double first, double p1, double p2, double x, double d) {
      const double uniform = ((1.0 - r) * first + w1 * p1) + w2 * p2;
      const double middle = ((first + p1) + p2) / 3.0;
      const double on_ray = x + d * scale;
      // Two-way selects from the last test back (GCC if-converts no merge of five values).
      double y = grazing ? middle : on_ray;
      y = degenerate ? first : y;
      y = by_area ? uniform : y;
      return sees ? y : first;
    };
    L.y[0][k] = pick(c0.x, p1x[k], p2x[k], x0, dx);
    L.y[1][k] = pick(c0.y, p1y[k], p2y[k], x1, dy);
    L.y[2][k] = pick(c0.z, p1z[k], p2z[k], x2, dz);
    L.omega[k] = sees ? total[k] : 0.0;
  }
}

// The same body compiled for each instruction set (inlined, then vectorised for the caller's
// target; no FMA contraction in any: CMakeLists.txt), chosen once by what the processor has.
[[gnu::target("avx512f")]] void sample_lanes_avx512(std::span<const Vec3> c, const Vec3& n,
                                                    int count, SolidAngleLanes& L) {
  sample_lanes(c, n, count, L);
}
[[gnu::target("avx2")]] void sample_lanes_avx2(std::span<const Vec3> c, const Vec3& n, int count,
                                               SolidAngleLanes& L) {
  sample_lanes(c, n, count, L);
}
void sample_lanes_baseline(std::span<const Vec3> c, const Vec3& n, int count, SolidAngleLanes& L) {
  sample_lanes(c, n, count, L);
}

bool sample_solid_angles_on(SamplerIsa isa, std::span<const Vec3> corners, const Vec3& normal,
                            int count, SolidAngleLanes& lanes) {
  switch (isa) {
    case SamplerIsa::avx512:
      if (!__builtin_cpu_supports("avx512f")) return false;
      sample_lanes_avx512(corners, normal, count, lanes);
      return true;
    case SamplerIsa::avx2:
      if (!__builtin_cpu_supports("avx2")) return false;
      sample_lanes_avx2(corners, normal, count, lanes);
      return true;
    case SamplerIsa::baseline:
      break;
  }
  sample_lanes_baseline(corners, normal, count, lanes);
  return true;
}

void sample_solid_angles(std::span<const Vec3> corners, const Vec3& normal, int count,
                         SolidAngleLanes& lanes) {
  static const SamplerIsa best = __builtin_cpu_supports("avx512f") ? SamplerIsa::avx512
                                 : __builtin_cpu_supports("avx2")  ? SamplerIsa::avx2
                                                                   : SamplerIsa::baseline;
  sample_solid_angles_on(best, corners, normal, count, lanes);
}

}  // namespace radlab
