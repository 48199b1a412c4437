// Dense LU factorisation with partial pivoting, blocked and run on all of radlab's threads: the
// certified reference's direct solver for n <= dense_limit (solvers/reference/reference.cpp).
//
// Method: right-looking blocked LU (Golub & Van Loan, Matrix Computations, 4th ed., §3.2.11,
// Algorithm 3.2.2 with partial pivoting as in LAPACK's dgetrf). For each panel of kPanel columns:
// factor the panel (recursively in halves, as LAPACK's dgetrf2, down to 16 columns done one by
// one with the rows below the diagonal split over threads), swap
// the pivot rows in the rest of the matrix, solve L11 U12 = A12 (columns in fixed chunks over
// threads), and update the trailing matrix A22 -= L21 U12 in fixed kTile x kTile tiles over threads
// (each tile one Eigen matrix product). Every partition is fixed by n alone, never by the thread
// count, and each entry's operations run in the same order whichever thread runs them: the factors
// and solutions are the same bits on 1, 2 or 64 threads (tests/solvers/reference/threads_test.cpp).
//
// Cost: 2n^3/3 flops, n^2 doubles (the matrix is factorised in place). Singular pivots are left
// as they are (no error here): the solution is then inf or NaN and the caller's certification
// refuses it. Left out: a parallel triangular solve (O(n^2), a fraction of a second at
// n = 9,000) and vector code of its own (the products are Eigen's, built for generic x86-64).
#pragma once

#include <cstddef>
#include <functional>
#include <vector>

namespace radlab {

class BlockedLu {
 public:
  // Factorises the n x n matrix with entries entry(i, j) (called once per entry, in parallel).
  BlockedLu(size_t n, const std::function<double(size_t, size_t)>& entry);

  // x = A^-1 b.
  void solve(const std::vector<double>& b, std::vector<double>& x) const;

  size_t size() const { return n_; }

 private:
  void factorise();
  void factor_panel(size_t k0, size_t k1, size_t c0, size_t c1);

  size_t n_ = 0;
  std::vector<double> a_;      // column-major: a_[i + j n] = A_ij, then L (unit) and U
  std::vector<size_t> pivot_;  // row k was swapped with row pivot_[k] at step k
};

}  // namespace radlab
