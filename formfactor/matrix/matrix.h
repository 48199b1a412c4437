// A form-factor matrix in float (default: half the memory and bandwidth) or double, in one of two
// layouts:
//   dense   n*n entries, row-major, one allocation (the default; cheapest to read);
//   sparse  each row on its own, stored as runs of consecutive non-zero columns (8 bytes a run)
//           and their values, or as all n values when that is smaller. Pairs that are culled or
//           fully occluded cost no memory, and no row costs more than its dense form
//           (docs/memory.md). prepare_problem builds the cached matrix in it.
// Solvers read rows through visit_row(), which hands the kernel a typed pointer to n values, so
// one templated kernel serves both precisions and both layouts: a sparse row is scattered into a
// zeroed thread-local scratch row (O(stored entries) to fill and clear again), so every kernel does
// the same arithmetic on the same numbers whichever the layout, and results are bit-identical.
#pragma once

#include <algorithm>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "formfactor/form_factor_method.h"

namespace radlab {

enum class Precision { kFloat, kDouble };
enum class Layout { kDense, kSparse };

class FormFactorMatrix {
 public:
  // One row of the sparse layout: runs of consecutive stored columns, `run` holding (first
  // column, index of its first value) pairs in ascending order, and their values back to back in
  // the vector of the matrix's precision (a run ends where the next one's values begin). A row kept
  // whole has no runs and n values. Runs suit form factors: the elements of one polygon are
  // consecutive, so a culled or occluded polygon is one gap, and a run costs 8 bytes where a column
  // index per entry would cost 4 bytes an entry.
  struct SparseRow {
    std::vector<uint32_t> run;
    std::vector<float> f32;
    std::vector<double> f64;
  };

  FormFactorMatrix() = default;
  // All zero. A sparse matrix starts with empty rows (no memory per entry).
  FormFactorMatrix(size_t n, Precision precision, Layout layout = Layout::kDense);

  size_t size() const { return n_; }
  Precision precision() const { return precision_; }
  Layout layout() const { return layout_; }
  bool sparse() const { return layout_ == Layout::kSparse; }
  // Bytes of the entries (and of the runs when sparse).
  size_t bytes() const;
  // Dense layout only: the n*n entries as raw bytes, row-major (the cache reads and writes them).
  // A sparse matrix's bytes are its rows' runs and values (matrix_cache.cpp reads them row by
  // row); compare matrices with identical_entries().
  const void* data() const;
  void* data();

  // Dense layout only: the row's n entries.
  const float* row_f32(size_t i) const { return f32_.data() + i * n_; }
  const double* row_f64(size_t i) const { return f64_.data() + i * n_; }
  float* row_f32(size_t i) { return f32_.data() + i * n_; }
  double* row_f64(size_t i) { return f64_.data() + i * n_; }

  // Sparse layout only: row i as stored, and whether it is kept whole.
  const SparseRow& sparse_row(size_t i) const { return rows_[i]; }
  bool whole_row(size_t i) const { return rows_[i].run.empty() && values(rows_[i]) == n_; }
  // Sparse layout only: replaces row i (runs ascending, disjoint, inside [0, n), values to
  // match; or no runs and n values). Throws std::invalid_argument otherwise. Used by the cache.
  void set_sparse_row(size_t i, SparseRow row);

  // Calls fn(const T* row) with T = float or double: row[j] = F_ij for every j.
  template <class Fn>
  decltype(auto) visit_row(size_t i, Fn&& fn) const {
    if (layout_ == Layout::kSparse) {
      if (precision_ == Precision::kFloat) return visit_sparse(rows_[i].run, rows_[i].f32, fn);
      return visit_sparse(rows_[i].run, rows_[i].f64, fn);
    }
    if (precision_ == Precision::kFloat) return fn(row_f32(i));
    return fn(row_f64(i));
  }

  double at(size_t i, size_t j) const {
    if (layout_ == Layout::kSparse)
      return precision_ == Precision::kFloat ? double(sparse_at(rows_[i].run, rows_[i].f32, j))
                                             : sparse_at(rows_[i].run, rows_[i].f64, j);
    return precision_ == Precision::kFloat ? double(f32_[i * n_ + j]) : f64_[i * n_ + j];
  }
  // On a sparse row, a zero not stored stays unstored, a stored entry is overwritten in place
  // (rows may then be written in parallel), and a new non-zero repacks the row (O(n); not safe
  // in parallel with any other access to row i).
  void set(size_t i, size_t j, double value);
  // Row i from n values: a sparse row keeps the runs of non-zeros (gaps too short to pay for a
  // run are stored as zeros), or all n values when that is smaller. Rows may be set in parallel.
  void set_row(size_t i, std::span<const double> values);
  // Sparse: row i from n values, storing also the entries where keep[j] is non-zero.
  void set_row(size_t i, std::span<const double> values, std::span<const char> keep);

 private:
  size_t values(const SparseRow& row) const {
    return precision_ == Precision::kFloat ? row.f32.size() : row.f64.size();
  }

  // A zeroed scratch row of n values per thread and nesting depth (a kernel may visit a row of
  // another matrix while visiting one); the runs copied into it are cleared again on exit, so a
  // visit costs O(stored entries) besides the kernel's own O(n) read.
  template <class T>
  class Scratch {
   public:
    explicit Scratch(size_t n) {
      if (pool().size() <= depth()) pool().emplace_back();
      buffer_ = &pool()[depth()++];
      if (buffer_->size() != n) buffer_->assign(n, T(0));
    }
    ~Scratch() { --depth(); }
    Scratch(const Scratch&) = delete;
    Scratch& operator=(const Scratch&) = delete;
    T* data() { return buffer_->data(); }

