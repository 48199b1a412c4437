// Health of a form-factor matrix: row sums (1 in a closed scene, < 1 where light escapes),
// reciprocity defect (A_i F_ij = A_j F_ji in exact arithmetic), and bad entries.
#pragma once

#include <span>
#include <string>

#include "formfactor/matrix.h"

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

}  // namespace radlab
