// The discretised radiosity system a solver works on (DESIGN §2):
//
//   B_i = E_i + rho_i * sum_j F_ij B_j      for every element i and colour channel
//
// It holds the per-element areas, reflectances and emissions (one channel when the scene is
// grey, three otherwise) and gives access to rows of F, either from a cached dense matrix or
// computed on the fly by a form-factor method. Every row a solver reads is counted, and rows
// computed on the fly charge their time to the step that asked (the runner's clock is running),
// so "form-factor rows" on every plot axis is honest whichever way the rows come.
//
// The work column common to every solver is "element-pair form factors evaluated"
// (pair_evaluations): a flat row counts n (it holds n pair form factors), and a solver that works
// on other pairs (hierarchical links, patch-to-element rows) charges what it evaluates with
// charge_pair_evaluations(), refinement estimates included.
//
// Shooters (Cohen et al. 1988 §3.4): a shooting solver shoots from "shooters" and reads their
// rows through with_shooter_row(). On a one-level System shooter p is element p and its row is
// F's row p (the same call as with_row). On a two-level System (solvers/two_level/patches.h) the
// shooters are patches: with_row(e) gives K's row e (element e gathering over patches) and
// with_shooter_row(p) the patch-to-element row P_p; both count one row and n pair evaluations.
// A solver written against shooters runs on both without knowing which it has.
//
// A System is immutable during a run except for its counters.
#pragma once

#include <atomic>
#include <memory>
#include <span>
#include <vector>

#include "core/radiosity.h"
#include "formfactor/form_factor_method.h"
#include "formfactor/matrix/matrix.h"
#include "formfactor/matrix/parallel_row.h"
#include "scene/mesh.h"
#include "solvers/kernels/kernels_row.h"
#include "solvers/two_level/patches.h"

namespace radlab {

class System {
 public:
  // Rows from a dense matrix (not owned; must outlive the System).
  System(const Scene& scene, const Mesh& mesh, const FormFactorMatrix& matrix);
  // Rows computed on demand by `method` (not owned).
  System(const Scene& scene, const Mesh& mesh, const FormFactorMethod& method);
  // Two levels: `rows` the patch rows of `patches` and `gather` K's rows from them (TwoLevelRows,
  // solvers/two_level/patch_rows.h), served like rows computed on the fly; none is owned, all must
  // outlive the System.
  System(const Scene& scene, const Mesh& mesh, const FormFactorMethod& gather,
         const Patches& patches, const RowMatrix& rows);

  size_t size() const { return area_.size(); }
  int channels() const { return reflectance_.channels(); }
  const Scene& scene() const { return scene_; }
  const Mesh& mesh() const { return mesh_; }
  std::span<const double> area() const { return area_; }
  std::span<const double> inverse_area() const { return inverse_area_; }
  double total_area() const { return total_area_; }
  const Radiosity& reflectance() const { return reflectance_; }
  const Radiosity& emission() const { return emission_; }
  // The largest reflectance over elements and channels.
  double max_reflectance() const { return max_reflectance_; }

  // Calls fn(const T* row) with row[j] = F_ij, T = float or double; counts one row.
  template <class Fn>
  void with_row(size_t i, Fn&& fn) const {
    rows_used_.fetch_add(1, std::memory_order_relaxed);
    pair_evaluations_.fetch_add(size(), std::memory_order_relaxed);
    if (matrix_) {
      matrix_->visit_row(i, fn);
      return;
    }
    thread_local std::vector<double> scratch;
    scratch.resize(size());
    RowCost cost;
    row_in_parallel(*method_, i, scratch, cost);
    rays_used_.fetch_add(cost.rays, std::memory_order_relaxed);
    fn(static_cast<const double*>(scratch.data()));
  }

  // Rows i and k at once, for kernels that read two rows in one pass (kernels::gather_pair): when
  // both are stored whole in a dense matrix, calls fn(const T* row_i, const T* row_k), counts
  // row i, and row k too unless count_k is false, and returns true; otherwise does nothing and
  // returns false (the caller reads them one at a time). With count_k false the caller charges
  // row k with count_row() at the step that uses its result (Jacobi: one row a step).
  template <class Fn>
  bool with_dense_rows(size_t i, size_t k, Fn&& fn, bool count_k = true) const {
    if (!matrix_ || matrix_->sparse()) return false;
    count_row();
    if (count_k) count_row();
    if (matrix_->precision() == Precision::kFloat)
      fn(matrix_->row_f32(i), matrix_->row_f32(k));
    else
      fn(matrix_->row_f64(i), matrix_->row_f64(k));
    return true;
  }

