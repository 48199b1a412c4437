// Double-area Gauss rules for well-separated unoccluded pairs (`exact`, issue 13 target 2).
//
//   F_ij = (1/A_i) ∫_i ∫_j cos θ_i cos θ_j / (π r²) dA_j dA_i
//        ≈ (A_j / π) Σ_k Σ_l w_k v_l (n_i·d)(−n_j·d) / |d|⁴,   d = y_l − x_k,
//
// the product of an order-m Gauss rule on each element (quadrature.h; weights are area fractions).
// For a pair whose elements are apart and each wholly in front of the other's plane the kernel
// is analytic over both, so the product rule converges geometrically like the single-area rule
// of polygon_integral.h, but each term costs a few multiplications instead of one Lambert
// evaluation (four arctangents): the method of View3D's "2AI" for distant surfaces (Walton 2002,
// NISTIR 6925), there also with the number of points raised until two rules agree.
// The rules of every element for orders 1..kMaxOrder are made once (30 points an element, ~1 KB).
// Cost: m^4 kernel terms per rule (16 at order 2). Left out: pairs that touch, straddle a plane
// or are near (their kernel is not analytic over both elements); exact.cpp integrates those
// with Lambert's formula.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "scene/mesh.h"

namespace radlab {

class ElementRules {
 public:
  static constexpr int kMaxOrder = 4;
  explicit ElementRules(const Mesh& mesh);

  // The order-m rule of element e (1 <= m <= kMaxOrder): points and area-fraction weights.
  struct Rule {
    const double *x, *y, *z, *w;
    size_t count;
  };
  Rule rule(size_t e, int order) const {
    const size_t k = e * kMaxOrder + size_t(order - 1);
    const size_t s = start_[k], count = (start_[k + 1] - s) / 4;
    const double* x = data_.data() + s;
    return {x, x + count, x + 2 * count, x + 3 * count, count};
  }

 private:
  // One block per (element, order): the rule's x, then y, z and the weights, the blocks of an
  // element back to back, lowest order first. A pair reads its two rules from one place (orders 2
  // and 1 of a quad: 160 bytes, three cache lines) instead of from four arrays of every element's
  // points: with those the loads of the next element's points were the double-area rule's
  // slowest instructions.
  std::vector<double> data_;
  std::vector<uint64_t> start_;  // first value of (element, order), one past the last at the end
};

// (A_j / π) Σ_k Σ_l w_k v_l (n_i·d)(−n_j·d)/|d|⁴ over the rules a (on i) and b (on j).
double double_area_form_factor(const ElementRules::Rule& a, const Vec3& n_i,
                               const ElementRules::Rule& b, const Vec3& n_j, double area_j);

// The acceptance test's rules of one pair (exact.cpp): orders m and m - 1 on both elements.
struct DoubleAreaRules {
  ElementRules::Rule a_high, b_high, a_low, b_low;
  Vec3 n_i, n_j;
  double area_j;
};
struct DoubleAreaPair {
  double high, low;
};
// Both rules in one call, each the same bits as double_area_form_factor.
DoubleAreaPair double_area_pair(const DoubleAreaRules& p);
// Two pairs in one call (one dispatch for two; the out-of-order core may overlap their chains of
// sums and divisions); each result the same bits as double_area_pair's.
void double_area_pairs(const DoubleAreaRules& p, const DoubleAreaRules& q, DoubleAreaPair& fp,
                       DoubleAreaPair& fq);

}  // namespace radlab
