#include "solvers/reference/dense_lu.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <utility>

namespace radlab {
namespace {

constexpr size_t kPanel = 256;  // columns per panel (the rank of each trailing update)
constexpr size_t kTile = 512;   // trailing-update tiles: kTile x kTile entries, one product each
constexpr size_t kLeaf = 16;    // panel columns factorised one by one
constexpr size_t kRowChunk = 1024;  // rows per task in the panel's column updates
constexpr size_t kColChunk = 256;   // columns per task in the row swaps and the L11 solve

using Stride = Eigen::OuterStride<>;
using Block = Eigen::Map<Eigen::MatrixXd, Eigen::Unaligned, Stride>;

}  // namespace

BlockedLu::BlockedLu(size_t n, const std::function<double(size_t, size_t)>& entry)
    : n_(n), a_(n * n), pivot_(n) {
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 16), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end(); ++i)
      for (size_t j = 0; j < n; ++j) a_[i + j * n] = entry(i, j);
  });
  factorise();
}

// Columns [c0, c1) of the panel [k0, k1), rows [c0, n): halves recursively (Toledo's recursive
// LU, as LAPACK's dgetrf2), each half's update of the other a triangular solve and a product;
// at kLeaf columns or fewer, column by column (LAPACK dgetf2). Row swaps are applied across the
// whole panel as they are chosen.
void BlockedLu::factor_panel(size_t k0, size_t k1, size_t c0, size_t c1) {
  const size_t n = n_;
  double* a = a_.data();
  auto at = [&](size_t i, size_t j) -> double& { return a[i + j * n]; };
  if (c1 - c0 <= kLeaf) {
    for (size_t k = c0; k < c1; ++k) {
      size_t p = k;
      double best = std::abs(at(k, k));
      for (size_t i = k + 1; i < n; ++i)
        if (std::abs(at(i, k)) > best) {  // the first largest: a fixed choice
          best = std::abs(at(i, k));
          p = i;
        }
      pivot_[k] = p;
      if (p != k)
        for (size_t j = k0; j < k1; ++j) std::swap(at(k, j), at(p, j));
      const double d = at(k, k);
      if (d == 0.0) continue;  // singular: leave the column (the solve gives inf/NaN)
      tbb::parallel_for(tbb::blocked_range<size_t>(0, (n - k - 1 + kRowChunk - 1) / kRowChunk, 1),
                        [&](const tbb::blocked_range<size_t>& r) {
                          for (size_t c = r.begin(); c != r.end(); ++c) {
                            const size_t lo = k + 1 + c * kRowChunk;
                            const size_t hi = std::min(n, lo + kRowChunk);
                            for (size_t i = lo; i < hi; ++i) at(i, k) /= d;
                            for (size_t j = k + 1; j < c1; ++j) {
                              const double u = at(k, j);
                              for (size_t i = lo; i < hi; ++i) at(i, j) -= at(i, k) * u;
                            }
                          }
                        });
    }
    return;
  }
  const size_t mid = c0 + (c1 - c0) / 2;
  factor_panel(k0, k1, c0, mid);
  const Stride stride{Eigen::Index(n)};
  const auto left = Eigen::Index(mid - c0), right = Eigen::Index(c1 - mid);
  const Block l11(&at(c0, c0), left, left, stride);
  Block u12(&at(c0, mid), left, right, stride);
  l11.triangularView<Eigen::UnitLower>().solveInPlace(u12);
  // A22 -= L21 U12 over rows [mid, n), in fixed chunks of kTile rows.
  const size_t chunks = (n - mid + kTile - 1) / kTile;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, chunks, 1),
                    [&](const tbb::blocked_range<size_t>& r) {
                      for (size_t c = r.begin(); c != r.end(); ++c) {
                        const size_t i0 = mid + c * kTile;
                        const auto rows = Eigen::Index(std::min(kTile, n - i0));
                        Block a22(&at(i0, mid), rows, right, stride);
                        const Block l21(&at(i0, c0), rows, left, stride);
                        const Block u(&at(c0, mid), left, right, stride);
                        a22.noalias() -= l21 * u;
                      }
                    });
  factor_panel(k0, k1, mid, c1);
}

