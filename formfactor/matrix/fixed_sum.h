// Sums of non-negative row errors in fixed point, so that a row's sum has the same bits in
// whatever order, and in whatever pieces, its terms are added (blocked builds:
// formfactor/matrix/matrix_blocks.h add each block's share of a row's sum; a one-process build
// adds the row's terms in column order, or in the order its threads finish).
//
// Units of 2^-80, each term rounded up (a stated error never shrinks by it; 8e-25 a term) and
// capped at 2^20 (a row that far off fails every check anyway), so 2^24 terms (the matrix
// cache's largest n) fit in 124 of the 128 bits. Integer addition is exact and associative;
// from_fixed rounds the sum up to a double, and to_fixed(from_fixed(s)) == s (the double is an
// integer multiple of 2^-80 that a double holds exactly), so a sum saved as a double and loaded
// again is unchanged.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

namespace radlab {

__extension__ typedef unsigned __int128 FixedSum;

inline constexpr int kFixedSumBits = 80;
inline constexpr double kFixedSumTermCap = 1048576.0;  // 2^20

inline FixedSum to_fixed(double x) {
  if (!(x > 0.0)) return 0;
  return static_cast<FixedSum>(std::ceil(std::ldexp(std::min(x, kFixedSumTermCap), kFixedSumBits)));
}

// The sum as a double, rounded up.
inline double from_fixed(FixedSum sum) {
  double d = static_cast<double>(sum);
  if (static_cast<FixedSum>(d) < sum) d = std::nextafter(d, std::numeric_limits<double>::max());
  return std::ldexp(d, -kFixedSumBits);
}

}  // namespace radlab
