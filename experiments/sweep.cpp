#include "experiments/sweep.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>

#include "core/error.h"
#include "core/json.h"
#include "core/log.h"
#include "core/text.h"
#include "experiments/coverage.h"
#include "experiments/images.h"
#include "experiments/outputs.h"
#include "experiments/summary.h"
#include "experiments/trace.h"
#include "solvers/registry.h"

namespace radlab {

std::pair<int, int> parse_shard(const std::string& text) {
  auto parts = text::split(text, '/');
  if (parts.size() == 2) {
    auto i = text::parse_int(parts[0]);
    auto n = text::parse_int(parts[1]);
    if (i && n && *n >= 1 && *i >= 0 && *i < *n) return {int(*i), int(*n)};
  }
  throw UsageError("--shard must be i/N with 0 <= i < N, got '" + text + "'");
}

std::string file_stem(const std::string& run_id) {
  std::string stem;
  for (char c : run_id)
    stem += (c == '/' || c == ':' || c == ' ' || c == ',' || c == '=') ? '_' : c;
  return stem;
}

namespace {

bool is_gathering(const std::string& solver) {
  return solver == "jacobi" || solver == "gauss-seidel";
}

double worst_spectral_radius(const Problem& problem) {
  double worst = 0.0;
  for (int c = 0; c < problem.system->channels(); ++c)
    worst = std::max(
        worst, spectral_radius_bounds(problem.matrix, problem.system->reflectance().channel(c), 200)
                   .upper);
  return worst;
}

}  // namespace

SweepReport run_sweep(const ExperimentSpec& spec, const SweepOptions& options) {
  if (options.shard_count < 1 || options.shard_index < 0 ||
      options.shard_index >= options.shard_count)
    throw UsageError("invalid shard " + std::to_string(options.shard_index) + "/" +
                     std::to_string(options.shard_count));
  const SweepPlan plan = plan_sweep(spec);
  namespace fs = std::filesystem;
  const fs::path out(options.out_dir);
  fs::create_directories(out / "runs");
  if (!spec.images.steps.empty()) fs::create_directories(out / "images");
  if (!spec.coverage_steps.empty()) fs::create_directories(out / "coverage");

  TraceWriter trace((out / "trace.csv").string());
  CsvWriter summary((out / "summary.csv").string(), summary_columns());
  SweepReport report;
  report.runs_total = plan.runs.size();

  std::unique_ptr<Problem> problem;
  size_t problem_index = size_t(-1);
  double spectral_radius = std::nan("");
  std::unique_ptr<ImageMaker> images;
  std::vector<std::string> run_ids;

  for (const PlannedRun& run : plan.runs) {
    if (int(run.index % size_t(options.shard_count)) != options.shard_index) continue;
    if (run.problem != problem_index) {
      problem.reset();
      images.reset();
      problem = prepare_problem(plan.problems[run.problem].spec);
      problem_index = run.problem;
      spectral_radius = std::nan("");
      if (!spec.images.steps.empty()) images = std::make_unique<ImageMaker>(*problem, spec.images);
    }
    if (is_gathering(run.solver) && std::isnan(spectral_radius) && problem->has_matrix())
      spectral_radius = worst_spectral_radius(*problem);

    std::vector<std::string> assignments;
    for (const auto& [k, v] : run.parameters) assignments.push_back(k + "=" + v);
    ParamBag bag = ParamBag::from_assignments(assignments, "solver '" + run.solver + "'");
    std::unique_ptr<Solver> solver = make_solver(run.solver, bag);

    RunLabels labels{run.run_id, plan.problems[run.problem].spec.scene, run.solver,
                     bag.canonical()};
    CheckpointSchedule schedule = spec.schedule;
    for (long long s : spec.images.steps) schedule.extra.push_back(s);
    for (long long s : spec.coverage_steps) schedule.extra.push_back(s);
    const std::string stem = file_stem(run.run_id);
    auto wanted = [](const std::vector<long long>& steps, long long step) {
      return std::find(steps.begin(), steps.end(), step) != steps.end();
    };
    CheckpointHook hook = [&, stem](long long step, const Solver& s) {
      if (images && wanted(spec.images.steps, step))
        images->save(s, step, (out / "images" / stem).string());
      if (wanted(spec.coverage_steps, step)) {
        char name[64];
        std::snprintf(name, sizeof name, "_step%06lld.csv", step);
        write_coverage_csv((out / "coverage" / (stem + name)).string(), s, *problem, step);
      }
    };
    log::info("[" + std::to_string(run.index + 1) + "/" + std::to_string(plan.runs.size()) + "] " +
              run.run_id);
    RunResult result = run_solver(*solver, *problem, spec.budget, schedule, labels, &trace, hook);

    SummaryInputs inputs;
    inputs.run_index = run.index;
    inputs.labels = labels;
    inputs.elements = problem->mesh.size();
    inputs.channels = problem->system->channels();
    inputs.gathering = is_gathering(run.solver);
    inputs.spectral_radius = inputs.gathering ? spectral_radius : std::nan("");
    write_summary_row(summary, inputs, result);
    summary.flush();

    JsonWriter json;
    json.begin_object();
    json.field("run_id", run.run_id);
    json.field("run_index", run.index);
    json.field("experiment", spec.path);
    write_build_info(json);
    write_problem_info(json, *problem);
    write_solver_info(json, run.solver, bag.values());
    write_run_result(json, spec.budget, result);
    json.end_object();
    json.save((out / "runs" / (stem + ".run.json")).string());
    write_radiosity_csv((out / "runs" / (stem + ".radiosity.csv")).string(), problem->mesh,
                        solver->solution());
    run_ids.push_back(run.run_id);
    ++report.runs_done;
  }

  JsonWriter sweep;
  sweep.begin_object();
  sweep.field("experiment", spec.path);
  sweep.field("name", spec.name);
  sweep.field("description", spec.description);
  sweep.field("command", options.command);
  sweep.field("shard",
              std::to_string(options.shard_index) + "/" + std::to_string(options.shard_count));
  sweep.field("runs_total", plan.runs.size());
  sweep.field("runs", run_ids);
  write_build_info(sweep);
  sweep.end_object();
  sweep.save((out / "sweep.json").string());
  return report;
}

}  // namespace radlab
