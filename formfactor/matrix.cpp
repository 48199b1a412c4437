#include "formfactor/matrix.h"

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <chrono>
#include <cstdio>

namespace radlab {

FormFactorMatrix::FormFactorMatrix(size_t n, Precision precision) : n_(n), precision_(precision) {
  if (precision == Precision::kFloat)
    f32_.assign(n * n, 0.0f);
  else
    f64_.assign(n * n, 0.0);
}

size_t FormFactorMatrix::bytes() const {
  return f32_.size() * sizeof(float) + f64_.size() * sizeof(double);
}

const void* FormFactorMatrix::data() const {
  return precision_ == Precision::kFloat ? static_cast<const void*>(f32_.data())
                                         : static_cast<const void*>(f64_.data());
}

void* FormFactorMatrix::data() {
  return precision_ == Precision::kFloat ? static_cast<void*>(f32_.data())
                                         : static_cast<void*>(f64_.data());
}

std::string BuildReport::summary() const {
  char buffer[400];
  std::snprintf(buffer, sizeof buffer,
                "%.3f s on %d threads, %llu rays, %llu kernel evaluations, pairs: %llu culled, "
                "%llu unoccluded, %llu traced",
                seconds, threads, static_cast<unsigned long long>(cost.rays),
                static_cast<unsigned long long>(cost.kernel_evaluations),
                static_cast<unsigned long long>(cost.pairs_culled),
                static_cast<unsigned long long>(cost.pairs_unoccluded),
                static_cast<unsigned long long>(cost.pairs_traced));
  std::string text = buffer;
  if (cached) {
    std::snprintf(buffer, sizeof buffer, " (loaded from the cache in %.3f s: ", load_seconds);
    text += buffer + cache_file + ")";
  }
  return text;
}

void FormFactorMatrix::set_row(size_t i, std::span<const double> values) {
  if (precision_ == Precision::kFloat) {
    float* r = row_f32(i);
    for (size_t j = 0; j < n_; ++j) r[j] = float(values[j]);
  } else {
    std::copy(values.begin(), values.end(), row_f64(i));
  }
}

FormFactorMatrix build_matrix(const FormFactorMethod& method, size_t n, Precision precision,
                              BuildReport& report,
                              const std::function<void(size_t, size_t)>& progress) {
  const auto start = std::chrono::steady_clock::now();
  FormFactorMatrix matrix(n, precision);
  tbb::combinable<RowCost> costs;
  // Every row is asked for: the method may share work between the two rows of a pair.
  struct AllRows {
    const FormFactorMethod& method;
    explicit AllRows(const FormFactorMethod& m) : method(m) { method.begin_all_rows(); }
    ~AllRows() { method.end_all_rows(); }
  } all_rows(method);
  std::atomic<size_t> done{0};
  std::atomic<int> last_reported{-1};
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1), [&](const tbb::blocked_range<size_t>& r) {
    thread_local std::vector<double> row;
    row.resize(n);
    for (size_t i = r.begin(); i != r.end(); ++i) {
      method.row(i, row, costs.local());
      matrix.set_row(i, row);
      size_t now = ++done;
      // Report at most ~200 times; only one thread reports a given percentage step.
      int step = int(200 * now / std::max<size_t>(n, 1));
      int seen = last_reported.load();
      if (progress && step > seen && last_reported.compare_exchange_strong(seen, step))
        progress(now, n);
    }
  });
  report.cost = costs.combine([](RowCost a, const RowCost& b) { return a += b; });
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  report.threads =
      int(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
  return matrix;
}

void symmetrise(FormFactorMatrix& m, std::span<const double> area) {
  const size_t n = m.size();
  tbb::parallel_for(size_t(0), n, [&](size_t i) {
    for (size_t j = i + 1; j < n; ++j) {
      const double ai = area[i], aj = area[j];
      const double g = ai * aj * (aj * m.at(i, j) + ai * m.at(j, i)) / (ai * ai + aj * aj);
      m.set(i, j, g / area[i]);
      m.set(j, i, g / area[j]);
    }
  });
}

}  // namespace radlab
