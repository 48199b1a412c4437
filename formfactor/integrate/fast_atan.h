// An inline atan2 for the upper half-plane (y >= 0, so the angle lies in [0, pi]), the case of
// Lambert's formula: the angle between two edge vectors is atan2(|a x b|, a . b). Branch-free
// (min, max, arithmetic; one division; no table), so loops over many angles vectorise; libm's
// atan2 is an opaque call (~15 ns here) that stops that.
//
// Range reduction (atan2_upper_reduce): k pi/4 (k = 0..4) plus or minus atan(v), |v| <=
// tan(pi/8), where v = num / den is exact up to the roundings of num, den and the quotient: fold
// onto [0, pi/4] by min/max, use atan(t) = pi/4 + atan((t - 1) / (t + 1)) in the middle octant,
// unfold by symmetry. atan(v) = v + v^3 P(v^2), P of degree 10 fitted by Remez for the least
// relative error on |v| <= 1.01 tan(pi/8) (scripts/fit_atan.py; 2.5e-18 with these double
// coefficients, far below rounding), evaluated by Estrin's scheme. k pi/4 is added as a hi + lo
// pair, so a result near pi/8 does not inherit pi/4's rounding. Near 0 the result is v itself to
// the first rounding: tiny angles keep their relative accuracy.
//
// Accuracy (tests/formfactor/closed_forms_test.cpp, FastAtan.*): relative error against std::atan2
// at most 2.8e-16 (~2.5 ulp, at pi/8, where the middle octant's argument carries three roundings)
// over the whole range, tiny angles and angles near pi included; the same with and without FMA in
// the polynomial. Requires y >= 0, finite arguments and not x = y = 0 (0/0; Lambert's callers
// skip that case).
#pragma once

#include <cmath>

namespace radlab {

// The range reduction: atan2(y, x) = hi + lo + atan(num / den), |num / den| <= tan(pi/8).
struct AtanReduction {
  double num, den, hi, lo;
};

inline AtanReduction atan2_upper_reduce(double y, double x) {
  constexpr double kTanPi8 = 0.41421356237309503;  // where the regions meet; need not be exact
  // pi/4 as hi + lo: hi the nearest double, which has only 50 significant bits, so k hi is
  // exact for k = 0..4; lo the nearest double to the rest.
  constexpr double kQuarterHi = 0.7853981633974483, kQuarterLo = 3.061616997868383e-17;
  // Fold onto [0, pi/4]: t = p / q with p = min(y, |x|), q = max; in the middle octant (t above
  // tan(pi/8)) atan(t) = pi/4 + atan((p - q) / (p + q)). Then unfold: pi/2 - angle where y > |x|
  // (`swap`), pi - angle where x < 0 (`negative`). Altogether k pi/4 + sign * atan(v), v the
  // folded argument, k and the sign from the three conditions:
  //   swap  negative   angle                     k          sign
  //   no    no         m pi/4 + atan(v)          m          +
  //   yes   no         pi/2 - m pi/4 - atan(v)   2 - m      -
  //   no    yes        pi - m pi/4 - atan(v)     4 - m      -
  //   yes   yes        pi/2 + m pi/4 + atan(v)   2 + m      +
  // with m = 1 in the middle octant, else 0; the sign goes into num, atan being odd. No select
  // among computed values but min and max: the conditions become 0 or 1 and the choices
  // arithmetic with them, exact (products with 0, 1 or -1; p - 1 q and q + 1 p are the middle
  // octant's p - q and p + q), which takes fewer instructions than selects and leaves GCC no
  // branch to keep (it does not if-convert a merge of more than four values, nor, with its
  // default -ftrapping-math, move arithmetic out of a branch). Arguments must be finite (0 * inf).
  const double ax = std::fabs(x);
  // (Written as selects, which compile to single min/max instructions; a NaN argument reaches
  // the result.)
  const double p = y < ax ? y : ax, q = y < ax ? ax : y;
  const double m = p > kTanPi8 * q ? 1.0 : 0.0;
  const double swap = y > ax ? 1.0 : 0.0;
  const double negative = x < 0.0 ? 1.0 : 0.0;
  const double swap_sign = 1.0 - 2.0 * swap, negative_sign = 1.0 - 2.0 * negative;
  const double sign = swap_sign * negative_sign;
  const double base = 2.0 * swap + 4.0 * negative * (1.0 - swap);
  AtanReduction r;
  r.num = sign * (p - m * q);
  r.den = q + m * p;
  const double k = base + sign * m;
  r.hi = k * kQuarterHi;
  r.lo = k * kQuarterLo;
  return r;
}

// a * b + c, fused (one rounding) when kFma: where the target has FMA, or through libm's fma
// (exact, slow) in a test.
template <bool kFma>
inline double multiply_add(double a, double b, double c) {
  if constexpr (kFma) return __builtin_fma(a, b, c);
  return a * b + c;
}

// hi + lo + atan(u) for |u| <= 1.01 tan(pi/8): atan(u) = u + u^3 P(u^2), P evaluated by Estrin's
// scheme (latency: four multiplications deep instead of Horner's ten) in z = u^2.
template <bool kFma = false>
inline double atan2_upper_finish(const AtanReduction& r, double u) {
  const double z = u * u, z2 = z * z, z4 = z2 * z2, z8 = z4 * z4;
  // Coefficients of u^3, u^5, ..., u^23 (scripts/fit_atan.py).
  const double q0 = multiply_add<kFma>(0.1999999999994394, z, -0.33333333333333165);
  const double q1 = multiply_add<kFma>(0.11111110731892658, z, -0.14285714279191977);
  const double q2 = multiply_add<kFma>(0.07692032790080466, z, -0.09090896242876918);
  const double q3 = multiply_add<kFma>(0.05845558635764282, z, -0.06662787688935538);
  const double q4 = multiply_add<kFma>(0.03779249553360627, z, -0.05028691908036365);
  const double r0 = multiply_add<kFma>(q1, z2, q0);
  const double r1 = multiply_add<kFma>(q3, z2, q2);
  const double r2 = multiply_add<kFma>(-0.017606989031329887, z2, q4);
  const double p = multiply_add<kFma>(r2, z8, multiply_add<kFma>(r1, z4, r0));
  return r.hi + (multiply_add<kFma>(u * z, p, u) + r.lo);
}

template <bool kFma = false>
inline double atan2_upper(double y, double x) {
  const AtanReduction r = atan2_upper_reduce(y, x);
  return atan2_upper_finish<kFma>(r, r.num / r.den);
}

}  // namespace radlab
