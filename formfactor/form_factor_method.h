// A way of computing form factors, one row at a time (DESIGN §3).
//
// row(i) fills F_i* for every element j: the fraction of power leaving element i that arrives at
// j. Methods are immutable after construction and row() is thread-safe, so a dense matrix is
// built by calling row() from many threads. Each call reports its cost in RowCost.
//
// Everything code outside a method asks of it is a virtual function here: its stated errors
// (row sums, reciprocity), side files kept beside a cached matrix, rows at a point (two levels'
// patch rows), symmetric builds. No code outside a method names a concrete one; methods are
// created through the registry (formfactor/registry.h), built-in or from a plugin.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "core/param_bag.h"
#include "scene/mesh.h"

namespace radlab {

// What float storage adds to a row sum's error: each entry rounded by 2^-24 relative moves a row
// sum by at most 6e-8 of itself.
inline constexpr double kFloatStorageRowError = 1e-7;

// How many standard errors of a row's sampling (visibility rays, Monte Carlo points) a stated
// row error allows: with rows checked one by one, a Gaussian tail of 2.9e-7 per row (under 1%
// over 24,000 rows).
inline constexpr double kRowSamplingSigmas = 5.0;

struct RowCost {
  uint64_t rays = 0;                // visibility rays cast
  uint64_t kernel_evaluations = 0;  // point-to-polygon (or pixel) evaluations
  uint64_t pairs_culled = 0;        // facing away or coplanar: cost nothing
  uint64_t pairs_unoccluded = 0;    // no visibility work needed (no possible occluder)
  uint64_t pairs_traced = 0;        // pairs that needed visibility rays

  RowCost& operator+=(const RowCost& o) {
    rays += o.rays;
    kernel_evaluations += o.kernel_evaluations;
    pairs_culled += o.pairs_culled;
    pairs_unoccluded += o.pairs_unoccluded;
    pairs_traced += o.pairs_traced;
    return *this;
  }
};

class FormFactorMethod {
 public:
  virtual ~FormFactorMethod() = default;
  virtual std::string name() const = 0;
  // Resolved parameters, canonical "k=v,..." (for run.json and cache keys).
  virtual std::string parameters() const = 0;
  // Human-readable notes on work the scene let the method leave out.
  virtual std::vector<std::string> left_out() const { return {}; }
  // Fills out[j] = F_ij for all j (out.size() == mesh size). Thread-safe.
  virtual void row(size_t i, std::span<double> out, RowCost& cost) const = 0;
  // The receivers [lo, hi) of row i alone: out[j] = F_ij for j in [lo, hi), the same bits as
  // row() gives them, other entries untouched; thread-safe. A method whose row is one indivisible
  // computation (the hemicube's z-buffer) returns false and does nothing; row_in_parallel
  // (formfactor/matrix/parallel_row.h) then calls row().
  virtual bool row_part(size_t /*i*/, size_t /*lo*/, size_t /*hi*/, std::span<double> /*out*/,
                        RowCost& /*cost*/) const {
    return false;
  }
  // Bracket a computation of every row (build_matrix): between them a method may keep work that
  // the other row of a pair can reuse (raycast keeps V_ij for V_ji). Results are the same as
  // row by row; only the cost changes. Not thread-safe themselves.
  virtual void begin_all_rows() const {}
  virtual void end_all_rows() const {}

  // ---- What code outside a method asks of it (nothing outside a method names one) ----

  // The error the method states for a row sum of its matrix (docs/formfactors.md, "Row sums"):
  // a row of planar polygons sums to at most 1, so a row above 1 + this is a defect of the input
  // or of the method, not noise. It covers every row computed so far in this process (or
  // restored from side files): raycast's visibility sampling and exact's capped pairs are known
  // only then. `basis`, if given, receives how the number is made up.
  virtual double stated_row_sum_error(std::string* basis = nullptr) const = 0;
  // Methods whose rows carry errors of their own (raycast: each row's visibility sampling) state
  // a part common to every row and each row's allowance on top; the row-sum check then holds row
  // i to 1 + common + allowance(i), asked only for rows above the common part (it may compute
  // the row). Others hold every row to stated_row_sum_error().
  virtual bool states_row_allowances() const { return false; }
  virtual double row_sum_error_common() const { return stated_row_sum_error(); }
  virtual double row_sum_allowance(size_t /*i*/) const { return 0.0; }
  // The relative reciprocity defect the method states, e with |A_i F_ij - A_j F_ji| <=
  // e (A_i F_ij + A_j F_ji) for every pair computed so far; or nullopt when it states none (a
  // hemicube's aliasing, a rule taken at one point of the source).
  virtual std::optional<double> stated_reciprocity_error() const { return std::nullopt; }
  // Methods that sample each source from one point at a finite resolution (a hemicube's pixels)
  // state how well row i samples the emitters, measured on each emitting polygon's unoccluded
  // footprint against the exact point form factor the method approximates (its limit at infinite
  // resolution): `error` = sum over emitting polygons P of |sum_{j in P} L_j (F~_ij - F°_ij)|
  // and `exact` = sum_{j emitting} L_j F°_ij, with L_j element j's mean emission over channels and
  // F~ the footprint's sampled value before occlusion. Both NaN until row i is computed (or
  // restored from side files); nullopt from methods that state no such error (rows that
  // integrate over the source carry their errors in the row sums).
  struct EmitterSampling {
    double error = 0.0;
    double exact = 0.0;
  };
  virtual std::optional<EmitterSampling> row_emitter_sampling(size_t /*i*/) const {
    return std::nullopt;
  }
  // F_ij without visibility when the method can say (the row-sum report tells partly occluded
  // pairs by it), else -1.
  virtual double unoccluded_pair(size_t /*i*/, size_t /*j*/) const { return -1.0; }

