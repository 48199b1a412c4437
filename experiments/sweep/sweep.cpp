#include "experiments/sweep/sweep.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <sstream>

#include "core/csv_reader.h"
#include "core/error.h"
#include "core/json.h"
#include "core/log.h"
#include "core/output_file.h"
#include "core/text.h"
#include "experiments/run/coverage.h"
#include "experiments/run/images.h"
#include "experiments/run/outputs.h"
#include "experiments/run/run_request.h"
#include "experiments/run/seed_aggregate.h"
#include "experiments/run/summary.h"
#include "experiments/run/trace.h"
#include "experiments/sweep/sweep_folder.h"
#include "solvers/registry.h"

namespace radlab {

std::pair<int, int> parse_shard(const std::string& text) {
  auto parts = text::split(text, '/');
  if (parts.size() == 2) {
    auto i = text::parse_int(parts[0]);
    auto n = text::parse_int(parts[1]);
    // N is checked in 64 bits before it becomes an int (1/4294967298 is not 1/2).
    if (i && n && *n >= 1 && *n <= 2147483647 && *i >= 0 && *i < *n) return {int(*i), int(*n)};
  }
  throw UsageError("--shard must be i/N with 0 <= i < N <= 2147483647, got '" + text + "'");
}

std::string file_stem(const std::string& run_id) {
  std::string stem;
  for (char c : run_id)
    stem += (c == '/' || c == ':' || c == ' ' || c == ',' || c == '=') ? '_' : c;
  return stem;
}

namespace {

// The solver's kind is in its SolverInfo: a new gathering solver gets per-sweep checkpoints, the
// rate fit and the spectral-radius column without an edit here.
bool is_gathering(const std::string& solver) {
  return solver_info(solver).kind == SolverKind::kGathering;
}

// The experiment's schedule plus the image and coverage steps, evenly spaced checkpoints over the
// second half of a step or row budget (a geometric schedule alone leaves only ~5 checkpoints
// there, too few for the tail fit), and for gathering solvers the end of every sweep (the fitted
// per-sweep rate uses those: mid-sweep errors depend on where in the sweep the checkpoint falls).
CheckpointSchedule run_schedule(const ExperimentSpec& spec, bool gathering, size_t elements) {
  CheckpointSchedule schedule = spec.schedule;
  for (long long s : spec.images.steps) schedule.extra.push_back(s);
  for (long long s : spec.coverage_steps) schedule.extra.push_back(s);
  // Most solvers read one row per step; for the others these are merely extra checkpoints.
  const long long limit = spec.budget.steps  ? *spec.budget.steps
                          : spec.budget.rows ? *spec.budget.rows
                                             : 0;
  constexpr int kTailCheckpoints = 16;
  if (limit >= 2 * kTailCheckpoints)
    for (int k = 0; k < kTailCheckpoints; ++k)
      schedule.extra.push_back(limit / 2 + (limit - limit / 2) * k / kTailCheckpoints);
  if (gathering && elements > 0) {
    // Without a step or row budget the runner caps a run at 1000 sweeps.
    const long long sweeps = limit > 0 ? limit / static_cast<long long>(elements) : 1000;
    for (long long k = 1; k <= std::min<long long>(sweeps, 1000); ++k)
      schedule.extra.push_back(k * static_cast<long long>(elements));
  }
  std::sort(schedule.extra.begin(), schedule.extra.end());
  schedule.extra.erase(std::unique(schedule.extra.begin(), schedule.extra.end()),
                       schedule.extra.end());
  return schedule;
}

// Collatz–Wielandt bounds on the spectral radius of diag(rho)F, worst channel.
SpectralRadiusBounds worst_spectral_radius(const Problem& problem) {
  SpectralRadiusBounds worst;
  for (int c = 0; c < problem.system->channels(); ++c) {
    const SpectralRadiusBounds b =
        spectral_radius_bounds(problem.matrix, problem.system->reflectance().channel(c), 200);
    worst.lower = std::max(worst.lower, b.lower);
    worst.upper = std::max(worst.upper, b.upper);
  }
  return worst;
}

}  // namespace

int SweepReport::exit_code() const {
  if (failures.empty()) return 0;
  int code = 0;
  for (const RunFailure& f : failures) {
    if (f.code == ExitCode::kNumerical) return int(ExitCode::kNumerical);
    code = std::max(code, int(f.code));
  }
  return code;
}

std::string failure_stop_reason(ExitCode code) {
  switch (code) {
    case ExitCode::kUsage:
      return "failed: usage error";
    case ExitCode::kInvalidInput:
      return "failed: invalid input";
    case ExitCode::kNumerical:
      return "failed: numerical error";
    default:
      return "failed";
  }
}

namespace {

// What sweep.json says about one problem of this shard (prepared or not).
struct ProblemEntry {
  size_t index = 0;
  const PlannedProblem* planned = nullptr;
  bool prepared = false;
  size_t elements = 0, polygons = 0;
  int channels = 0;
  std::string ff_parameters;
  std::string error;
};

ProblemEntry problem_entry(size_t index, const PlannedProblem& planned, const Problem* problem,
                           const std::string& error) {
  ProblemEntry e;
  e.index = index;
  e.planned = &planned;
  e.error = error;
  if (problem) {
    e.prepared = true;
    e.elements = problem->mesh.size();
    e.polygons = problem->scene().polygons.size();
    e.channels = problem->system->channels();
    e.ff_parameters = problem->ff_parameters;
  }
  return e;
}

void write_problem_entry(JsonWriter& json, const ProblemEntry& e) {
  const ProblemSpec& spec = e.planned->spec;
  json.begin_object();
  json.field("index", e.index);
  json.field("label", e.planned->label);
  json.field("scene", spec.scene);
  json.field("subdivisions", spec.mesh.subdivisions);
  json.field("element_size", spec.mesh.element_size);
  if (e.prepared) {
    json.field("polygons", e.polygons);
    json.field("elements", e.elements);
    json.field("channels", e.channels);
  }
  json.key("form_factors").begin_object();
  json.field("method", spec.ff_method);
  json.field("parameters", e.prepared ? e.ff_parameters : text::join(spec.ff_set, ","));
  json.field("precision", spec.precision == Precision::kFloat ? "float" : "double");
  json.field("rows", spec.row_mode == RowMode::kCached ? "cached" : "on-the-fly");
  json.end_object();
  json.field("patches", spec.patches.canonical());
  if (!e.error.empty()) json.field("error", e.error);
  json.end_object();
}

}  // namespace

namespace {

// sweep.json: status "running" at the start, "complete" once trace.csv and summary.csv are in
// place. `runs` lists this shard's runs done so far.
void write_sweep_json(const std::filesystem::path& out, const ExperimentSpec& spec,
                      const SweepOptions& options, const SweepIdentity& identity, size_t runs_total,
                      const char* status, const std::vector<std::string>& run_ids,
                      const std::vector<RunFailure>& failures,
                      const std::map<size_t, ProblemEntry>& problems,
                      const std::vector<ManifestEntry>* manifest = nullptr) {
  JsonWriter sweep;
  sweep.begin_object();
  sweep.field("experiment", spec.path);
  sweep.field("name", spec.name);
  sweep.field("description", spec.description);
  sweep.field("status", status);
  write_identity(sweep, identity);
  sweep.field("command", options.command);
  sweep.field("shard", identity.shard);
  sweep.field("runs_total", runs_total);
  sweep.field("runs", run_ids);
  sweep.key("failed").begin_array();
  for (const RunFailure& f : failures) {
    sweep.begin_object();
    sweep.field("run_index", f.run_index);
    sweep.field("run_id", f.run_id);
    sweep.field("exit_code", int(f.code));
    sweep.field("error", f.message);
    sweep.end_object();
  }
  sweep.end_array();
  sweep.key("problems").begin_array();
  for (const auto& [index, e] : problems) write_problem_entry(sweep, e);
  sweep.end_array();
  write_build_info(sweep);
  if (manifest) write_manifest(sweep, *manifest);
  sweep.end_object();
  sweep.save((out / "sweep.json").string());
}

// A problem's sweep.json entry rebuilt from the run.json of a run done in an earlier attempt.
ProblemEntry problem_entry_from(size_t index, const PlannedProblem& planned, const Json& run) {
  ProblemEntry e;
  e.index = index;
  e.planned = &planned;
  auto scene = run.find("scene");
  auto mesh = run.find("mesh");
  auto ff = run.find("form_factors");
  if (scene != run.end() && mesh != run.end() && ff != run.end()) {
    e.prepared = true;
    e.polygons = scene->value("polygons", size_t(0));
    e.channels = scene->value("channels", 0);
    e.elements = mesh->value("elements", size_t(0));
    e.ff_parameters = ff->value("parameters", std::string());
  } else if (auto r = run.find("run"); r != run.end()) {
    e.error = r->value("error", std::string());
  }
  return e;
}

// Appends the rows of a partial file (everything after its header line) to `out`.
void append_rows(OutputFile& out, const std::filesystem::path& part) {
  std::ifstream in(part, std::ios::binary);
  if (!in) throw InputError(part.string() + ": cannot read the rows of a finished run");
  std::string header;
  std::getline(in, header);
  std::ostringstream rows;
  rows << in.rdbuf();
  if (in.bad()) throw InputError(part.string() + ": read error");
  out.write(rows.str());
}

// File names are at most NAME_MAX (255) bytes on every Linux file system.
constexpr size_t kMaxFileName = 255;
constexpr size_t kLongestSuffix =
    sizeof("_step000000_perror.exr.tmp.4294967295.18446744073709551615");

}  // namespace

namespace {

void make_folder(const std::filesystem::path& folder) {
  std::error_code ec;
  std::filesystem::create_directories(folder, ec);
  if (ec) throw InputError(folder.string() + ": cannot create folder (" + ec.message() + ")");
}

void make_sweep_folders(const std::filesystem::path& out, const ExperimentSpec& spec) {
  make_folder(out / "runs");
  make_folder(partial_folder(out));
  if (!spec.images.steps.empty()) make_folder(out / "images");
  if (!spec.coverage_steps.empty()) make_folder(out / "coverage");
}

// The problem the runs in plan order share, prepared when the first of them comes; a problem that
// cannot be prepared leaves the error its runs are recorded with.
struct CurrentProblem {
  std::unique_ptr<Problem> problem;
  std::unique_ptr<ImageMaker> images;
  size_t index = size_t(-1);
  std::string error;
  ExitCode code = ExitCode::kOk;
  SpectralRadiusBounds spectral_radius{std::nan(""), std::nan("")};

