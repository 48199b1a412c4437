// A way of computing form factors, one row at a time (DESIGN §3).
//
// row(i) fills F_i* for every element j: the fraction of power leaving element i that arrives at
// j. Methods are immutable after construction and row() is thread-safe, so a dense matrix is
// built by calling row() from many threads. Each call reports its cost in RowCost.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "core/param_bag.h"
#include "scene/mesh.h"

namespace radlab {

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
};

struct FormFactorMethodInfo {
  std::string name;
  std::string summary;
  std::vector<std::pair<std::string, std::string>> parameters;  // key, "default: help"
};

// The explicit table of methods (for --help and `radlab solvers`, which lists them).
const std::vector<FormFactorMethodInfo>& form_factor_methods();

// Creates a method by name; unknown names or keys are UsageErrors listing the valid ones.
std::unique_ptr<FormFactorMethod> make_form_factor_method(const std::string& name,
                                                          ParamBag& parameters, const Scene& scene,
                                                          const Mesh& mesh);

}  // namespace radlab