void BlockedLu::factorise() {
  const size_t n = n_;
  double* a = a_.data();
  auto at = [&](size_t i, size_t j) -> double& { return a[i + j * n]; };
  for (size_t k0 = 0; k0 < n; k0 += kPanel) {
    const size_t k1 = std::min(n, k0 + kPanel);  // panel columns [k0, k1)
    // 1. The panel (recursively, so that most of its work is matrix products too).
    factor_panel(k0, k1, k0, k1);
    // 2. The panel's row swaps in the columns left and right of it (each column independently),
    // and 3. U12 = L11^-1 A12 for the columns right of it: Eigen's blocked triangular solve, on
    // chunks of columns fixed by n (the same shapes whatever the thread count).
    const size_t kb = k1 - k0;
    const size_t chunks = (n + kColChunk - 1) / kColChunk;
    tbb::parallel_for(
        tbb::blocked_range<size_t>(0, chunks, 1), [&](const tbb::blocked_range<size_t>& r) {
          for (size_t c = r.begin(); c != r.end(); ++c) {
            const size_t lo = c * kColChunk, hi = std::min(n, lo + kColChunk);
            for (size_t j = lo; j < hi; ++j) {
              if (j >= k0 && j < k1) continue;
              for (size_t k = k0; k < k1; ++k)
                if (pivot_[k] != k) std::swap(at(k, j), at(pivot_[k], j));
            }
            const size_t first = std::max(lo, k1);
            if (first >= hi) continue;
            const Stride stride{Eigen::Index(n)};
            const Block l11(&at(k0, k0), Eigen::Index(kb), Eigen::Index(kb), stride);
            Block a12(&at(k0, first), Eigen::Index(kb), Eigen::Index(hi - first), stride);
            l11.triangularView<Eigen::UnitLower>().solveInPlace(a12);
          }
        });
    if (k1 == n) break;
    // 4. A22 -= L21 U12 in fixed tiles.
    const size_t m = n - k1;
    const size_t tiles = (m + kTile - 1) / kTile;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, tiles * tiles, 1),
                      [&](const tbb::blocked_range<size_t>& r) {
                        for (size_t t = r.begin(); t != r.end(); ++t) {
                          const size_t i0 = k1 + (t / tiles) * kTile, j0 = k1 + (t % tiles) * kTile;
                          const auto rows = Eigen::Index(std::min(kTile, n - i0));
                          const auto cols = Eigen::Index(std::min(kTile, n - j0));
                          const auto depth = Eigen::Index(kb);
                          const Stride stride{Eigen::Index(n)};
                          Block c(&at(i0, j0), rows, cols, stride);
                          const Block l(&at(i0, k0), rows, depth, stride);
                          const Block u(&at(k0, j0), depth, cols, stride);
                          c.noalias() -= l * u;
                        }
                      });
  }
}

void BlockedLu::solve(const std::vector<double>& b, std::vector<double>& x) const {
  const size_t n = n_;
  x = b;
  for (size_t k = 0; k < n; ++k)
    if (pivot_[k] != k) std::swap(x[k], x[pivot_[k]]);
  const double* a = a_.data();
  // L y = P b (unit lower), then U x = y; column-oriented, in a fixed order.
  for (size_t k = 0; k < n; ++k) {
    const double v = x[k];
    if (v != 0.0)
      for (size_t i = k + 1; i < n; ++i) x[i] -= a[i + k * n] * v;
  }
  for (size_t k = n; k-- > 0;) {
    x[k] /= a[k + k * n];
    const double v = x[k];
    if (v != 0.0)
      for (size_t i = 0; i < k; ++i) x[i] -= a[i + k * n] * v;
  }
}

}  // namespace radlab
