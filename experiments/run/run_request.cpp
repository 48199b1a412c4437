// One run as one library call (see run_request.h).
#include "experiments/run/run_request.h"

#include <filesystem>

#include "core/error.h"
#include "core/log.h"
#include "core/output_file.h"
#include "core/text.h"
#include "experiments/problem/stand_in_reference.h"
#include "experiments/problem/two_level_problem.h"
#include "experiments/run/images.h"
#include "experiments/run/outputs.h"
#include "formfactor/visibility/embree_scene.h"
#include "render/exr_io.h"
#include "render/png_io.h"
#include "render/renderer.h"
#include "solvers/plugin_loader.h"
#include "solvers/registry.h"

namespace radlab {
namespace {

// The final image (EXR, PNG beside it) from the scene's camera, or a default view.
void save_final_image(const Problem& problem, const Radiosity& field, const RunOutputs& outputs,
                      const ExrAttributes& provenance) {
  EmbreeScene embree(problem.mesh);
  const Camera camera =
      problem.scene().camera ? *problem.scene().camera : default_camera(problem.mesh);
  Image image =
      render_radiosity(problem.mesh, embree, field, camera, outputs.width, outputs.height);
  const std::string& path = outputs.image;
  write_via_temporary(path, [&](const std::string& temp) { write_exr(temp, image, provenance); });
  std::string png = std::filesystem::path(path).replace_extension(".png").string();
  write_via_temporary(
      png, [&](const std::string& temp) { write_png(temp, image, auto_exposure(image)); });
  if (outputs.announce) log::info("wrote " + path + " and " + png);
}

// Every output can be written, checked before the computation rather than after it.
void check_outputs_writable(const RunOutputs& outputs) {
  for (const std::string& path : {outputs.trace, outputs.radiosity, outputs.image, outputs.json})
    if (!path.empty()) check_writable(path);
  if (!outputs.image.empty())
    check_writable(std::filesystem::path(outputs.image).replace_extension(".png").string());
}

std::unique_ptr<Solver> make_requested_solver(const RunRequest& request) {
  ParamBag bag = request.solver_parameters;  // make_solver marks what it reads
  // A plugin's factory may throw anything: contained to this run (runner.h).
  return call_solver(request.labels, "its factory",
                     [&] { return make_solver(request.solver, bag); });
}

// The run proper, with its solver made: run, then the files.
RunOutcome run_prepared(const RunRequest& request, const Problem& problem,
                        std::unique_ptr<Solver> solver) {
  RunOutcome outcome;
  outcome.problem = &problem;
  outcome.solver = std::move(solver);
  const RunOutputs& outputs = request.outputs;
  std::unique_ptr<TraceWriter> owned_trace;
  if (!outputs.trace.empty()) owned_trace = std::make_unique<TraceWriter>(outputs.trace);
  TraceWriter* trace = owned_trace ? owned_trace.get() : outputs.trace_sink;
  outcome.result = run_solver(*outcome.solver, problem, request.budget, request.schedule,
                              request.labels, trace, request.hook);
  // The outputs read the solver once more after the run: through the same guard and contract
  // check as the run's own reads (runner.h), so a plugin that throws or changes its answer's
  // size here fails this run by name instead of ending a sweep or reading out of bounds.
  const Solver& made = *outcome.solver;
  const RunLabels& labels = request.labels;
  // On two levels, adaptive-shooting's final system, certified on the evaluation mesh.
  for (auto& entry : call_solver(labels, "its final system",
                                 [&] { return final_system_statistics(problem, made); }))
    outcome.result.statistics.push_back(entry);
  const auto checked = [&](const char* call, const Radiosity& field) -> const Radiosity& {
    check_solver_field(field, *problem.system, labels, call);
    return field;
  };
  const Radiosity& solution = checked(
      "solution()",
      call_solver(labels, "solution()", [&]() -> const Radiosity& { return made.solution(); }));

  if (!outputs.radiosity.empty()) {
    write_radiosity_csv(outputs.radiosity, problem.mesh, solution);
    if (outputs.announce) log::info("wrote " + outputs.radiosity);
  }
  if (trace) trace->close();
  if (owned_trace && outputs.announce) log::info("wrote " + outputs.trace);
  if (!outputs.image.empty())
    save_final_image(
        problem,
        outputs.display_image
            ? checked("display()", call_solver(labels, "display()", [&] { return made.display(); }))
            : solution,
        outputs,
        run_provenance(request.labels.run_id, problem.spec.scene, request.solver,
                       outcome.result.steps, outcome.result.rows));
  if (!outputs.json.empty()) {
    JsonWriter json;
    begin_run_json(json, request, &problem, &request.solver_parameters.values());
    write_run_result(json, request.budget, outcome.result);
    write_solver_statistics(json, outcome.result.statistics);
    json.end_object();
    json.save(outputs.json);
    if (outputs.announce) log::info("wrote " + outputs.json);
  }
  return outcome;
}

}  // namespace

std::unique_ptr<Problem> prepare_run_problem(const ProblemSpec& spec_in,
                                             const ReferenceChoice& reference, const Budget& budget,
                                             bool rows_read) {
  if (reference.kind != "certified" && reference.kind != "none" &&
      reference.kind != kHierarchicalFineReference)
    throw UsageError("reference: unknown kind '" + reference.kind +
                     "' (certified, none or hierarchical-fine)");
  ProblemSpec spec = spec_in;
  if (reference.kind != "certified") {
    if (budget.tol) throw UsageError("--tol needs the certified reference (--reference certified)");
    // No dense matrix: rows (for flat solvers) are computed on the fly.
    spec.need_reference = false;
    spec.row_mode = RowMode::kOnTheFly;
  }
  // A solver that reads no row needs no matrix (a reference not in the cache still builds one,
  // in prepare_problem's matrix stage, for the reference alone).
  if (!rows_read) spec.row_mode = RowMode::kOnTheFly;
  std::unique_ptr<Problem> problem = prepare_problem(spec);
  if (budget.tol && !problem->has_matrix() && !problem->system->two_level())
    throw UsageError(
        "--tol needs the certified bound of the solver's own error, taken with the dense matrix; "
        "rows on the fly with a cached reference have none (use --ff-mode cached)");
  if (reference.kind == kHierarchicalFineReference) {
    log::info("reference: NOT certified: a finer hierarchical run (feps " +
              text::format_double(reference.feps) + ", aeps " +
              text::format_double(reference.aeps) +
              ") stands in for it (the scene is too large for the certified one)");
    problem->reference =
        hierarchical_fine_reference(*problem->system, reference.feps, reference.aeps);
  }
  return problem;
}

RunOutcome execute_run(const RunRequest& request, const Problem& problem) {
  return run_prepared(request, problem, make_requested_solver(request));
}

RunOutcome execute_run(const RunRequest& request) {
  // The solver's parameters and the outputs are checked before any work.
  std::unique_ptr<Solver> solver = make_requested_solver(request);
  check_outputs_writable(request.outputs);
  std::unique_ptr<Problem> problem = prepare_run_problem(
      request.problem, request.reference, request.budget, !is_matrix_free(request.solver));
  RunOutcome outcome = run_prepared(request, *problem, std::move(solver));
  outcome.owned_problem = std::move(problem);
  return outcome;
}

void begin_run_json(JsonWriter& json, const RunRequest& request, const Problem* problem,
                    const std::map<std::string, std::string>* options) {
  json.begin_object();
  if (!request.identity.command.empty()) json.field("command", request.identity.command);
  json.field("run_id", request.labels.run_id);
  if (request.identity.run_index) json.field("run_index", *request.identity.run_index);
  if (!request.identity.experiment.empty()) json.field("experiment", request.identity.experiment);
  write_build_info(json);
  // The plugin files whose code this run executes (its solver's, its form-factor method's).
  json.key("plugins").begin_array();
  for (const PluginProvenance& p : plugins_providing(request.solver, request.problem.ff_method)) {
    json.begin_object();
    json.field("path", p.path);
    json.field("sha256", p.sha256);
    json.end_object();
  }
  json.end_array();
  if (problem) write_problem_info(json, *problem);
  if (options) write_solver_info(json, request.solver, *options);
}

}  // namespace radlab
