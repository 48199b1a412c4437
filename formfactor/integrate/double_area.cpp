#include "formfactor/integrate/double_area.h"

#include <algorithm>
#include <numbers>
#include <span>

#include "formfactor/integrate/quadrature.h"

namespace radlab {

ElementRules::ElementRules(const Mesh& mesh) {
  QuadratureRule rule;
  std::vector<Vec3> corners;
  start_.reserve(mesh.size() * kMaxOrder + 1);
  for (size_t e = 0; e < mesh.size(); ++e) {
    mesh.corners(e, corners);
    for (int order = 1; order <= kMaxOrder; ++order) {
      start_.push_back(data_.size());
      element_quadrature(corners, order, rule);
      for (const std::vector<double>* v : {&rule.x, &rule.y, &rule.z, &rule.weight})
        data_.insert(data_.end(), v->begin(), v->end());
    }
  }
  start_.push_back(data_.size());
}

namespace {

// One term of the double sum: v_l (n_i.d)(-n_j.d) / |d|^4 for d = y_l - x_k (both loops below).
[[gnu::always_inline]] inline double kernel_term(double ax, double ay, double az, double bx,
                                                 double by, double bz, double bw, const Vec3& n_i,
                                                 const Vec3& n_j) {
  const double dx = bx - ax, dy = by - ay, dz = bz - az;
  const double r2 = dx * dx + dy * dy + dz * dz;
  const double ci = n_i.x * dx + n_i.y * dy + n_i.z * dz;
  const double cj = -(n_j.x * dx + n_j.y * dy + n_j.z * dz);
  return bw * (ci * cj) / (r2 * r2);
}

// Rules of NA and NB points (compile-time sizes: every loop unrolled and vectorised). The same
// operations in the same order as the general loop below, so the same bits: each point k of i
// sums its terms over l in order, then the points' weighted sums are added in order. The loops
// run over l outside and k inside, so the NA running sums are one vector (no horizontal sum
// a point).
template <size_t NA, size_t NB>
[[gnu::always_inline]] inline double double_area_fixed(const ElementRules::Rule& a, const Vec3& n_i,
                                                       const ElementRules::Rule& b,
                                                       const Vec3& n_j) {
  double inner[NA];
  for (size_t k = 0; k < NA; ++k) inner[k] = 0.0;
  for (size_t l = 0; l < NB; ++l) {
    const double bx = b.x[l], by = b.y[l], bz = b.z[l], bw = b.w[l];
    for (size_t k = 0; k < NA; ++k)
      inner[k] += kernel_term(a.x[k], a.y[k], a.z[k], bx, by, bz, bw, n_i, n_j);
  }
  double sum = 0.0;
  for (size_t k = 0; k < NA; ++k) sum += a.w[k] * inner[k];
  return sum;
}

// The terms of one point of i against a block of j's points first (a loop without a reduction,
// which GCC vectorises; AVX2 where the CPU has it, without FMA so every CPU gets the same bits),
// then their sum in order. Quads and triangles have m^2 points at order m, so the common sizes
// (1, 4, 9, 16 on both sides) take loops of fixed length: with the general loop's bounds known
// only at run time, its set-up outweighed the 16 or 81 terms of orders 2 and 3.
[[gnu::always_inline]] inline double double_area_sum(const ElementRules::Rule& a, const Vec3& n_i,
                                                     const ElementRules::Rule& b, const Vec3& n_j) {
  if (a.count == b.count) {
    switch (a.count) {
      case 1:
        return double_area_fixed<1, 1>(a, n_i, b, n_j);
      case 4:
        return double_area_fixed<4, 4>(a, n_i, b, n_j);
      case 9:
        return double_area_fixed<9, 9>(a, n_i, b, n_j);
      case 16:
        return double_area_fixed<16, 16>(a, n_i, b, n_j);
      default:
        break;
    }
  }
  constexpr size_t kBlock = 64;
  double term[kBlock];
  double sum = 0.0;
  for (size_t k = 0; k < a.count; ++k) {
    const double ax = a.x[k], ay = a.y[k], az = a.z[k];
    double inner = 0.0;
    for (size_t first = 0; first < b.count; first += kBlock) {
      const size_t count = std::min(kBlock, b.count - first);
      const double *bx = b.x + first, *by = b.y + first, *bz = b.z + first, *bw = b.w + first;
      for (size_t l = 0; l < count; ++l)
        term[l] = kernel_term(ax, ay, az, bx[l], by[l], bz[l], bw[l], n_i, n_j);
      for (size_t l = 0; l < count; ++l) inner += term[l];
    }
    sum += a.w[k] * inner;
  }
  return sum;
}

}  // namespace

[[gnu::target_clones("avx2", "default")]] double double_area_form_factor(
    const ElementRules::Rule& a, const Vec3& n_i, const ElementRules::Rule& b, const Vec3& n_j,
    double area_j) {
  return double_area_sum(a, n_i, b, n_j) * area_j / std::numbers::pi;
}

namespace {

// The pair most separated pairs take: orders 2 and 1 on quads (16 terms and 1).
bool common(const DoubleAreaRules& p) {
  return p.a_high.count == 4 && p.b_high.count == 4 && p.a_low.count == 1 && p.b_low.count == 1;
}

[[gnu::always_inline]] inline DoubleAreaPair common_pair(const DoubleAreaRules& p) {
  return {double_area_fixed<4, 4>(p.a_high, p.n_i, p.b_high, p.n_j) * p.area_j / std::numbers::pi,
          double_area_fixed<1, 1>(p.a_low, p.n_i, p.b_low, p.n_j) * p.area_j / std::numbers::pi};
}

[[gnu::always_inline]] inline DoubleAreaPair any_pair(const DoubleAreaRules& p) {
  if (common(p)) return common_pair(p);
  return {double_area_sum(p.a_high, p.n_i, p.b_high, p.n_j) * p.area_j / std::numbers::pi,
          double_area_sum(p.a_low, p.n_i, p.b_low, p.n_j) * p.area_j / std::numbers::pi};
}

}  // namespace

[[gnu::target_clones("avx2", "default")]] DoubleAreaPair double_area_pair(
    const DoubleAreaRules& p) {
  return any_pair(p);
}

[[gnu::target_clones("avx2", "default")]] void double_area_pairs(const DoubleAreaRules& p,
                                                                 const DoubleAreaRules& q,
                                                                 DoubleAreaPair& fp,
                                                                 DoubleAreaPair& fq) {
  if (common(p) && common(q)) {  // two independent chains, no branch between them
    const DoubleAreaPair a = common_pair(p), b = common_pair(q);
    fp = a;
    fq = b;
    return;
  }
  fp = any_pair(p);
  fq = any_pair(q);
}

}  // namespace radlab
