#include "experiments/run/coverage.h"

#include "core/csv.h"
#include "metrics/error_metrics.h"

namespace radlab {

bool write_coverage_csv(const std::string& path, const Solver& solver, const Problem& problem,
                        long long step) {
  const ShotCoverage* coverage = solver.shot_coverage();
  if (!coverage || !problem.reference) return false;
  const Radiosity& B = solver.solution();
  const size_t n = B.size();
  const int channels = B.channels();
  std::vector<std::string> columns = {"step", "session", "element", "area",
                                      "dff",  "shot",    "p_mean"};
  if (channels == 3) columns.insert(columns.end(), {"p_r", "p_g", "p_b"});
  std::vector<std::vector<double>> p(channels == 3 ? 4 : 1, std::vector<double>(n));
  relative_errors(B, problem.reference->B, problem.mesh.area, kMeanOfChannels, p[0]);
  if (channels == 3)
    for (int c = 0; c < 3; ++c)
      relative_errors(B, problem.reference->B, problem.mesh.area, c, p[size_t(c) + 1]);
  CsvWriter csv(path, columns);
  for (size_t i = 0; i < n; ++i) {
    csv.add(step).add(coverage->session).add(i).add(problem.mesh.area[i]);
    csv.add(coverage->form_factor_sum[i]).add(int(coverage->shot[i]));
    for (const auto& column : p) csv.add(column[i]);
    csv.end_row();
  }
  csv.close();
  return true;
}

}  // namespace radlab
