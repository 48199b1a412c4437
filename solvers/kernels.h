// Inner loops shared by the solvers, templated on the stored precision of F (float or double);
// accumulation is always in double (DESIGN §2: all-float shooting stalls at rho near 1).
#pragma once

#include <cstddef>

#include "core/radiosity.h"

namespace radlab::kernels {

// out[c] = sum_j F[j] * B_c[j] for each channel c.
template <class T>
inline void gather(const T* F, const Radiosity& B, double* out) {
  const size_t n = B.size();
  if (B.channels() == 1) {
    const double* b = B.channel(0).data();
    double s0 = 0.0, s1 = 0.0;
    size_t j = 0;
    for (; j + 1 < n; j += 2) {
      s0 += double(F[j]) * b[j];
      s1 += double(F[j + 1]) * b[j + 1];
    }
    if (j < n) s0 += double(F[j]) * b[j];
    out[0] = s0 + s1;
    return;
  }
  const double* r = B.channel(0).data();
  const double* g = B.channel(1).data();
  const double* b = B.channel(2).data();
  double sr = 0.0, sg = 0.0, sb = 0.0;
  for (size_t j = 0; j < n; ++j) {
    const double f = double(F[j]);
    sr += f * r[j];
    sg += f * g[j];
    sb += f * b[j];
  }
  out[0] = sr;
  out[1] = sg;
  out[2] = sb;
}

}  // namespace radlab::kernels
