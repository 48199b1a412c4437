// The two-level stages of prepare_problem (see two_level_problem.h).
#include "experiments/problem/two_level_problem.h"

#include <cstdio>

#include "core/error.h"
#include "core/limits.h"
#include "core/log.h"
#include "core/progress.h"
#include "formfactor/matrix/diagnostics.h"
#include "metrics/error_metrics.h"
#include "solvers/two_level/patch_rows.h"
#include "solvers/two_level/two_level_adaptive.h"
#include "solvers/two_level/two_level_reference.h"

namespace radlab {

namespace {

// The float storage of double patch rows: every entry rounded to nearest.
RowMatrix round_rows_to_float(const RowMatrix& rows) {
  RowMatrix out(rows.rows(), rows.columns(), Precision::kFloat);
  for (size_t p = 0; p < rows.rows(); ++p)
    for (size_t e = 0; e < rows.columns(); ++e) out.set(p, e, rows.at(p, e));
  return out;
}

}  // namespace

void two_level_patch_rows(Problem& problem) {
  const ProblemSpec& spec = problem.spec;
  const size_t n = problem.mesh.size();
  problem.patches = make_patches(problem.scene(), problem.mesh, spec.patches);
  const size_t P = problem.patches.size();
  check_limit("memory_gb", double(P) * double(n) * 8.0,
              problem.scene().name + ": the patch rows of " + std::to_string(P) + " patches to " +
                  std::to_string(n) + " elements");
  const std::string rule_name = spec.patches.resolved_rows(spec.ff_method);
  const PatchRowRule rule = patch_row_rule(rule_name);
  PatchRowReport& report = problem.patch_row_report;
  {
    Progress progress(
        "patch rows (" + spec.ff_method + ", " + rule_name + ", " + std::to_string(P) + " patches)",
        "patches", double(P));
    // In double: the reference certifies these numbers; float storage is their rounding.
    problem.certified_patch_rows =
        compute_patch_rows(*problem.method, problem.mesh, problem.patches, rule, Precision::kDouble,
                           report, [&](size_t done, size_t) { progress.update(double(done)); });
    progress.finish(std::to_string(report.method_rows) + " method rows");
  }
  problem.build.cost = report.cost;
  problem.build.seconds = report.seconds;
  log::info("two levels: " + std::to_string(P) + " patches (" + spec.patches.canonical() +
            (spec.patches.rows == "auto" ? ", rows " + rule_name : std::string()) + ") shoot to " +
            std::to_string(n) + " elements; largest patch " +
            std::to_string(problem.patches.largest()) + " elements; " + report.summary());
}

void check_two_level_rows(const Problem& problem, bool accept_unphysical) {
  const PatchRowReport& report = problem.patch_row_report;
  const double stated = stated_row_sum_error(*problem.method);
  if (report.max_row_sum > 1.0 + stated) {
    char buffer[300];
    std::snprintf(buffer, sizeof buffer,
                  "a patch row sums to %.6g, above 1 + the method's stated error %.3g",
                  report.max_row_sum, stated);
    if (!accept_unphysical)
      throw NumericalError(std::string("refusing to solve: the patch rows are unphysical: ") +
                           buffer + "; --ff-set unphysical=accept solves it anyway");
    log::warning(std::string("solving anyway (unphysical=accept): ") + buffer);
  }
  if (report.max_gather_sum > 1.0 + stated)
    log::info(
        "two levels: element-to-patch factors by reciprocity (P_pe A_p / A_e) sum to at "
        "most " +
        std::to_string(report.max_gather_sum) +
        " at an element (a patch's aliasing on a small element, scaled by A_p / A_e; "
        "docs/solvers.md); shooting conserves light whatever this is");
}

void two_level_reference(Problem& problem, bool accept_unphysical) {
  const ProblemSpec& spec = problem.spec;
  {
    Progress progress("two-level reference (" + std::to_string(problem.mesh.size()) +
                          " elements, rank " + std::to_string(problem.patches.size()) + ")",
                      "", 0);
    // The certified system is K of the double rows; a System on them gives rho and E.
    TwoLevelRows certified_gather(problem.mesh, problem.patches, problem.certified_patch_rows);
    System certified(problem.scene(), problem.mesh, certified_gather, problem.patches,
                     problem.certified_patch_rows);
    problem.reference =
        compute_two_level_reference(certified, problem.patches, problem.certified_patch_rows);
    progress.finish();
  }
  const double stated = stated_row_sum_error(*problem.method);
  problem.reference->system =
      "two levels: K of " + spec.patches.canonical() + ", patch rows " +
      spec.patches.resolved_rows(spec.ff_method) + " of " + spec.ff_method +
      " in double precision (docs/solvers.md, \"Two levels\")" +
      (spec.precision == Precision::kFloat ? "; solvers read the rows rounded to float" : "") +
      (accept_unphysical && problem.patch_row_report.max_row_sum > 1.0 + stated
           ? "; UNPHYSICAL: patch rows above 1 + the method's stated error, accepted with "
             "unphysical=accept"
           : "");
  log::info("reference: " + problem.reference->summary());
}

void two_level_system(Problem& problem) {
  if (problem.spec.precision == Precision::kFloat)
    problem.patch_rows = round_rows_to_float(problem.certified_patch_rows);
  else
    problem.patch_rows = problem.certified_patch_rows;
  problem.gather_rows =
      std::make_unique<TwoLevelRows>(problem.mesh, problem.patches, problem.patch_rows);
  problem.system = std::make_unique<System>(problem.scene(), problem.mesh, *problem.gather_rows,
                                            problem.patches, problem.patch_rows);
}

std::vector<std::pair<std::string, double>> final_system_statistics(const Problem& problem,
                                                                    const Solver& solver) {
  if (!problem.system || !problem.system->two_level() || !problem.reference) return {};
  const std::vector<uint32_t> blocks = adaptive_blocks(solver);
  if (blocks.size() != problem.mesh.size()) return {};
  const RowMatrix rows = block_rows(problem.certified_patch_rows, problem.mesh.area, blocks);
  TwoLevelRows gather(problem.mesh, problem.patches, rows);
  const System system(problem.scene(), problem.mesh, gather, problem.patches, rows);
  const Reference final_reference = compute_two_level_reference(system, problem.patches, rows);
  const auto area = problem.system->area();
  return {
      {"final_system_rms_rel_to_fine",
       compare(final_reference.B, problem.reference->B, area, kMeanOfChannels).rms_rel},
      {"rms_rel_to_final_system",
       compare(solver.solution(), final_reference.B, area, kMeanOfChannels).rms_rel},
      {"final_system_bound_relative", final_reference.bound_relative},
  };
}

std::vector<double> two_level_residual(const Problem& problem, const Radiosity& B) {
  return two_level_residual_inf(*problem.system, problem.patches, problem.certified_patch_rows, B);
}

}  // namespace radlab
