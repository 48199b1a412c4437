#include "formfactor/diagnostics.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace radlab {

MatrixDiagnostics diagnose(const FormFactorMatrix& m, std::span<const double> area) {
  MatrixDiagnostics d;
  const size_t n = m.size();
  d.row_sum_min = n ? 1e300 : 0.0;
  d.row_sum_max = n ? -1e300 : 0.0;
  double largest = 0.0;
  for (size_t i = 0; i < n; ++i) {
    double sum = 0.0;
    for (size_t j = 0; j < n; ++j) {
      double f = m.at(i, j);
      if (!std::isfinite(f)) {
        ++d.non_finite_entries;
        continue;
      }
      if (f < 0) ++d.negative_entries;
      if (f != 0) ++d.nonzero_entries;
      sum += f;
      largest = std::max(largest, area[i] * f);
    }
    d.row_sum_min = std::min(d.row_sum_min, sum);
    d.row_sum_max = std::max(d.row_sum_max, sum);
  }
  for (size_t i = 0; i < n; ++i)
    for (size_t j = i + 1; j < n; ++j) {
      const double a = area[i] * m.at(i, j), b = area[j] * m.at(j, i);
      if (!std::isfinite(a) || !std::isfinite(b)) continue;
      const double defect = std::abs(a - b);
      d.reciprocity_defect = std::max(d.reciprocity_defect, defect);
      const double scale = std::max(a, b);
      if (scale > 1e-12 * largest)
        d.reciprocity_defect_relative = std::max(d.reciprocity_defect_relative, defect / scale);
    }
  return d;
}

std::string MatrixDiagnostics::summary() const {
  char buffer[400];
  std::snprintf(buffer, sizeof buffer,
                "row sums [%.9g, %.9g], reciprocity defect %.3g (relative %.3g), %zu non-zero, "
                "%zu negative, %zu non-finite entries",
                row_sum_min, row_sum_max, reciprocity_defect, reciprocity_defect_relative,
                nonzero_entries, negative_entries, non_finite_entries);
  return buffer;
}

}  // namespace radlab