  // As with_row, but a row that a sparse matrix stores in part is handed over as it is stored:
  // fn(kernels::RunRow<T>) (solvers/kernels_row.h) instead of fn(const T*) with the row expanded
  // into a scratch row of n values. For kernels that take both (kernels::gather, shoot): the same
  // bits, without the scratch's fill and clear and without reading the zeros. fn must accept
  // both kinds (a generic lambda taking `const auto& F`, indexing F[j] only for single entries).
  template <class Fn>
  void with_compact_row(size_t i, Fn&& fn) const {
    if (!matrix_ || !matrix_->sparse() || matrix_->whole_row(i)) return with_row(i, fn);
    rows_used_.fetch_add(1, std::memory_order_relaxed);
    pair_evaluations_.fetch_add(size(), std::memory_order_relaxed);
    const FormFactorMatrix::SparseRow& row = matrix_->sparse_row(i);
    if (matrix_->precision() == Precision::kFloat)
      fn(kernels::RunRow<float>{row.run.data(), row.run.size() / 2, row.f32.data(),
                                row.f32.size()});
    else
      fn(kernels::RunRow<double>{row.run.data(), row.run.size() / 2, row.f64.data(),
                                 row.f64.size()});
  }

  // Shooters: patches on a two-level System, else the elements themselves.
  bool two_level() const { return patch_rows_ != nullptr; }
  const Patches& shooters() const { return *shooters_; }
  // Calls fn(const T* row) with row[e] = the form factor from shooter p to element e; counts one
  // row.
  template <class Fn>
  void with_shooter_row(size_t p, Fn&& fn) const {
    if (!patch_rows_) return with_row(p, fn);
    rows_used_.fetch_add(1, std::memory_order_relaxed);
    pair_evaluations_.fetch_add(size(), std::memory_order_relaxed);
    patch_rows_->visit_row(p, fn);
  }

  // with_shooter_row, with a sparse matrix's rows handed over as stored (with_compact_row).
  template <class Fn>
  void with_compact_shooter_row(size_t p, Fn&& fn) const {
    if (!patch_rows_) return with_compact_row(p, fn);
    with_shooter_row(p, fn);
  }

  // As above, charging `pairs` pair evaluations instead of n on a two-level System: the row read
  // onto coarser receivers (adaptive elements, each a union of the mesh's elements).
  template <class Fn>
  void with_shooter_row(size_t p, uint64_t pairs, Fn&& fn) const {
    if (!patch_rows_) return with_row(p, fn);
    rows_used_.fetch_add(1, std::memory_order_relaxed);
    pair_evaluations_.fetch_add(pairs, std::memory_order_relaxed);
    patch_rows_->visit_row(p, fn);
  }

  // Counts one row read earlier and not yet counted (with_dense_rows with count_k = false).
  void count_row() const {
    rows_used_.fetch_add(1, std::memory_order_relaxed);
    pair_evaluations_.fetch_add(size(), std::memory_order_relaxed);
  }

  // The dense matrix when rows come from one (null when computed on the fly).
  const FormFactorMatrix* matrix() const { return matrix_; }

  uint64_t rows_used() const { return rows_used_.load(); }
  uint64_t rays_used() const { return rays_used_.load(); }
  uint64_t pair_evaluations() const { return pair_evaluations_.load(); }
  // For solvers that evaluate form factors themselves (not through with_row): charges the work
  // to the same counters, so every solver's trace has the same x-axes.
  void charge_pair_evaluations(uint64_t pairs) const {
    pair_evaluations_.fetch_add(pairs, std::memory_order_relaxed);
  }
  void charge_rays(uint64_t rays) const { rays_used_.fetch_add(rays, std::memory_order_relaxed); }
  void reset_counters() const {
    rows_used_ = 0;
    rays_used_ = 0;
    pair_evaluations_ = 0;
  }

 private:
  void init(const Scene& scene);

  const Scene& scene_;
  const Mesh& mesh_;
  const FormFactorMatrix* matrix_ = nullptr;
  const FormFactorMethod* method_ = nullptr;
  const RowMatrix* patch_rows_ = nullptr;
  const Patches* shooters_ = nullptr;
  Patches own_shooters_;  // one per element, on a one-level System
  std::vector<double> area_, inverse_area_;
  double total_area_ = 0.0;
  double max_reflectance_ = 0.0;
  Radiosity reflectance_, emission_;
  mutable std::atomic<uint64_t> rows_used_{0};
  mutable std::atomic<uint64_t> rays_used_{0};
  mutable std::atomic<uint64_t> pair_evaluations_{0};
};

}  // namespace radlab
