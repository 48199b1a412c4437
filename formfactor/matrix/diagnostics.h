// Health of a form-factor matrix: row sums (1 in a closed scene, < 1 where light escapes),
// reciprocity defect (A_i F_ij = A_j F_ji in exact arithmetic), and bad entries.
#pragma once

#include <functional>
#include <span>
#include <string>
#include <vector>

#include "formfactor/form_factor_method.h"
#include "formfactor/matrix/matrix.h"
#include "scene/mesh.h"
#include "scene/scene.h"

namespace radlab {

struct MatrixDiagnostics {
  double row_sum_min = 0.0;
  double row_sum_max = 0.0;
  // max_ij |A_i F_ij - A_j F_ji|, and the same divided by max(A_i F_ij, A_j F_ji) over pairs
  // where that exceeds 1e-12 of the largest A_i F_ij.
  double reciprocity_defect = 0.0;
  double reciprocity_defect_relative = 0.0;
  size_t negative_entries = 0;
  size_t non_finite_entries = 0;
  size_t nonzero_entries = 0;

  std::string summary() const;
};

MatrixDiagnostics diagnose(const FormFactorMatrix& matrix, std::span<const double> area);

// The error a method states for a row sum of its matrix: the method's own
// (FormFactorMethod::stated_row_sum_error; docs/formfactors.md, "Row sums").
double stated_row_sum_error(const FormFactorMethod& method, std::string* basis = nullptr);

// The row-sum check of every matrix build: rows above 1 + the stated error, the worst of them
// with their largest entries, and for each entry what makes it too large.
struct RowSumCheck {
  double stated_error = 0.0;  // the part common to every row
  bool per_row = false;       // plus each row's own allowance (raycast: 5 sigma of its sampling)
  double row_sum_min = 0.0, row_sum_max = 0.0;
  size_t rows_above = 0;  // rows summing above 1 + stated_error (+ the row's allowance)
  struct Entry {
    size_t j = 0;
    double f = 0.0;
    double unoccluded = -1.0;  // F^u_ij when the method can say (raycast), else -1
    std::string cause;         // the pair's classification (see classify in diagnostics.cpp)
  };
  struct Row {
    size_t i = 0;
    double sum = 0.0;
    double allowance = 0.0;      // the row's own allowance (per_row), else 0
    std::vector<Entry> entries;  // largest first
  };
  std::vector<Row> worst;                             // the worst rows, largest sum first
  std::vector<std::pair<std::string, size_t>> tally;  // cause kind -> entries, over all rows above

  bool ok() const { return rows_above == 0; }
  std::string headline() const;  // one line: count, range, stated error
  // Multi-line: the headline, then each worst row and its entries with their polygons.
  std::string report(const Scene& scene, const Mesh& mesh) const;
};

// `unoccluded(i, j)`, if given, returns F^u_ij (raycast: the pair without visibility), which lets
// the check tell partly occluded pairs. Cost: one pass over the matrix, and O(n) per entry named.
RowSumCheck check_row_sums(const FormFactorMatrix& matrix, const Scene& scene, const Mesh& mesh,
                           double stated_error,
                           const std::function<double(size_t, size_t)>& unoccluded = {},
                           size_t worst_rows = 5, size_t entries_per_row = 4,
                           const std::function<double(size_t)>& row_allowance = {});

// The check with the method's own stated error: a method that states row allowances
// (FormFactorMethod::states_row_allowances; raycast: each row's visibility sampling) is held to
// its common part plus each row's allowance (asked only for rows above the common part), the
// others to stated_row_sum_error(); F^u classifies entries where the method gives it.
RowSumCheck check_row_sums(const FormFactorMatrix& matrix, const Scene& scene, const Mesh& mesh,
                           const FormFactorMethod& method);

// The same verdict from row sums alone, with the method's limits as above (when no matrix is held:
// rows on the fly, checked from their one streamed pass): counts and range, no rows classified.
RowSumCheck check_row_sums(std::span<const double> sums, const FormFactorMethod& method);

// The power emitters send by their rows against what the matrix lets every element gather from
// them (sum_j E_j A_j sum_i F_ji against sum_j E_j sum_i A_i F_ij, equal under reciprocity). A
// reference solved by gathering sees only the second: a matrix whose rows miss a small lamp
// (raw hemicubes) solves to a black room. Returns gathered / sent (1 when reciprocal), or 1 when
// nothing emits.
double emitted_power_ratio(const FormFactorMatrix& matrix, const Scene& scene, const Mesh& mesh);

// How well the rows sample the emitters, over every row (FormFactorMethod::row_emitter_sampling):
// the stated error of the direct light the elements gather, area-weighted (of the power gathered,
// sum_i A_i e_i / sum_i A_i g°_i) and at the worst element among those that gather at least 1e-3
// of the brightest one's direct light (smaller ones are covered by the area-weighted figure).
struct EmitterSamplingReport {
  bool stated = false;    // the method states it, for every row
  double relative = 0.0;  // of the power the elements gather directly
  double worst_relative = 0.0;
  size_t worst_element = 0;
  // "the hemicube samples the emitters to 3.1% of the direct power gathered (worst: element 17,
  // 24%)"
  std::string text() const;
};
EmitterSamplingReport emitter_sampling_report(const FormFactorMethod& method, const Mesh& mesh);

}  // namespace radlab
