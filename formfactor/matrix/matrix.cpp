#include "formfactor/matrix/matrix.h"

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>

namespace radlab {

FormFactorMatrix::FormFactorMatrix(size_t n, Precision precision, Layout layout)
    : n_(n), precision_(precision), layout_(layout) {
  if (layout == Layout::kSparse) {
    if (n > size_t(UINT32_MAX)) throw std::length_error("sparse form-factor matrix: n too large");
    rows_.resize(n);
  } else if (precision == Precision::kFloat) {
    f32_.assign(n * n, 0.0f);
  } else {
    f64_.assign(n * n, 0.0);
  }
}

size_t FormFactorMatrix::bytes() const {
  size_t total = f32_.size() * sizeof(float) + f64_.size() * sizeof(double);
  for (const SparseRow& row : rows_)
    total += row.run.size() * sizeof(uint32_t) + row.f32.size() * sizeof(float) +
             row.f64.size() * sizeof(double);
  return total;
}

void FormFactorMatrix::set_sparse_row(size_t i, SparseRow row) {
  if (layout_ != Layout::kSparse) throw std::logic_error("set_sparse_row on a dense matrix");
  const size_t count = values(row);
  if (row.run.empty() && count == n_) {
    rows_[i] = std::move(row);
    return;
  }
  // Runs: ascending, disjoint, non-empty, inside the row; value offsets from 0 to the count.
  const size_t runs = row.run.size() / 2;
  bool ok = row.run.size() % 2 == 0 && (runs > 0 || count == 0);
  for (size_t k = 0; ok && k < runs; ++k) {
    const size_t first = row.run[2 * k], offset = row.run[2 * k + 1];
    const size_t end = k + 1 < runs ? row.run[2 * k + 3] : count;
    ok = (k == 0 ? offset == 0 : first > row.run[2 * k - 2]) && end > offset &&
         first + (end - offset) <= n_ &&
         (k + 1 == runs || row.run[2 * k + 2] >= first + (end - offset));
  }
  if (!ok)
    throw std::invalid_argument("sparse form-factor row " + std::to_string(i) +
                                ": runs out of order, overlapping or outside the row");
  rows_[i] = std::move(row);
}

void FormFactorMatrix::set(size_t i, size_t j, double value) {
  if (layout_ == Layout::kDense) {
    if (precision_ == Precision::kFloat)
      f32_[i * n_ + j] = float(value);
    else
      f64_[i * n_ + j] = value;
    return;
  }
  SparseRow& row = rows_[i];
  size_t k = whole_row(i) ? j : find(row.run, values(row), j);
  if (k == SIZE_MAX) {
    if (value == 0.0) return;
    std::vector<double> dense(n_);
    visit_row(i, [&](const auto* r) {
      for (size_t c = 0; c < n_; ++c) dense[c] = double(r[c]);
    });
    dense[j] = value;
    set_row(i, dense);
    return;
  }
  if (precision_ == Precision::kFloat)
    row.f32[k] = float(value);
  else
    row.f64[k] = value;
}

const void* FormFactorMatrix::data() const {
  if (layout_ == Layout::kSparse)
    throw std::logic_error("FormFactorMatrix::data(): dense layout only");
  return precision_ == Precision::kFloat ? static_cast<const void*>(f32_.data())
                                         : static_cast<const void*>(f64_.data());
}

void* FormFactorMatrix::data() {
  return const_cast<void*>(std::as_const(*this).data());
}

bool identical_entries(const FormFactorMatrix& a, const FormFactorMatrix& b) {
  if (a.size() != b.size() || a.precision() != b.precision()) return false;
  std::vector<double> row(a.size());
  for (size_t i = 0; i < a.size(); ++i) {
    a.visit_row(i, [&](const auto* x) {
      for (size_t j = 0; j < row.size(); ++j) row[j] = double(x[j]);
    });
    bool same = true;
    b.visit_row(i, [&](const auto* y) {
      for (size_t j = 0; j < row.size() && same; ++j)
        // float -> double is exact, so equal doubles are equal entries (the sign for zeros).
        same = double(y[j]) == row[j] && std::signbit(double(y[j])) == std::signbit(row[j]);
    });
    if (!same) return false;
  }
  return true;
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
  if (layout_ == Layout::kSparse) return set_row(i, values, {});
  if (precision_ == Precision::kFloat) {
    float* r = row_f32(i);
    for (size_t j = 0; j < n_; ++j) r[j] = float(values[j]);
  } else {
    std::copy(values.begin(), values.end(), row_f64(i));
  }
}

void FormFactorMatrix::set_row(size_t i, std::span<const double> values,
                               std::span<const char> keep) {
  if (layout_ != Layout::kSparse) throw std::logic_error("set_row with keep on a dense matrix");
  const size_t value_bytes = precision_ == Precision::kFloat ? sizeof(float) : sizeof(double);
  auto stored = [&](size_t j) { return values[j] != 0.0 || (!keep.empty() && keep[j]); };
  // Runs of stored entries; a gap costing no more than a run (8 bytes) is stored as zeros.
  const size_t max_gap = 2 * sizeof(uint32_t) / value_bytes;
  std::vector<uint32_t> run;
  size_t count = 0;
  for (size_t j = 0; j < n_;) {
    if (!stored(j)) {
      ++j;
      continue;
    }
    size_t end = j + 1;
    for (;;) {
      while (end < n_ && stored(end)) ++end;
      size_t next = end;
      while (next < n_ && next - end <= max_gap && !stored(next)) ++next;
      if (next < n_ && next - end <= max_gap && stored(next))
        end = next;
      else
        break;
    }
    run.push_back(uint32_t(j));
    run.push_back(uint32_t(count));
    count += end - j;
    j = end;
  }
  SparseRow row;
  const bool whole = (run.size() * sizeof(uint32_t) + count * value_bytes) >= n_ * value_bytes;
  // Appended run by run (converted to T on the way), not resized to zeros first and then
  // overwritten: one pass over the new row's memory instead of two.
  auto fill = [&](auto& out) {
    if (whole) {
      out.assign(values.begin(), values.end());
      return;
    }
    out.reserve(count);
    for (size_t k = 0; k < run.size(); k += 2) {
      const size_t end = k + 2 < run.size() ? run[k + 3] : count;
      const auto first = values.begin() + std::ptrdiff_t(run[k]);
      out.insert(out.end(), first, first + std::ptrdiff_t(end - run[k + 1]));
    }
  };
  if (precision_ == Precision::kFloat)
    fill(row.f32);
  else
    fill(row.f64);
  if (!whole) row.run = std::move(run);
  rows_[i] = std::move(row);
}

FormFactorMatrix build_matrix(const FormFactorMethod& method, size_t n, Precision precision,
                              BuildReport& report,
                              const std::function<void(size_t, size_t)>& progress) {
  return build_matrix(method, n, precision, Layout::kDense, report, progress);
}

FormFactorMatrix convert_precision(const FormFactorMatrix& F, Precision precision) {
  const size_t n = F.size();
  FormFactorMatrix out(n, precision, F.layout());
  tbb::parallel_for(size_t(0), n, [&](size_t i) {
    thread_local std::vector<double> row;
    row.resize(n);
    F.visit_row(i, [&](const auto* r) {
      for (size_t j = 0; j < n; ++j) row[j] = double(r[j]);
    });
    // set_row rounds each entry to the target precision once (double -> float: to nearest).
    out.set_row(i, row);
  });
  return out;
}

FormFactorMatrix build_matrix(const FormFactorMethod& method, size_t n, Precision precision,
                              Layout layout, BuildReport& report,
                              const std::function<void(size_t, size_t)>& progress) {
  return build_matrix_rows(method, n, 0, n, precision, layout, report, progress);
}

FormFactorMatrix build_matrix_rows(const FormFactorMethod& method, size_t n, size_t first,
                                   size_t end, Precision precision, Layout layout,
                                   BuildReport& report,
                                   const std::function<void(size_t, size_t)>& progress) {
  if (first > end || end > n)
    throw std::invalid_argument("build_matrix_rows: rows [" + std::to_string(first) + ", " +
                                std::to_string(end) + ") outside a matrix of " + std::to_string(n));
  const size_t rows = end - first;
  const auto start = std::chrono::steady_clock::now();
  FormFactorMatrix matrix(n, precision, layout);
  tbb::combinable<RowCost> costs;
  // Every row asked for: the method may share work between the two rows of a pair. Not for a
  // block of rows: the other row of most pairs is another process's, and what sharing keeps can
  // grow with n^2 (raycast: 4 bytes a pair, 5.7 GB at soda's 53,216 elements, measured as one
  // block of 64 peaking at 5.8 GB).
  struct AllRows {
    const FormFactorMethod& method;
    bool on;
    AllRows(const FormFactorMethod& m, bool all) : method(m), on(all) {
      if (on) method.begin_all_rows();
    }
    ~AllRows() {
      if (on) method.end_all_rows();
    }
  } all_rows(method, first == 0 && end == n);
  std::atomic<size_t> done{0};
  std::atomic<int> last_reported{-1};
  tbb::parallel_for(
      tbb::blocked_range<size_t>(first, end, 1), [&](const tbb::blocked_range<size_t>& r) {
        thread_local std::vector<double> row;
        row.resize(n);
        for (size_t i = r.begin(); i != r.end(); ++i) {
          method.row(i, row, costs.local());
          matrix.set_row(i, row);
          size_t now = ++done;
          // Report at most ~200 times; only one thread reports a given step.
          int step = int(200 * now / std::max<size_t>(rows, 1));
          int seen = last_reported.load();
          if (progress && step > seen && last_reported.compare_exchange_strong(seen, step))
            progress(now, rows);
        }
      });
  report.cost = costs.combine([](RowCost a, const RowCost& b) { return a += b; });
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  report.threads =
      int(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
  return matrix;
}

namespace {

// Sparse: stores a zero at (i, j) wherever only F_ji is non-zero, so that every pair with a
// non-zero entry is stored both ways and can be written in place. Row by row from the
// transposed pattern (one uint32_t per non-zero, freed on return).
void symmetrise_structure(FormFactorMatrix& m) {
  const size_t n = m.size();
  std::vector<uint64_t> start(n + 1, 0);
  auto each_nonzero = [&](size_t i, auto&& fn) {
    m.visit_row(i, [&](const auto* row) {
      for (size_t j = 0; j < n; ++j)
        if (row[j] != 0) fn(j);
    });
  };
  for (size_t i = 0; i < n; ++i) each_nonzero(i, [&](size_t j) { ++start[j + 1]; });
  for (size_t j = 0; j < n; ++j) start[j + 1] += start[j];
  std::vector<uint32_t> transposed(start[n]);
  {
    std::vector<uint64_t> next(start.begin(), start.end() - 1);
    for (size_t i = 0; i < n; ++i)
      each_nonzero(i, [&](size_t j) { transposed[next[j]++] = uint32_t(i); });
  }
  tbb::parallel_for(size_t(0), n, [&](size_t i) {
    if (m.whole_row(i)) return;  // every entry is stored already
    std::vector<char> keep(n, 0);
    bool missing = false;
    for (uint64_t k = start[i]; k < start[i + 1]; ++k)
      if (m.at(i, transposed[k]) == 0.0) {
        keep[transposed[k]] = 1;
        missing = true;
      }
    if (!missing) return;
    std::vector<double> values(n);
    m.visit_row(i, [&](const auto* row) {
      for (size_t j = 0; j < n; ++j) values[j] = double(row[j]);
    });
    m.set_row(i, values, keep);
  });
}

}  // namespace

void symmetrise(FormFactorMatrix& m, std::span<const double> area) {
  const size_t n = m.size();
  if (m.sparse()) {
    symmetrise_structure(m);
    // The pair (i, j), i < j, is read and written by row i's task only, as in the dense case, and
    // with the same expression. A pair with a non-zero entry is stored both ways, and one with
    // none gives zero (which set() does not store), so no row is repacked while others run.
    tbb::parallel_for(size_t(0), n, [&](size_t i) {
      std::vector<size_t> partners;  // the stored entries right of the diagonal
      if (m.whole_row(i)) {
        for (size_t j = i + 1; j < n; ++j) partners.push_back(j);
      } else {
        const auto& row = m.sparse_row(i);
        const size_t count = m.precision() == Precision::kFloat ? row.f32.size() : row.f64.size();
        for (size_t k = 0; k < row.run.size(); k += 2) {
          const size_t end = k + 2 < row.run.size() ? row.run[k + 3] : count;
          for (size_t j = row.run[k]; j < row.run[k] + (end - row.run[k + 1]); ++j)
            if (j > i) partners.push_back(j);
        }
      }
      for (size_t j : partners) {
        const double ai = area[i], aj = area[j];
        const double g = ai * aj * (aj * m.at(i, j) + ai * m.at(j, i)) / (ai * ai + aj * aj);
        m.set(i, j, g / area[i]);
        m.set(j, i, g / area[j]);
      }
    });
    return;
  }
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