   private:
    static std::vector<std::vector<T>>& pool() {
      thread_local std::vector<std::vector<T>> buffers;
      return buffers;
    }
    static size_t& depth() {
      thread_local size_t level = 0;
      return level;
    }
    std::vector<T>* buffer_;
  };

  template <class T, class Fn>
  decltype(auto) visit_sparse(const std::vector<uint32_t>& run, const std::vector<T>& value,
                              Fn&& fn) const {
    if (run.empty() && value.size() == n_) return fn(static_cast<const T*>(value.data()));
    Scratch<T> scratch(n_);
    T* row = scratch.data();
    auto each_run = [&](auto&& body) {
      for (size_t k = 0; k < run.size(); k += 2) {
        const size_t end = k + 2 < run.size() ? run[k + 3] : value.size();
        body(row + run[k], value.data() + run[k + 1], end - run[k + 1]);
      }
    };
    each_run([](T* to, const T* from, size_t count) { std::copy(from, from + count, to); });
    struct Clear {  // also when fn throws
      decltype(each_run)& runs;
      ~Clear() {
        runs([](T* to, const T*, size_t count) { std::fill_n(to, count, T(0)); });
      }
    } clear{each_run};
    return fn(static_cast<const T*>(row));
  }

  // Index into the row's `count` values of column j, or SIZE_MAX when j is not stored.
  static size_t find(const std::vector<uint32_t>& run, size_t count, size_t j) {
    size_t lo = 0, hi = run.size() / 2;  // the first run starting after j
    while (lo < hi) {
      const size_t mid = (lo + hi) / 2;
      if (run[2 * mid] <= j)
        lo = mid + 1;
      else
        hi = mid;
    }
    if (lo == 0) return SIZE_MAX;
    const size_t k = 2 * (lo - 1), end = lo < run.size() / 2 ? run[k + 3] : count;
    const size_t index = run[k + 1] + (j - run[k]);
    return index < end ? index : SIZE_MAX;
  }

  template <class T>
  T sparse_at(const std::vector<uint32_t>& run, const std::vector<T>& value, size_t j) const {
    if (run.empty() && value.size() == n_) return value[j];
    const size_t k = find(run, value.size(), j);
    return k == SIZE_MAX ? T(0) : value[k];
  }

  size_t n_ = 0;
  Precision precision_ = Precision::kFloat;
  Layout layout_ = Layout::kDense;
  std::vector<float> f32_;  // dense layout
  std::vector<double> f64_;
  std::vector<SparseRow> rows_;  // sparse layout
};

// The same matrix with its entries rounded to `precision` (to nearest), in the same layout.
FormFactorMatrix convert_precision(const FormFactorMatrix& matrix, Precision precision);

// The same size, precision and entries, bit for bit, whatever the layouts (dense or sparse).
bool identical_entries(const FormFactorMatrix& a, const FormFactorMatrix& b);

struct BuildReport {
  RowCost cost;
  double seconds = 0.0;  // wall time of the build (of the original build when `cached`)
  int threads = 0;
  bool cached = false;        // loaded from the on-disk cache (matrix_cache.h)
  double load_seconds = 0.0;  // time to load and verify the cached file
  std::string cache_file;     // the cache file read or written, if any

  // "12.3 s on 2 threads, 4567 rays, pairs: 1 culled, 2 unoccluded, 3 traced[, from cache ...]"
  std::string summary() const;
};

// Builds every row with TBB. `progress`, if given, is called now and then with rows done.
FormFactorMatrix build_matrix(const FormFactorMethod& method, size_t n, Precision precision,
                              BuildReport& report,
                              const std::function<void(size_t done, size_t total)>& progress = {});
// The same in a chosen layout (sparse: each row stored in the smaller of its two forms as it is
// computed, so the build never holds n^2 numbers).
FormFactorMatrix build_matrix(const FormFactorMethod& method, size_t n, Precision precision,
                              Layout layout, BuildReport& report,
                              const std::function<void(size_t done, size_t total)>& progress = {});

// Rows [first, end) of the same (one block of a blocked build, formfactor/matrix/matrix_blocks.h):
// the other rows stay zero (a sparse matrix: empty). Each row the same bits as build_matrix's.
// `progress` counts the rows of the range.
FormFactorMatrix build_matrix_rows(
    const FormFactorMethod& method, size_t n, size_t first, size_t end, Precision precision,
    Layout layout, BuildReport& report,
    const std::function<void(size_t done, size_t total)>& progress = {});

// Makes A F exactly symmetric (reciprocity to rounding), so that gathering, shooting, conjugate
// gradients and the reference solve one system: A_i F_ij and A_j F_ji become
//
//   G_ij = (A_j^2 (A_i F_ij) + A_i^2 (A_j F_ji)) / (A_i^2 + A_j^2),
//
// the inverse-variance weighting of the two estimates of G. Why: a method's estimate from
// element i's row is worst when j is small — a hemicube hits or misses j by whole pixels, a
// relative error ~ 1/A_j (and the quadrature over i is coarsest when i is large) — so the smaller
// element's row is the better estimate. Equal areas give the plain average. The plain average
// instead lets one aliased pixel of a large element's hemicube on a tiny element swamp the tiny
// element's row: on builtin:office at --subdiv 4 with hemicubes its row sums reached 3.6.
// Each pair is read and written by the task of row min(i, j), so rows run in parallel.
// A sparse matrix first gains the entries (i, j) where only F_ji is non-zero (G_ij > 0 there),
// then every pair is weighted by the same expression: the result equals the dense one bit for bit.
void symmetrise(FormFactorMatrix& matrix, std::span<const double> area);

}  // namespace radlab
