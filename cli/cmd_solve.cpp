// `radlab solve SCENE --solver NAME`: one run of one solver, measured against the certified
// reference: trace CSV, final radiosities, run.json and (optionally) an EXR + PNG image.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "cli/cli_common.h"
#include "core/error.h"
#include "experiments/problem/stand_in_reference.h"
#include "experiments/run/outputs.h"
#include "experiments/run/run_request.h"
#include "experiments/sweep/experiment_spec.h"

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

// The budget from the options given, checked with budget_violation's rules in the options' words.
Budget budget_of(const SolveOptions& o) {
  Budget budget;
  if (o.steps_given) budget.steps = o.steps;
  if (o.rows_given) budget.rows = o.rows;
  if (o.seconds_given) budget.seconds = o.seconds;
  if (o.tol_given) {
    budget.tol = o.tol;
    budget.tol_of_reflected = o.tol_of == "reflected";
  }
  if (auto violation = budget_violation(budget))
    throw UsageError("--" + violation->field + " " + violation->requirement + ", got " +
                     violation->given);
  return budget;
}

// The request `radlab solve` stands for: parsed and checked here, run by execute_run.
RunRequest request_of(const SolveOptions& o, int argc, char** argv) {
  if (!o.image.empty() && (o.width < 8 || o.height < 8 || o.width > 8192 || o.height > 8192))
    throw UsageError("--width and --height must lie in [8, 8192], got " + std::to_string(o.width) +
                     " x " + std::to_string(o.height));
  RunRequest request;
  request.problem = make_problem_spec(o.scene, o.ff);
  request.reference = {o.reference, o.reference_feps, o.reference_aeps};
  request.solver = o.solver;
  request.solver_parameters = ParamBag::from_assignments(o.set, "solver '" + o.solver + "'");
  request.budget = budget_of(o);
  // The same run-id format as `radlab run`'s (experiment_spec.h), so one run reads the same in
  // both.
  request.labels = {make_run_id(o.solver, "scene:" + scene_label(o.scene.scene),
                                request.solver_parameters.values()),
                    o.scene.scene, o.solver, request.solver_parameters.canonical()};
  request.identity.command = command_line(argc, argv);
  RunOutputs& outputs = request.outputs;
  outputs.trace = o.trace;
  outputs.radiosity = o.out;
  outputs.image = o.image;
  outputs.width = o.width;
  outputs.height = o.height;
  outputs.display_image = o.display_image;
  outputs.json = o.json;
  if (outputs.json.empty() && !o.trace.empty())
    outputs.json = std::filesystem::path(o.trace).replace_extension(".run.json").string();
  return request;
}

void print_reference(const RunOutcome& run) {
  const Problem& problem = *run.problem;
  const RunResult& result = run.result;
  std::printf("error        rms_rel %.6g, p_mean %.6g, p_max %.6g (display: rms_rel %.6g)\n",
              result.final_errors.rms_rel, result.final_errors.p_mean, result.final_errors.p_max,
              result.final_display_errors.rms_rel);
  if (problem.reference->kind != "certified") {
    std::printf("reference    %s (NOT certified: %s)\n", problem.reference->kind.c_str(),
                problem.reference->method.c_str());
  } else if (!problem.has_matrix() && !problem.system->two_level()) {
    std::printf(
        "certified    reference only (rows on the fly: no matrix to take the solver's "
        "residual with, so no bound on its error)\n");
  } else {
    std::printf("certified    ||B - B*||_inf / max B* <= %.6g\n", result.final_bound_relative);
    // Said beside it whenever the two scales differ by more than 10%: max B* is an emitter's
    // radiosity, and a bound that is small against it can be large against the reflected light.
    if (std::isfinite(result.final_bound_relative_reflected) &&
        result.final_bound_relative_reflected > 1.1 * result.final_bound_relative)
      std::printf("certified    ||B - B*||_inf / max(B* - E) <= %.6g (the reflected light)\n",
                  result.final_bound_relative_reflected);
  }
}

// No physical radiosity is negative; over-relaxation can leave some (issue 35.5).
void print_negative_radiosities(const Radiosity& solution) {
  size_t negative = 0;
  double lowest = 0.0;
  for (double b : solution.raw())
    if (b < 0.0) ++negative, lowest = std::min(lowest, b);
  if (negative > 0)
    std::printf(
        "verdict      %zu radiosity values are negative (lowest %.6g): not a physical "
        "solution yet\n",
        negative, lowest);
}

void print_verdict(const RunResult& result, double tol) {
  if (!result.tolerance_reached) {
    std::printf("verdict      %s\n", result.tolerance_message.c_str());
  } else if (result.tolerance_of_reflected) {
    std::printf("verdict      tolerance %.6g of max(B* - E) reached (the reflected light)\n", tol);
  } else if (result.final_bound_relative_reflected > tol) {
    // True but easily misread: the bound is relative to the brightest emitter.
    std::printf(
        "verdict      tolerance %.6g of max B* reached; the reflected light is bounded only to "
        "%.3g of max(B* - E) (--tol-of reflected stops on that)\n",
        tol, result.final_bound_relative_reflected);
  } else {
    std::printf("verdict      tolerance %.6g of max B* reached\n", tol);
  }
}

void run(const SolveOptions& o, int argc, char** argv) {
  const RunRequest request = request_of(o, argc, argv);
  const RunOutcome run = execute_run(request);
  const RunResult& result = run.result;
  std::printf("run          %s\n", request.labels.run_id.c_str());
  std::printf("stopped      %s after %lld steps, %llu form-factor rows, %.4f s (%.4f s CPU)\n",
              result.stop_reason.c_str(), result.steps, result.rows, result.seconds,
              result.cpu_seconds);
  if (run.problem->reference) print_reference(run);
  for (const auto& [key, value] : run.solver->statistics())
    std::printf("statistic    %-28s %.10g\n", key.c_str(), value);
  print_negative_radiosities(run.solver->solution());
  if (result.tolerance_asked) print_verdict(result, o.tol);
  // Everything is written; the exit code tells a script the tolerance was missed.
  if (result.tolerance_asked && !result.tolerance_reached)
    throw Error(ExitCode::kToleranceNotReached,
                request.labels.run_id + ": " + result.tolerance_message);
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
