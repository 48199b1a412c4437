#include "formfactor/matrix/symmetric_build.h"

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <stdexcept>
#include <vector>

namespace radlab {

namespace {

// Rows assembled together from the upper triangle: the entries below the diagonal of a block's
// rows are a column slice of each upper row above, read once per block (one search for the
// slice's first run, then consecutive values) instead of once per entry (a search each, a row of
// its own each: the columns were ~11% of the box's build).
constexpr size_t kBlock = 16;

// upper(row, c) for c in [lo, hi) into out[c - lo]: the stored values, 0 where none is stored
// (what FormFactorMatrix::at() gives).
void upper_columns(const FormFactorMatrix& upper, size_t row, size_t lo, size_t hi, double* out) {
  const FormFactorMatrix::SparseRow& r = upper.sparse_row(row);
  if (upper.whole_row(row)) {
    std::copy(r.f64.begin() + std::ptrdiff_t(lo), r.f64.begin() + std::ptrdiff_t(hi), out);
    return;
  }
  std::fill(out, out + (hi - lo), 0.0);
  // Runs are (first column, first value) pairs, ascending; start at the last one beginning at or
  // before lo (a binary search: a row of a large scene may hold thousands of runs).
  const size_t runs = r.run.size() / 2;
  size_t first = 0, last = runs;
  while (first < last) {
    const size_t mid = (first + last) / 2;
    if (r.run[2 * mid] <= lo)
      first = mid + 1;
    else
      last = mid;
  }
  for (size_t k = first > 0 ? first - 1 : 0; k < runs; ++k) {
    const size_t column = r.run[2 * k], value = r.run[2 * k + 1];
    if (column >= hi) break;
    const size_t end = k + 1 < runs ? r.run[2 * k + 3] : r.f64.size();
    const size_t from = std::max(column, lo), to = std::min(column + (end - value), hi);
    for (size_t c = from; c < to; ++c) out[c - lo] = r.f64[value + (c - column)];
  }
}

// Rows [lo, hi) of the result: F_ab of the integrated side from `upper` (row min(i, j)), the
// other side by reciprocity (the method's orient_row), each entry by the same expression as the
// method's row(i).
void assemble_rows(const FormFactorMethod& method, const FormFactorMatrix& upper, const Mesh& mesh,
                   size_t lo, size_t hi, FormFactorMatrix& matrix) {
  const size_t n = mesh.size();
  thread_local std::vector<double> tile;  // (hi - lo) rows of n: F_ab of the pair (i, j)
  tile.resize(kBlock * n);
  double slice[kBlock];
  // Below the diagonal: upper(j, i) for j < i, a column slice of each row j above the block's
  // last row.
  for (size_t j = 0; j + 1 < hi; ++j) {
    const size_t from = std::max(lo, j + 1);
    upper_columns(upper, j, from, hi, slice);
    for (size_t i = from; i < hi; ++i) tile[(i - lo) * n + j] = slice[i - from];
  }
  for (size_t i = lo; i < hi; ++i) {
    double* row = tile.data() + (i - lo) * n;
    upper_columns(upper, i, i + 1, n, row + i + 1);
    row[i] = 0.0;
    method.orient_row(i, std::span<double>(row, n));
    matrix.set_row(i, std::span<const double>(row, n));
  }
}

}  // namespace

FormFactorMatrix build_matrix_symmetric(const FormFactorMethod& method, const Mesh& mesh,
                                        Precision precision, Layout layout, BuildReport& report,
                                        const std::function<void(size_t, size_t)>& progress) {
  if (!method.integrates_pairs_once())
    throw std::logic_error("build_matrix_symmetric: form factors '" + method.name() +
                           "' do not integrate each pair once");
  const size_t n = mesh.size();
  const auto start = std::chrono::steady_clock::now();
  // upper(i, j), j > i: the integral over the pair's integrated side a, F_ab.
  FormFactorMatrix upper(n, Precision::kDouble, Layout::kSparse);
  tbb::combinable<RowCost> costs;
  const size_t total = n * (n - std::min<size_t>(n, 1)) / 2;
  std::atomic<size_t> done{0};
  std::atomic<int> last_reported{-1};
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1), [&](const tbb::blocked_range<size_t>& r) {
    thread_local std::vector<double> row;
    row.assign(n, 0.0);
    RowCost& cost = costs.local();
    for (size_t i = r.begin(); i != r.end(); ++i) {
      // Each pair's classes count for both of its entries, its work once.
      RowCost one;
      method.upper_row(i, row, one);
      cost.rays += one.rays;
      cost.kernel_evaluations += one.kernel_evaluations;
      cost.pairs_culled += 2 * one.pairs_culled;
      cost.pairs_unoccluded += 2 * one.pairs_unoccluded;
      cost.pairs_traced += 2 * one.pairs_traced;
      upper.set_row(i, row);
      std::fill(row.begin() + std::ptrdiff_t(i) + 1, row.end(), 0.0);
      const size_t now = done += n - 1 - i;
      // Report at most ~200 times; only one thread reports a given step.
      const int step = total ? int(200 * now / total) : 200;
      int seen = last_reported.load();
      if (progress && step > seen && last_reported.compare_exchange_strong(seen, step))
        progress(now, total);
    }
  });
  FormFactorMatrix matrix(n, precision, layout);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, (n + kBlock - 1) / kBlock, 1),
                    [&](const tbb::blocked_range<size_t>& r) {
                      for (size_t b = r.begin(); b != r.end(); ++b)
                        assemble_rows(method, upper, mesh, b * kBlock,
                                      std::min(n, (b + 1) * kBlock), matrix);
                    });
  report.cost = costs.combine([](RowCost x, const RowCost& y) { return x += y; });
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  report.threads =
      int(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
  return matrix;
}

}  // namespace radlab
