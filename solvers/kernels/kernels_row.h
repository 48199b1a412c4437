// A row of F as a sparse matrix stores it (formfactor/matrix.h, Layout::kSparse), handed to the
// kernels as it is: runs of consecutive stored columns and their values, without expanding it
// into a dense scratch row of n values (the scratch costs a write and a clear of every stored
// entry, and the kernel then reads all n columns, zeros included).
//
// The kernels that take a RunRow (gather, shoot in solvers/kernels.h) do, on the stored columns,
// exactly the arithmetic the dense kernels do on the same columns, and skip the others. Skipping
// is exact: a column with F_ij = 0 adds F_ij x_j = +-0 to a lane sum that is never -0 (sums start
// at +0, and round-to-nearest never makes -0 from a sum of non-zeros or from +0 + -0), and a shot
// adds (0 / A_j) (k rho_j) = +-0 to a dB_j that is never -0 either (it starts at E_j >= +0 and
// changes only by such sums). So the results are the same bits as on the dense row, for finite x
// and shot amounts (with an infinite or NaN x_j the dense kernels would make NaN from 0 * x_j;
// tests/solvers/kernels/kernels_test.cpp compares both layouts).
#pragma once

#include <cstddef>
#include <cstdint>

namespace radlab::kernels {

template <class T>
struct RunRow {
  // run[2k] = the first column of run k, run[2k+1] = the index of its first value in `value`;
  // run k ends where run k+1's values begin (the last at `values`). Ascending and disjoint.
  const uint32_t* run = nullptr;
  size_t runs = 0;  // number of runs (run holds 2 * runs entries)
  const T* value = nullptr;
  size_t values = 0;

  size_t first(size_t k) const { return run[2 * k]; }
  size_t begin(size_t k) const { return run[2 * k + 1]; }
  size_t count(size_t k) const { return (k + 1 < runs ? run[2 * k + 3] : values) - begin(k); }

  // F_ij for any column j (0 where nothing is stored): a binary search over the runs, for the few
  // single entries a solver reads besides the kernels' passes (the self term, a correction).
  T operator[](size_t j) const {
    size_t lo = 0, hi = runs;  // the first run starting after j
    while (lo < hi) {
      const size_t mid = (lo + hi) / 2;
      if (first(mid) <= j)
        lo = mid + 1;
      else
        hi = mid;
    }
    if (lo == 0) return T(0);
    const size_t k = lo - 1, offset = j - first(k);
    return offset < count(k) ? value[begin(k) + offset] : T(0);
  }
};

}  // namespace radlab::kernels
