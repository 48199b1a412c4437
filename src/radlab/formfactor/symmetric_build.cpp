#include "radlab/formfactor/symmetric_build.h"

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <chrono>

namespace radlab {

FormFactorMatrix build_matrix_symmetric(const ExactFormFactors& method, const Mesh& mesh,
                                        Precision precision, BuildReport& report) {
  const size_t n = mesh.size();
  const auto start = std::chrono::steady_clock::now();
  FormFactorMatrix matrix(n, precision);
  tbb::combinable<RowCost> costs;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1), [&](const tbb::blocked_range<size_t>& r) {
    RowCost& cost = costs.local();
    for (size_t i = r.begin(); i != r.end(); ++i)
      for (size_t j = i + 1; j < n; ++j) {
        // Integrate over the smaller element; the other entry by reciprocity.
        const bool from_i = mesh.area[i] <= mesh.area[j];
        const size_t a = from_i ? i : j, b = from_i ? j : i;
        const double f = method.pair(a, b, cost);
        matrix.set(a, b, f);
        matrix.set(b, a, f * (mesh.area[a] / mesh.area[b]));
      }
  });
  report.cost = costs.combine([](RowCost x, const RowCost& y) { return x += y; });
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  report.threads =
      int(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
  return matrix;
}

}  // namespace radlab
