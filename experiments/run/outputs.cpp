#include "experiments/run/outputs.h"

#include <tbb/global_control.h>
#include <tbb/info.h>

#include <cmath>
#include <cstdio>

#include "core/csv.h"
#include "core/text.h"
#include "core/version.h"
#include "experiments/problem/two_level_problem.h"
#include "formfactor/matrix/matrix_cache.h"
#include "solvers/registry.h"

#ifndef RADLAB_BUILD_TYPE
#define RADLAB_BUILD_TYPE "unknown"
#endif

namespace radlab {

void write_radiosity_csv(const std::string& path, const Mesh& mesh, const Radiosity& B) {
  CsvWriter csv(path, {"element", "area", "B_r", "B_g", "B_b"});
  for (size_t i = 0; i < B.size(); ++i) {
    const auto rgb = B.rgb(i);
    csv.add(i).add(mesh.area[i]).add(rgb.x).add(rgb.y).add(rgb.z).end_row();
  }
  csv.close();
}

void write_build_info(JsonWriter& json) {
  json.key("build").begin_object();
  json.field("radlab_version", kVersion);
  json.field("git_sha", build_git_sha());
  json.field("source_hash", formfactor_code_version());
  json.field("compiler", std::string("g++ ") + __VERSION__);
  json.field("build_type", RADLAB_BUILD_TYPE);
  json.field("threads",
             int(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism)));
  json.end_object();
}

namespace {

void write_scene_info(JsonWriter& json, const Problem& p) {
  json.key("scene").begin_object();
  json.field("spec", p.spec.scene);
  json.field("polygons", p.scene().polygons.size());
  json.field("emitters", p.scene().emitter_count());
  json.field("channels", p.system->channels());
  json.field("grey", p.scene().is_grey());
  json.field("polygons_dropped", p.loaded.report.dropped);
  json.field("polygons_split", p.loaded.report.triangulated);
  // Every file the scene was read from, with the SHA-256 of the bytes read (Scene::sources).
  json.key("files").begin_array();
  for (const SourceFile& f : p.scene().sources) {
    json.begin_object();
    json.field("path", f.path);
    json.field("sha256", f.sha256);
    json.end_object();
  }
  json.end_array();
  json.end_object();
}

void write_mesh_info(JsonWriter& json, const Problem& p) {
  json.key("mesh").begin_object();
  json.field("subdivisions", p.spec.mesh.subdivisions);
  json.field("element_size", p.spec.mesh.element_size);
  json.field("elements", p.mesh.size());
  json.field("total_area", p.mesh.total_area);
  json.end_object();
}

// The form factors: method, storage, and the cost and diagnostics of the patch rows (two levels)
// or of the matrix build.
void write_form_factor_info(JsonWriter& json, const Problem& p) {
  json.key("form_factors").begin_object();
  json.field("method", p.spec.ff_method);
  json.field("parameters", p.ff_parameters);
  json.field("precision", p.spec.precision == Precision::kFloat ? "float" : "double");
  json.field("rows", p.spec.row_mode == RowMode::kCached ? "cached" : "on-the-fly");
  // What preparing the problem did (problem.h): whether a matrix was built, loaded or neither.
  json.key("preparation").begin_array();
  for (const std::string& stage : p.preparation) json.value(stage);
  json.end_array();
  if (p.system && p.system->two_level()) {  // the patch rows' cost (solvers/two_level/patch_rows.h)
    json.field("patch_rows", p.spec.patches.resolved_rows(p.spec.ff_method));
    json.field("patch_rows_method_rows",
               static_cast<unsigned long long>(p.patch_row_report.method_rows));
    json.field("patch_rows_seconds", p.patch_row_report.seconds);
    json.field("patch_row_sum_max", p.patch_row_report.max_row_sum);
    json.field("element_to_patch_sum_max", p.patch_row_report.max_gather_sum);
  }
  if (p.has_matrix()) {
    json.field("build_seconds", p.build.seconds);
    json.field("threads", p.build.threads);
    json.field("rays", static_cast<unsigned long long>(p.build.cost.rays));
    json.field("kernel_evaluations",
               static_cast<unsigned long long>(p.build.cost.kernel_evaluations));
    json.field("pairs_culled", static_cast<unsigned long long>(p.build.cost.pairs_culled));
    json.field("pairs_unoccluded", static_cast<unsigned long long>(p.build.cost.pairs_unoccluded));
    json.field("pairs_traced", static_cast<unsigned long long>(p.build.cost.pairs_traced));
    json.field("row_sum_min", p.diagnostics.row_sum_min);
    json.field("row_sum_max", p.diagnostics.row_sum_max);
    json.field("reciprocity_defect", p.diagnostics.reciprocity_defect);
    json.field("reciprocity_defect_relative", p.diagnostics.reciprocity_defect_relative);
    json.field("negative_entries", p.diagnostics.negative_entries);
    json.field("non_finite_entries", p.diagnostics.non_finite_entries);
    // The method's own defects, before symmetrising (equal to the above when not symmetrised).
    json.field("computed_row_sum_min", p.raw_diagnostics.row_sum_min);
    json.field("computed_row_sum_max", p.raw_diagnostics.row_sum_max);
    json.field("computed_reciprocity_defect_relative",
               p.raw_diagnostics.reciprocity_defect_relative);
  }
  if (p.emitter_sampling.stated) {  // FormFactorMethod::row_emitter_sampling
    json.field("emitter_sampling_error", p.emitter_sampling.relative);
    json.field("emitter_sampling_worst", p.emitter_sampling.worst_relative);
    json.field("emitter_sampling_worst_element",
               static_cast<unsigned long long>(p.emitter_sampling.worst_element));
  }
  json.end_object();
}

// The work the scene let radlab skip.
void write_left_out(JsonWriter& json, const Problem& p) {
  std::vector<std::string> left_out = p.method->left_out();
  if (p.scene().is_grey()) left_out.push_back("colour: one channel (every rho and E is grey)");
  if (p.system && p.system->two_level())
    left_out.push_back("dense matrix: none (two levels: P x n patch rows, K's rows from them)");
  else if (!p.has_matrix())
    left_out.push_back(
        p.reference && p.reference->kind == "certified"
            ? "dense matrix: none (rows streamed; the cached reference certified "
              "against them or their stored residual pass; the solver's own error is "
              "not certified at checkpoints)"
            : "dense matrix: none (rows streamed, no reference)");
  json.field("left_out", left_out);
}

void write_reference_info(JsonWriter& json, const Problem& p) {
  if (!p.reference) return;
  const Reference& r = *p.reference;
  json.key("reference").begin_object();
  json.field("kind", r.kind);
  json.field("method", r.method);
  if (r.kind != "certified") {  // a stand-in: no bound to report, none implied
    json.field("seconds", r.seconds);
    json.end_object();
    return;
  }
  json.field("certified_system", r.system);
  json.field("bound_inf", r.bound_inf);
  json.field("bound_relative", r.bound_relative);
  json.field("residual_inf", r.residual_inf);
  json.field("inverse_norm_bound", r.inverse_norm_bound);
  json.field("q", r.q);
  json.field("spectral_radius_upper", r.spectral_radius_upper);
  json.field("refinements", r.refinements);
  json.field("seconds", r.seconds);
  // With float storage: how far the solution of the float matrix the solvers read lies from B*
  // at most, their floor (issue 35.6; solvers/reference/reference.h).
  if (std::isfinite(r.float_storage_bound)) {
    json.field("float_storage_bound_inf", r.float_storage_bound);
    json.field("float_storage_bound_relative", r.float_storage_bound_relative);
  }
  json.end_object();
}

}  // namespace

