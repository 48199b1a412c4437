#include "radlab/formfactor/symmetric_build.h"

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <vector>

namespace radlab {

FormFactorMatrix build_matrix_symmetric(const ExactFormFactors& method, const Mesh& mesh,
                                        Precision precision, Layout layout, BuildReport& report,
                                        const std::function<void(size_t, size_t)>& progress) {
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
      for (size_t j = i + 1; j < n; ++j) {
        // Each pair's classes count for both of its entries, its work once.
        RowCost one;
        const bool from_i = ExactFormFactors::integrates_from(mesh, i, j);
        row[j] = from_i ? method.pair_integral(i, j, one) : method.pair_integral(j, i, one);
        cost.rays += one.rays;
        cost.kernel_evaluations += one.kernel_evaluations;
        cost.pairs_culled += 2 * one.pairs_culled;
        cost.pairs_unoccluded += 2 * one.pairs_unoccluded;
        cost.pairs_traced += 2 * one.pairs_traced;
      }
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
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 16), [&](const tbb::blocked_range<size_t>& r) {
    thread_local std::vector<double> row;
    row.resize(n);
    for (size_t i = r.begin(); i != r.end(); ++i) {
      for (size_t j = 0; j < n; ++j) {
        if (j == i) {
          row[j] = 0.0;
          continue;
        }
        const double f = j > i ? upper.at(i, j) : upper.at(j, i);
        // The same expression as ExactFormFactors::pair(i, j).
        row[j] = ExactFormFactors::integrates_from(mesh, i, j)
                     ? f
                     : ExactFormFactors::reciprocal(f, mesh.area[j], mesh.area[i]);
      }
      matrix.set_row(i, row);
    }
  });
  report.cost = costs.combine([](RowCost x, const RowCost& y) { return x += y; });
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  report.threads =
      int(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
  return matrix;
}

}  // namespace radlab