  void prepare(const ExperimentSpec& spec, const PlannedProblem& planned, size_t problem_index,
               const std::vector<SourceFile>& scene_files) {
    problem.reset();
    images.reset();
    index = problem_index;
    error.clear();
    code = ExitCode::kOk;
    spectral_radius = {std::nan(""), std::nan("")};
    try {
      problem = prepare_run_problem(planned.spec, ReferenceChoice{}, spec.budget);
      // The scene read now must be the one the sweep's identity names: an edit while the sweep
      // runs would otherwise mix two versions of the scene in one "complete" sweep.
      const std::string changed = scene_files_difference(scene_files, problem->scene().sources);
      if (!changed.empty())
        throw InputError(planned.spec.scene + ": " + changed +
                         " while the sweep ran; its runs are not computed on a scene that is not "
                         "the one the sweep started with (run the sweep again)");
      if (!spec.images.steps.empty()) images = std::make_unique<ImageMaker>(*problem, spec.images);
    } catch (const Error& e) {
      problem.reset();
      images.reset();
      error = e.what();
      code = e.code();
    } catch (const std::bad_alloc&) {
      problem.reset();
      images.reset();
      error = planned.label + ": out of memory (try a coarser mesh)";
      code = ExitCode::kNumerical;
    } catch (const std::exception& e) {
      // A form-factor method's plugin may throw anything: its problem's runs fail, not the sweep.
      problem.reset();
      images.reset();
      error = planned.label + ": preparing the problem failed: " + e.what();
      code = ExitCode::kNumerical;
    }
    if (!error.empty()) log::info("cannot prepare " + planned.label + ": " + error);
  }
};

// A run done in an interrupted attempt of this very sweep is kept: its failure (if it failed)
// and its problem's sweep.json entry are taken from its run.json. Returns false if it is not
// done.
bool keep_completed_run(const std::filesystem::path& out, const SweepPlan& plan,
                        const PlannedRun& run, const std::string& stem,
                        const std::vector<SourceFile>& scene_files, SweepReport& report,
                        std::map<size_t, ProblemEntry>& problem_entries) {
  std::optional<Json> done = completed_run(out, run, stem, scene_files);
  if (!done) return false;
  ++report.runs_resumed;
  const Json& result = (*done)["run"];
  if (result.contains("exit_code"))
    report.failures.push_back({run.index, run.run_id,
                               ExitCode(result.value("exit_code", int(ExitCode::kNumerical))),
                               result.value("error", std::string())});
  if (!problem_entries.count(run.problem))
    problem_entries[run.problem] =
        problem_entry_from(run.problem, plan.problems[run.problem], *done);
  log::info("[" + std::to_string(run.index + 1) + "/" + std::to_string(plan.runs.size()) + "] " +
            run.run_id + ": already complete (runs/" + stem + ".run.json), skipped");
  return true;
}

// A planned run's solver parameters as key=value.
std::vector<std::string> assignments_of(const PlannedRun& run) {
  std::vector<std::string> assignments;
  for (const auto& [k, v] : run.parameters) assignments.push_back(k + "=" + v);
  return assignments;
}

// The request of one planned run, as far as it is known before its solver's parameters are
// parsed: labels, identity and outputs (the trace is the caller's partial file).
RunRequest planned_request(const ExperimentSpec& spec, const SweepPlan& plan, const PlannedRun& run,
                           const std::string& stem, const std::filesystem::path& out) {
  RunRequest request;
  request.problem = plan.problems[run.problem].spec;
  request.solver = run.solver;
  request.budget = spec.budget;  // validated when the experiment file was read
  request.labels = RunLabels{run.run_id, request.problem.scene, run.solver,
                             text::join(assignments_of(run), ",")};
  request.identity.run_index = run.index;
  request.identity.experiment = spec.path;
  request.outputs.radiosity = (out / "runs" / (stem + ".radiosity.csv")).string();
  request.outputs.json = (out / "runs" / (stem + ".run.json")).string();
  request.outputs.announce = false;  // the sweep says where its results are at the end
  return request;
}

// Images and coverage at the experiment's steps, from the checkpoint hook.
CheckpointHook image_and_coverage_hook(const ExperimentSpec& spec, const PlannedRun& run,
                                       const std::string& stem, const std::filesystem::path& out,
                                       const CurrentProblem& current) {
  auto wanted = [](const std::vector<long long>& steps, long long step) {
    return std::find(steps.begin(), steps.end(), step) != steps.end();
  };
  return [&spec, &run, &current, stem, out, wanted](long long step, const Solver& s) {
    const Problem& problem = *current.problem;
    if (current.images && wanted(spec.images.steps, step))
      current.images->save(s, step, (out / "images" / stem).string(),
                           run_provenance(run.run_id, problem.spec.scene, run.solver, step,
                                          problem.system->rows_used()));
    if (wanted(spec.coverage_steps, step)) {
      char name[64];
      std::snprintf(name, sizeof name, "_step%06lld.csv", step);
      write_coverage_csv((out / "coverage" / (stem + name)).string(), s, problem, step);
    }
  };
}

// What the summary row of a run says besides its result.
SummaryInputs summary_inputs(const PlannedRun& run, const RunRequest& request,
                             const CurrentProblem& current) {
  SummaryInputs inputs;
  inputs.run_index = run.index;
  inputs.labels = request.labels;
  inputs.gathering = is_gathering(run.solver);
  inputs.spectral_radius = inputs.spectral_radius_lower = std::nan("");
  inputs.configuration = run.configuration;
  if (auto seed = run.parameters.find("seed"); seed != run.parameters.end())
    inputs.solver_seed = seed->second;
  if (current.problem) {
    inputs.elements = current.problem->mesh.size();
    inputs.channels = current.problem->system->channels();
  }
  return inputs;
}

// The run.json of a failed run: what identifies it (its solver's options once they parsed) and
// why it failed. A run.json that cannot be written is a warning: the summary row says it all.
void write_failed_run_json(const RunRequest& request, const Problem* problem, bool parsed,
                           ExitCode code, const std::string& message) {
  try {
    JsonWriter json;
    begin_run_json(json, request, problem, parsed ? &request.solver_parameters.values() : nullptr);
    json.key("run").begin_object();
    json.field("budget", request.budget.describe());
    json.field("stop_reason", failure_stop_reason(code));
    json.field("error", message);
    json.field("exit_code", int(code));
    json.end_object();
    json.end_object();
    json.save(request.outputs.json);
  } catch (const InputError& e) {
    log::warning(request.labels.run_id + ": " + e.what());
  }
}

// One run: its trace and summary rows into the partial folder, its run.json, radiosities, images
// and coverage into the sweep folder. A failure is recorded (report.failures, a failed summary
// row, a run.json saying why) and the sweep goes on.
void run_one(const ExperimentSpec& spec, const SweepPlan& plan, const PlannedRun& run,
             const std::string& stem, const std::filesystem::path& out, CurrentProblem& current,
             SweepReport& report) {
  RunRequest request = planned_request(spec, plan, run, stem, out);
  SummaryInputs inputs = summary_inputs(run, request, current);

  // This run's rows wait in the partial folder (short names, by index) until the sweep ends.
  // The summary row is written last: a run whose summary rows are in place is complete.
  TraceWriter trace(partial_file(out, run.index, "trace").string());
  request.outputs.trace_sink = &trace;
  const std::string summary_path = partial_file(out, run.index, "summary").string();

  // Everything from here may fail; a failure is recorded and the sweep goes on. Its run.json
  // is written when its name can be (a run id too long for a file name has none).
  bool parsed = false;  // the solver's parameters (run.json names them once they parse)
  auto record_failure = [&](ExitCode code, const std::string& message) {
    log::info(run.run_id + ": failed: " + message);
    report.failures.push_back({run.index, run.run_id, code, message});
    if (!trace.closed()) trace.close();
    write_failed_run_json(request, current.problem.get(), parsed, code, message);
    CsvWriter summary(summary_path, summary_columns());
    write_failed_summary_row(summary, inputs, failure_stop_reason(code), message);
    summary.close();
  };
  if (stem.size() + kLongestSuffix > kMaxFileName) {
    record_failure(ExitCode::kInvalidInput,
                   "run id too long for a file name (" + std::to_string(stem.size()) +
                       " bytes; the file system allows " + std::to_string(kMaxFileName) +
                       " with the longest suffix radlab adds)");
    return;
  }
  if (!current.problem) {
    record_failure(current.code, current.error);
    return;
  }
  const Problem& problem = *current.problem;

  RunResult result;
  try {
    request.solver_parameters =
        ParamBag::from_assignments(assignments_of(run), "solver '" + run.solver + "'");
    parsed = true;
    inputs.labels.params = request.labels.params = request.solver_parameters.canonical();
    if (inputs.gathering && problem.has_matrix()) {
      if (std::isnan(current.spectral_radius.upper))
        current.spectral_radius = worst_spectral_radius(problem);
      inputs.spectral_radius = current.spectral_radius.upper;
      inputs.spectral_radius_lower = current.spectral_radius.lower;
    }
    request.schedule = run_schedule(spec, inputs.gathering, problem.mesh.size());
    request.hook = image_and_coverage_hook(spec, run, stem, out, current);
    result = execute_run(request, problem).result;
  } catch (const Error& e) {
    record_failure(e.code(), e.what());
    return;
  } catch (const std::bad_alloc&) {
    record_failure(ExitCode::kNumerical, run.run_id + ": out of memory");
    return;
  }
  CsvWriter summary(summary_path, summary_columns());
  write_summary_row(summary, inputs, result);
  summary.close();
}

// Every run is done: trace.csv and summary.csv from the runs' rows in run order.
void write_sweep_tables(const std::filesystem::path& out, const std::vector<size_t>& shard_runs) {
  OutputFile trace_csv((out / "trace.csv").string());
  OutputFile summary_csv((out / "summary.csv").string());
  trace_csv.write(text::join(trace_columns(), ",") + "\n");
  summary_csv.write(text::join(summary_columns(), ",") + "\n");
  for (size_t index : shard_runs) {
    append_rows(trace_csv, partial_file(out, index, "trace"));
    append_rows(summary_csv, partial_file(out, index, "summary"));
  }
  trace_csv.commit();
  summary_csv.commit();
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
  const SweepIdentity identity = sweep_identity(
      spec, plan, std::to_string(options.shard_index) + "/" + std::to_string(options.shard_count));

  // One writer per folder; then decide between resuming, replacing and refusing.
  SweepFolderLock lock(out);
  std::string note;
  const bool resume = prepare_sweep_folder(out, identity, options.overwrite, note);
  if (!note.empty()) log::info(note);
  make_sweep_folders(out, spec);

  SweepReport report;
  report.runs_total = plan.runs.size();
  std::vector<std::string> run_ids;
  std::map<size_t, ProblemEntry> problem_entries;  // for sweep.json, by problem index
  write_sweep_json(out, spec, options, identity, plan.runs.size(), "running", run_ids,
                   report.failures, problem_entries);

  CurrentProblem current;
  std::vector<size_t> shard_runs;  // indices of this shard's runs, in order
  for (const PlannedRun& run : plan.runs) {
    if (int(run.index % size_t(options.shard_count)) != options.shard_index) continue;
    const std::string stem = file_stem(run.run_id);
    shard_runs.push_back(run.index);
    run_ids.push_back(run.run_id);
    ++report.runs_done;
    const PlannedProblem& planned = plan.problems[run.problem];
    const std::vector<SourceFile>& scene_files = identity.scene_files.at(planned.spec.scene);
    if (resume && keep_completed_run(out, plan, run, stem, scene_files, report, problem_entries))
      continue;
    if (run.problem != current.index) {
      current.prepare(spec, planned, run.problem, scene_files);
      problem_entries[run.problem] =
          problem_entry(run.problem, planned, current.problem.get(), current.error);
    }
    log::info("[" + std::to_string(run.index + 1) + "/" + std::to_string(plan.runs.size()) + "] " +
              run.run_id);
    run_one(spec, plan, run, stem, out, current, report);
  }

  // trace.csv and summary.csv, then sweep.json says "complete" with the manifest of every file
  // (merge and the workflow check it), then the partial rows go.
  write_sweep_tables(out, shard_runs);
  // A shard holds only some of a configuration's seeds: its aggregate is the merge's to write.
  if (options.shard_count == 1)
    write_seed_aggregate(read_csv((out / "summary.csv").string()),
                         (out / "aggregate.csv").string());
  const std::vector<ManifestEntry> manifest = folder_manifest(out);
  write_sweep_json(out, spec, options, identity, plan.runs.size(), "complete", run_ids,
                   report.failures, problem_entries, &manifest);
  std::error_code ignored;
  fs::remove_all(partial_folder(out), ignored);
  return report;
}

}  // namespace radlab