void write_problem_info(JsonWriter& json, const Problem& p) {
  write_scene_info(json, p);
  write_mesh_info(json, p);
  write_form_factor_info(json, p);
  write_left_out(json, p);
  write_reference_info(json, p);
}

void write_solver_info(JsonWriter& json, const std::string& solver,
                       const std::map<std::string, std::string>& given) {
  json.key("solver").begin_object();
  json.field("name", solver);
  json.key("options").begin_object();
  for (const ParameterInfo& p : solver_info(solver).parameters) {
    auto it = given.find(p.name);
    json.field(p.name, it != given.end() ? it->second : p.default_value);
  }
  json.end_object();
  json.end_object();
}

void write_run_result(JsonWriter& json, const Budget& budget, const RunResult& r) {
  json.key("run").begin_object();
  json.field("budget", budget.describe());
  json.field("stop_reason", r.stop_reason);
  json.field("steps", static_cast<long long>(r.steps));
  json.field("ff_rows", static_cast<unsigned long long>(r.rows));
  json.field("rays", static_cast<unsigned long long>(r.rays));
  json.field("pair_evals", static_cast<unsigned long long>(r.pair_evals));
  json.field("seconds", r.seconds);
  json.field("setup_seconds", r.setup_seconds);
  json.field("seconds_with_setup", r.seconds_with_setup);
  json.field("cpu_seconds", r.cpu_seconds);
  json.field("reference_kind", r.reference_kind);
  json.field("rms_rel_reflected", r.final_reflected.rms_rel);
  json.field("rms_rel", r.final_errors.rms_rel);
  json.field("p_mean", r.final_errors.p_mean);
  json.field("p_max", r.final_errors.p_max);
  json.field("rms_rel_display", r.final_display_errors.rms_rel);
  json.field("bound_relative", r.final_bound_relative);
  json.field("bound_relative_reflected", r.final_bound_relative_reflected);
  if (r.tolerance_asked) {
    json.field("tolerance_of", std::string(r.tolerance_of_reflected ? "reflected" : "max-b"));
    json.field("tolerance_reached", r.tolerance_reached);
    if (!r.tolerance_reached) json.field("tolerance_message", r.tolerance_message);
  }
  json.end_object();
}

void write_solver_statistics(JsonWriter& json,
                             const std::vector<std::pair<std::string, double>>& statistics) {
  if (statistics.empty()) return;
  json.key("solver_statistics").begin_object();
  for (const auto& [key, value] : statistics) json.field(key, value);
  json.end_object();
}

std::string command_line(int argc, char** argv) {
  std::vector<std::string> parts;
  for (int k = 0; k < argc; ++k) {
    std::string a = argv[k];
    if (a.find_first_of(" \t\"'") != std::string::npos) a = "'" + a + "'";
    parts.push_back(a);
  }
  return text::join(parts, " ");
}

}  // namespace radlab