  // Side files kept beside a cached matrix file (`matrix_file` + a suffix of the method's): what
  // the stated error of a loaded matrix needs and the matrix does not hold (raycast's per-row
  // sampling errors, exact's capped pairs). save_ writes them after the matrix is stored;
  // load_ restores them when the matrix is loaded, and returns false when the cached matrix must
  // not be used without them (it is then rebuilt). Not thread-safe.
  virtual void save_side_files(const std::string& /*matrix_file*/) const {}
  virtual bool load_side_files(const std::string& /*matrix_file*/, size_t /*n*/) const {
    return true;
  }

  // Blocked builds (formfactor/matrix/matrix_blocks.h): whether the matrix may be built as
  // blocks of rows, each by an independent process, and merged. Not for a method built in
  // blocks of pairs (below), nor one that integrates each pair once without saying how (its rows
  // share pair integrals: blocks of rows would integrate each pair twice), nor one with side
  // files other than row side files (below).
  virtual bool builds_in_row_blocks() const {
    return !integrates_pairs_once() && !builds_in_pair_blocks();
  }
  // Blocks of pairs: a method whose F_ij and F_ji share the pair's work (raycast: one
  // visibility estimate and one quadrature; exact: one integral) computes them together, so a
  // block of the unordered pairs (i, j > i), i in a range, computes each pair once:
  //   pair_entries(i):  upper[j] = F_ij and lower[j] = F_ji for every j in (i, n), the same bits
  //                     as row(i)[j] and row(j)[i] (other entries untouched); the pairs' classes
  //                     counted for both entries, their work (rays, kernel evaluations) once.
  //                     Thread-safe; it also adds the pairs' share of each row's side values
  //                     (raycast: each row's sampling variance) to the method's state.
  //   pair_block_state(): that state as bytes (pair_block_state_bytes(n) of them), kept beside
  //                     the block file;
  //   restore_pair_block_states(): the state of every block added up (the merge): afterwards
  //                     save_side_files() writes what a one-process build writes. False when a
  //                     state is not one the method wrote (nothing changed).
  virtual bool builds_in_pair_blocks() const { return false; }
  virtual void pair_entries(size_t i, std::span<double> upper, std::span<double> lower,
                            RowCost& cost) const;
  // Blocks of equal estimated work (matrix_blocks.h pair_split): the work of each row's pairs
  // (i, j > i), estimated from a fixed sample of them, in the method's units. Empty row_weight:
  // every pair the same work (blocks of equal pair counts). Every block, the merge and the plan
  // compute it anew and must cut the same rows, so it must be deterministic and the same bits
  // for any thread count; and cheap (seconds at 50,000 elements). row_facing[i] counts the
  // sampled pairs of row i that can hold a non-zero entry (both elements in front of each
  // other), for the memory estimate; `sample` is how many pairs one sampled pair stands for.
  struct PairWork {
    std::vector<uint64_t> row_weight;
    std::vector<uint32_t> row_facing;
    uint32_t sample = 1;
    std::string unit;               // what a unit of weight is, for the plan
    double seconds_per_unit = 0.0;  // CPU seconds a unit of weight takes (calibration)
  };
  virtual PairWork pair_work() const { return {}; }
  virtual size_t pair_block_state_bytes(size_t /*n*/) const { return 0; }
  virtual std::vector<char> pair_block_state() const { return {}; }
  virtual bool restore_pair_block_states(const std::vector<std::vector<char>>& /*states*/) const {
    return true;
  }
  // Side files (save_side_files) whose payload is `arrays` arrays of n floats, one value per row
  // in each (raycast's ".sigma", the hemicube's ".emitters"): the merge of a blocked build takes
  // each row's values from the side file beside the block that computed the row.
  struct RowSideFile {
    std::string suffix;
    size_t arrays = 0;
  };
  virtual std::vector<RowSideFile> row_side_files() const { return {}; }

  // The row from a point on element `element`'s surface (its plane and frame) other than its
  // centroid, out[j] = F from that point to j, elements in the point's plane left out; false
  // (and nothing done) when the method's rows are not taken at a point (it integrates over the
  // source). Two levels' patch rows "centre" (solvers/two_level/patch_rows.h). Thread-safe.
  virtual bool row_at_point(const Vec3& /*eye*/, size_t /*element*/, std::span<double> /*out*/,
                            RowCost& /*cost*/) const {
    return false;
  }

  // Symmetric builds (formfactor/matrix/symmetric_build.h): a method whose F_ij and F_ji come
  // from one integral of the unordered pair says so, and gives
  //   upper_row(i):  row[j] for j > i, the pair's integral over its integrated side (other
  //                  entries untouched), thread-safe;
  //   orient_row(i): row i of the matrix from the pair values (row[j] of pair (min, max)), the
  //                  same bits as row(i).
  virtual bool integrates_pairs_once() const { return false; }
  virtual void upper_row(size_t i, std::span<double> row, RowCost& cost) const;
  virtual void orient_row(size_t /*i*/, std::span<double> /*row*/) const {}
};

}  // namespace radlab
