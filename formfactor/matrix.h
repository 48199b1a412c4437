// A dense form-factor matrix, row-major, in float (default: half the memory and bandwidth) or
// double. Solvers read rows through visit_row(), which hands the kernel a typed pointer, so one
// templated kernel serves both precisions with no per-element branching.
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "formfactor/form_factor_method.h"

namespace radlab {

enum class Precision { kFloat, kDouble };

class FormFactorMatrix {
 public:
  FormFactorMatrix() = default;
  FormFactorMatrix(size_t n, Precision precision);

  size_t size() const { return n_; }
  Precision precision() const { return precision_; }
  size_t bytes() const;
  // The n*n entries, row-major, as raw bytes (for the cache).
  const void* data() const;
  void* data();

  const float* row_f32(size_t i) const { return f32_.data() + i * n_; }
  const double* row_f64(size_t i) const { return f64_.data() + i * n_; }
  float* row_f32(size_t i) { return f32_.data() + i * n_; }
  double* row_f64(size_t i) { return f64_.data() + i * n_; }

  // Calls fn(const T* row) with T = float or double.
  template <class Fn>
  decltype(auto) visit_row(size_t i, Fn&& fn) const {
    if (precision_ == Precision::kFloat) return fn(row_f32(i));
    return fn(row_f64(i));
  }

  double at(size_t i, size_t j) const {
    return precision_ == Precision::kFloat ? double(f32_[i * n_ + j]) : f64_[i * n_ + j];
  }
  void set(size_t i, size_t j, double value) {
    if (precision_ == Precision::kFloat)
      f32_[i * n_ + j] = float(value);
    else
      f64_[i * n_ + j] = value;
  }
  void set_row(size_t i, std::span<const double> values);

 private:
  size_t n_ = 0;
  Precision precision_ = Precision::kFloat;
  std::vector<float> f32_;
  std::vector<double> f64_;
};

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
void symmetrise(FormFactorMatrix& matrix, std::span<const double> area);

}  // namespace radlab
