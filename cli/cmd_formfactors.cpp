// `radlab formfactors SCENE --out F.csv`: computes the form-factor matrix, prints its diagnostics
// and writes the non-zero entries as CSV `i,j,F` (element ids in input order).
#include <cstdio>

#include "cli/cli_common.h"
#include "radlab/core/csv.h"
#include "radlab/core/log.h"
#include "radlab/core/output_file.h"

namespace radlab::cli {

void add_formfactors_command(CLI::App& app) {
  auto* command = app.add_subcommand("formfactors", "compute a form-factor matrix and check it");
  auto scene = std::make_shared<SceneOptions>();
  auto ff = std::make_shared<FormFactorOptions>();
  auto out = std::make_shared<std::string>();
  add_scene_options(*command, *scene);
  add_form_factor_options(*command, *ff, false);
  command->add_option("--out", *out, "CSV of the non-zero entries: i,j,F");
  command->callback([scene, ff, out]() {
    if (!out->empty()) check_writable(*out);  // before the computation, not after it
    ProblemSpec spec = make_spec(*scene, *ff);
    spec.need_reference = false;
    spec.require_emitter = false;
    auto problem = prepare_problem(spec);
    std::printf("method       %s (%s)\n", spec.ff_method.c_str(), problem->ff_parameters.c_str());
    std::printf("elements     %zu\n", problem->mesh.size());
    const ValidationReport& report = problem->loaded.report;
    std::printf(
        "repairs      %d degenerate polygons dropped, %d split into triangles, %d coincident "
        "same-facing overlaps removed (%d polygons dropped, %d cut), %d back-to-back kept, %d "
        "face-to-face contacts %s (%.4g m^2)\n",
        report.dropped, report.triangulated, report.overlaps.same_facing, report.overlaps.dropped,
        report.overlaps.clipped, report.overlaps.back_to_back, report.overlaps.contacts,
        spec.keep_overlaps ? "kept (--keep-overlaps)" : "removed from both",
        report.overlaps.contact_area);
    std::printf(
        "time         %.3f s on %d threads%s\n", problem->build.seconds, problem->build.threads,
        problem->build.cached
            ? (" (when built; loaded now from the cache " + problem->build.cache_file + ")").c_str()
            : "");
    std::printf("rays         %llu\n", static_cast<unsigned long long>(problem->build.cost.rays));
    std::printf("pairs        %llu culled (facing away / coplanar), %llu unoccluded, %llu traced\n",
                static_cast<unsigned long long>(problem->build.cost.pairs_culled),
                static_cast<unsigned long long>(problem->build.cost.pairs_unoccluded),
                static_cast<unsigned long long>(problem->build.cost.pairs_traced));
    if (problem->ff_parameters.find("symmetrise=true") != std::string::npos) {
      std::printf("computed     %s\n", problem->raw_diagnostics.summary().c_str());
      std::printf("symmetrised  %s\n", problem->diagnostics.summary().c_str());
    } else {
      std::printf("diagnostics  %s\n", problem->diagnostics.summary().c_str());
    }
    // The row-sum check (src/radlab/formfactor/diagnostics.h): rows above 1 + the method's stated
    // error, with the worst rows' largest entries, their polygons and what makes each too large.
    std::string basis;
    stated_row_sum_error(*problem->method, &basis);
    std::printf("stated error %s\n", basis.c_str());
    std::printf("row sums     %s\n",
                problem->row_sums.report(problem->scene(), problem->mesh).c_str());
    if (problem->ff_parameters.find("symmetrise=true") != std::string::npos &&
        !problem->used_row_sums.ok())
      std::printf("symmetrised  %s\n",
                  problem->used_row_sums.report(problem->scene(), problem->mesh).c_str());
    for (const std::string& note : problem->method->left_out())
      std::printf("left out     %s\n", note.c_str());
    if (!out->empty()) {
      ensure_parent_folder(*out);
      CsvWriter csv(*out, {"i", "j", "F"});
      const FormFactorMatrix& m = problem->matrix;
      for (size_t i = 0; i < m.size(); ++i)
        for (size_t j = 0; j < m.size(); ++j)
          if (double f = m.at(i, j); f != 0.0) csv.add(i).add(j).add(f).end_row();
      csv.close();
      log::info("wrote " + *out);
    }
  });
}

}  // namespace radlab::cli
