#include "experiments/run/trace.h"

namespace radlab {

const std::vector<std::string>& trace_columns() {
  static const std::vector<std::string> columns = {"run_id",
                                                   "scene",
                                                   "solver",
                                                   "params",
                                                   "channel",
                                                   "step",
                                                   "ff_rows",
                                                   "seconds",
                                                   "rms",
                                                   "rms_rel",
                                                   "p_mean",
                                                   "p_rms",
                                                   "p_max",
                                                   "p_over",
                                                   "p_under",
                                                   "p_excluded",
                                                   "rms_display",
                                                   "rms_rel_display",
                                                   "p_mean_display",
                                                   "p_rms_display",
                                                   "p_max_display",
                                                   "residual_inf",
                                                   "bound_inf",
                                                   "unshot_power",
                                                   "total_power",
                                                   "rays",
                                                   "pair_evals",
                                                   "rms_reflected",
                                                   "rms_rel_reflected",
                                                   "reference_kind",
                                                   "solver_elements"};
  return columns;
}

TraceWriter::TraceWriter(const std::string& path) : csv_(path, trace_columns()) {}

void TraceWriter::write(const TraceRow& r) {
  csv_.add(r.run_id).add(r.scene).add(r.solver).add(r.params).add(r.channel);
  csv_.add(r.step).add(r.ff_rows).add(r.seconds);
  csv_.add(r.rms).add(r.rms_rel).add(r.p_mean).add(r.p_rms).add(r.p_max).add(r.p_over);
  csv_.add(r.p_under).add(r.p_excluded);
  csv_.add(r.rms_display).add(r.rms_rel_display).add(r.p_mean_display).add(r.p_rms_display);
  csv_.add(r.p_max_display);
  csv_.add(r.residual_inf).add(r.bound_inf).add(r.unshot_power).add(r.total_power).add(r.rays);
  csv_.add(r.pair_evals).add(r.rms_reflected).add(r.rms_rel_reflected).add(r.reference_kind);
  csv_.add(r.solver_elements);
  csv_.end_row();
}

}  // namespace radlab
