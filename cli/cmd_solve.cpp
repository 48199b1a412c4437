// `radlab solve SCENE --solver NAME`: one run of one solver, measured against the certified
// reference: trace CSV, final radiosities, run.json and (optionally) an EXR + PNG image.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "cli/cli_common.h"
#include "core/error.h"
#include "core/log.h"
#include "core/output_file.h"
#include "core/text.h"
#include "experiments/problem/stand_in_reference.h"
#include "experiments/run/images.h"
#include "experiments/run/outputs.h"
#include "experiments/run/runner.h"
#include "experiments/sweep/experiment_spec.h"
#include "formfactor/visibility/embree_scene.h"
#include "render/exr_io.h"
#include "render/png_io.h"
#include "render/renderer.h"
#include "solvers/registry.h"

namespace radlab::cli {
namespace {

struct SolveOptions {
  SceneOptions scene;
  FormFactorOptions ff;
  std::string solver;
  std::vector<std::string> set;
  long long steps = 0, rows = 0;
  double seconds = 0, tol = 0;
  std::string tol_of = "max-b";  // max-b | reflected (Budget::tol_of_reflected)
  bool steps_given = false, rows_given = false, seconds_given = false, tol_given = false;
  std::string trace, out, image, json;
  int width = 512, height = 512;
  bool display_image = true;
  // certified | none | hierarchical-fine (stand_in_reference.h): the latter two skip the dense
  // matrix, for scenes too large for it.
  std::string reference = "certified";
  double reference_feps = 0.0025, reference_aeps = 1e-5;
};

// The same format as `radlab run`'s (experiment_spec.h), so one run reads the same in both.
std::string run_id_for(const SolveOptions& o, const ParamBag& bag) {
  return make_run_id(o.solver, "scene:" + scene_label(o.scene.scene), bag.values());
}

void save_image(const Problem& problem, const Radiosity& field, const std::string& path, int width,
                int height, const ExrAttributes& provenance) {
  EmbreeScene embree(problem.mesh);
  const Camera camera =
      problem.scene().camera ? *problem.scene().camera : default_camera(problem.mesh);
  Image image = render_radiosity(problem.mesh, embree, field, camera, width, height);
  ensure_parent_folder(path);
  write_via_temporary(path, [&](const std::string& temp) { write_exr(temp, image, provenance); });
  std::string png = std::filesystem::path(path).replace_extension(".png").string();
  write_via_temporary(
      png, [&](const std::string& temp) { write_png(temp, image, auto_exposure(image)); });
  log::info("wrote " + path + " and " + png);
}

void run(const SolveOptions& o, int argc, char** argv) {
  if (!o.image.empty() && (o.width < 8 || o.height < 8 || o.width > 8192 || o.height > 8192))
    throw UsageError("--width and --height must lie in [8, 8192], got " + std::to_string(o.width) +
                     " x " + std::to_string(o.height));
  ParamBag bag = ParamBag::from_assignments(o.set, "solver '" + o.solver + "'");
  std::unique_ptr<Solver> solver = make_solver(o.solver, bag);  // validates before any work

  Budget budget;
  if (o.steps_given) {
    if (o.steps < 1) throw UsageError("--steps must be >= 1, got " + std::to_string(o.steps));
    budget.steps = o.steps;
  }
  if (o.rows_given) {
    if (o.rows < 1) throw UsageError("--rows must be >= 1, got " + std::to_string(o.rows));
    budget.rows = o.rows;
  }
  if (o.seconds_given) {
    if (!(o.seconds > 0.0 && std::isfinite(o.seconds)))
      throw UsageError("--seconds must be a finite number > 0, got " +
                       text::format_double(o.seconds));
    budget.seconds = o.seconds;
  }
  if (o.tol_given) {
    if (!(o.tol > 0.0 && o.tol < 1.0))
      throw UsageError("--tol must lie in (0,1) (a bound relative to max B*), got " +
                       text::format_double(o.tol));
    budget.tol = o.tol;
    budget.tol_of_reflected = o.tol_of == "reflected";
  }

  std::string json_path = o.json;
  if (json_path.empty() && !o.trace.empty())
    json_path = std::filesystem::path(o.trace).replace_extension(".run.json").string();
  // Every output can be written, before the computation rather than after it.
  for (const std::string& path : {o.trace, o.out, o.image, json_path})
    if (!path.empty()) check_writable(path);
  if (!o.image.empty())
    check_writable(std::filesystem::path(o.image).replace_extension(".png").string());

  ProblemSpec spec = make_spec(o.scene, o.ff);
  if (o.reference != "certified") {
    if (o.tol_given)
      throw UsageError("--tol needs the certified reference (--reference certified)");
    // No dense matrix: rows (for flat solvers) are computed on the fly.
    spec.need_reference = false;
    spec.row_mode = RowMode::kOnTheFly;
  }
  auto problem = prepare_problem(spec);
  if (o.tol_given && !problem->has_matrix())
    throw UsageError(
        "--tol needs the certified bound of the solver's own error, taken with the dense matrix; "
        "rows on the fly with a cached reference have none (use --ff-mode cached)");
  if (o.reference == kHierarchicalFineReference) {
    log::info("reference: NOT certified: a finer hierarchical run (feps " +
              text::format_double(o.reference_feps) + ", aeps " +
              text::format_double(o.reference_aeps) +
              ") stands in for it (the scene is too large for the certified one)");
    problem->reference =
        hierarchical_fine_reference(*problem->system, o.reference_feps, o.reference_aeps);
  }

  std::unique_ptr<TraceWriter> trace;
  if (!o.trace.empty()) {
    ensure_parent_folder(o.trace);
    trace = std::make_unique<TraceWriter>(o.trace);
  }
  RunLabels labels{run_id_for(o, bag), o.scene.scene, o.solver, bag.canonical()};
  RunResult result =
      run_solver(*solver, *problem, budget, CheckpointSchedule{}, labels, trace.get());
  if (trace) trace->close();

  std::printf("run          %s\n", labels.run_id.c_str());
  std::printf("stopped      %s after %lld steps, %llu form-factor rows, %.4f s\n",
              result.stop_reason.c_str(), result.steps, result.rows, result.seconds);
  if (problem->reference) {
    std::printf("error        rms_rel %.6g, p_mean %.6g, p_max %.6g (display: rms_rel %.6g)\n",
                result.final_errors.rms_rel, result.final_errors.p_mean, result.final_errors.p_max,
                result.final_display_errors.rms_rel);
    if (problem->reference->kind == "certified" && !problem->has_matrix()) {
      std::printf(
          "certified    reference only (rows on the fly: no matrix to take the solver's "
          "residual with, so no bound on its error)\n");
    } else if (problem->reference->kind == "certified") {
      std::printf("certified    ||B - B*||_inf / max B* <= %.6g\n", result.final_bound_relative);
      // Said beside it whenever the two scales differ by more than 10%: max B* is an emitter's
      // radiosity, and a bound that is small against it can be large against the reflected light.
      if (std::isfinite(result.final_bound_relative_reflected) &&
          result.final_bound_relative_reflected > 1.1 * result.final_bound_relative)
        std::printf("certified    ||B - B*||_inf / max(B* - E) <= %.6g (the reflected light)\n",
                    result.final_bound_relative_reflected);
    } else
      std::printf("reference    %s (NOT certified: %s)\n", problem->reference->kind.c_str(),
                  problem->reference->method.c_str());
  }
  for (const auto& [key, value] : solver->statistics())
    std::printf("statistic    %-28s %.10g\n", key.c_str(), value);
  // No physical radiosity is negative; over-relaxation can leave some (issue 35.5).
  size_t negative = 0;
  double lowest = 0.0;
  for (double b : solver->solution().raw())
    if (b < 0.0) ++negative, lowest = std::min(lowest, b);
  if (negative > 0)
    std::printf(
        "verdict      %zu radiosity values are negative (lowest %.6g): not a physical "
        "solution yet\n",
        negative, lowest);
  if (result.tolerance_asked) {
    if (!result.tolerance_reached) {
      std::printf("verdict      %s\n", result.tolerance_message.c_str());
    } else if (result.tolerance_of_reflected) {
      std::printf("verdict      tolerance %.6g of max(B* - E) reached (the reflected light)\n",
                  o.tol);
    } else if (result.final_bound_relative_reflected > o.tol) {
      // True but easily misread: the bound is relative to the brightest emitter.
      std::printf(
          "verdict      tolerance %.6g of max B* reached; the reflected light is bounded only to "
          "%.3g of max(B* - E) (--tol-of reflected stops on that)\n",
          o.tol, result.final_bound_relative_reflected);
    } else {
      std::printf("verdict      tolerance %.6g of max B* reached\n", o.tol);
    }
  }
  if (!o.out.empty()) {
    ensure_parent_folder(o.out);
    write_radiosity_csv(o.out, problem->mesh, solver->solution());
    log::info("wrote " + o.out);
  }
  if (!o.trace.empty()) log::info("wrote " + o.trace);
  if (!o.image.empty())
    save_image(*problem, o.display_image ? solver->display() : solver->solution(), o.image, o.width,
               o.height,
               run_provenance(labels.run_id, o.scene.scene, o.solver, result.steps, result.rows));

  if (!json_path.empty()) {
    JsonWriter json;
    json.begin_object();
    json.field("command", command_line(argc, argv));
    json.field("run_id", labels.run_id);
    write_build_info(json);
    write_problem_info(json, *problem);
    write_solver_info(json, o.solver, bag.values());
    write_run_result(json, budget, result);
    write_solver_statistics(json, *solver, problem.get());
    json.end_object();
    ensure_parent_folder(json_path);
    json.save(json_path);
    log::info("wrote " + json_path);
  }
  // Everything is written; the exit code tells a script the tolerance was missed.
  if (result.tolerance_asked && !result.tolerance_reached)
    throw Error(ExitCode::kToleranceNotReached, labels.run_id + ": " + result.tolerance_message);
}

}  // namespace

void add_solve_command(CLI::App& app, int argc, char** argv) {
  auto* command = app.add_subcommand(
      "solve", "run one solver on one scene, measured against the certified reference");
  auto o = std::make_shared<SolveOptions>();
  add_scene_options(*command, o->scene);
  add_form_factor_options(*command, o->ff, true);
  command->add_option("--solver", o->solver, "solver name (see `radlab solvers`)")->required();
  command->add_option("--set", o->set, "solver parameter key=value (repeatable)")
      ->allow_extra_args(false);
  auto* steps = command->add_option("--steps", o->steps, "stop after N solver steps");
  auto* rows = command->add_option("--rows", o->rows, "stop after N form-factor rows");
  auto* seconds =
      command->add_option("--seconds", o->seconds, "stop after T seconds of solver time");
  auto* tol = command->add_option("--tol", o->tol,
                                  "stop when the certified bound ||B-B*||_inf / max B* <= X "
                                  "(checked at checkpoints); without any budget: 3n steps");
  command
      ->add_option(
          "--tol-of", o->tol_of,
          "what --tol is relative to: max-b (default, max B*) or reflected "
          "(max(B* - E), the reflected light; use it when a small bright lamp sets max B*)")
      ->check(CLI::IsMember({"max-b", "reflected"}));
  command->add_option("--trace", o->trace, "trace CSV (one row per checkpoint and channel)");
  command->add_option("--out", o->out, "final radiosities CSV element,area,B_r,B_g,B_b");
  command->add_option("--image", o->image, "EXR image of the display solution (PNG beside it)");
  command->add_option("--width", o->width, "image width in pixels (default 512)");
  command->add_option("--height", o->height, "image height in pixels (default 512)");
  command->add_option("--json", o->json, "run.json path (default: beside the trace)");
  command
      ->add_option("--reference", o->reference,
                   "certified (default; needs the dense matrix), none, or hierarchical-fine (an "
                   "uncertified finer hierarchical run, for scenes too large for the dense matrix)")
      ->check(CLI::IsMember({"certified", "none", kHierarchicalFineReference}));
  command->add_option("--reference-feps", o->reference_feps,
                      "feps of the hierarchical-fine reference (default 0.0025)");
  command->add_option("--reference-aeps", o->reference_aeps,
                      "aeps of the hierarchical-fine reference (default 1e-5)");
  command->callback([=]() {
    o->steps_given = steps->count() > 0;
    o->rows_given = rows->count() > 0;
    o->seconds_given = seconds->count() > 0;
    o->tol_given = tol->count() > 0;
    run(*o, argc, argv);
  });
}

}  // namespace radlab::cli
