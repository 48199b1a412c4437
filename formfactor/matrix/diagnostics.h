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

// The error a method states for a row sum of its matrix (docs/formfactors.md, "Row sums"): a
// row of planar polygons sums to at most 1, so a row above 1 + this is a defect of the input or
// of the method, not noise. `basis` (if given) receives how the number is made up. For raycast
// it holds the largest per-row visibility term of the rows computed so far (each row is checked
// against its own by the check_row_sums overload taking the method).
double stated_row_sum_error(const FormFactorMethod& method, std::string* basis = nullptr);

// How many standard errors of a row's visibility sampling its stated error allows: with rows
// checked one by one, a Gaussian tail of 2.9e-7 per row (under 1% over 24,000 rows).
inline constexpr double kRowSamplingSigmas = 5.0;

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

// The check with the method's own stated error: for raycast, quadrature tolerance and float
// storage for every row plus kRowSamplingSigmas standard errors of that row's visibility sampling
// (RaycastFormFactors::row_sampling_error; asked only for rows above the common part), and F^u
// for the classification; for the other methods the scalar stated_row_sum_error.
RowSumCheck check_row_sums(const FormFactorMatrix& matrix, const Scene& scene, const Mesh& mesh,
                           const FormFactorMethod& method);

// The power emitters send by their rows against what the matrix lets every element gather from
// them (sum_j E_j A_j sum_i F_ji against sum_j E_j sum_i A_i F_ij, equal under reciprocity). A
// reference solved by gathering sees only the second: a matrix whose rows miss a small lamp
// (raw hemicubes) solves to a black room. Returns gathered / sent (1 when reciprocal), or 1 when
// nothing emits.
double emitted_power_ratio(const FormFactorMatrix& matrix, const Scene& scene, const Mesh& mesh);

}  // namespace radlab
