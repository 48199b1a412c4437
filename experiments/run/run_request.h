// One run as one library call: a RunRequest says everything about a run (the problem, what it is
// measured against, the solver and its parameters, the budget, the checkpoints, the files to
// write), and execute_run carries it out. `radlab solve` builds one request from its options,
// each run of a sweep builds one from the experiment file, and any other front end (a Python
// API) does the same; the run itself is assembled in one place, so the two cannot drift.
//
// A request is validated where it is built, in its builder's words: the budget with
// budget_violation (runner.h), the rest by the builder. execute_run trusts it.
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/json.h"
#include "core/param_bag.h"
#include "experiments/problem/problem.h"
#include "experiments/run/runner.h"
#include "experiments/run/trace.h"

namespace radlab {

// What a run is measured against (experiments/problem/stand_in_reference.h).
struct ReferenceChoice {
  std::string kind = "certified";     // certified | none | hierarchical-fine
  double feps = 0.0025, aeps = 1e-5;  // of the hierarchical-fine stand-in
};

// The files a run writes; an empty path writes nothing.
struct RunOutputs {
  std::string trace;  // trace CSV, created and owned by the run (absent if the run fails)
  // Or a trace the caller owns (a sweep's partial file, kept up to a failure); not both.
  TraceWriter* trace_sink = nullptr;
  std::string radiosity;  // final radiosities CSV (write_radiosity_csv)
  std::string json;       // run.json
  std::string image;      // EXR of the final solution, PNG beside it
  int width = 512, height = 512;
  bool display_image = true;  // the image shows display() (else solution())
  bool announce = true;       // log each file written (a sweep's runs do not)
};

// run.json's identity fields besides run_id, written when set: who asked for the run.
struct RunIdentity {
  std::string command;              // the command line (`radlab solve`)
  std::optional<size_t> run_index;  // position in a sweep
  std::string experiment;           // the experiment file of a sweep
};

struct RunRequest {
  ProblemSpec problem;
  ReferenceChoice reference;
  std::string solver;
  ParamBag solver_parameters;  // parsed from key=value when the request is built
  Budget budget;               // validated when the request is built (budget_violation)
  CheckpointSchedule schedule;
  RunLabels labels;  // run_id, scene, solver, canonical parameters
  RunIdentity identity;
  RunOutputs outputs;
  CheckpointHook hook;  // called at every checkpoint (a sweep's images and coverage)
};

// What a run produced: the measurements, the solver (its final solution, its statistics) and the
// problem it ran on (owned when execute_run prepared it).
struct RunOutcome {
  RunResult result;
  std::unique_ptr<Solver> solver;
  std::unique_ptr<Problem> owned_problem;
  const Problem* problem = nullptr;
};

// The problem of a request, prepared with its reference choice: `none` and `hierarchical-fine`
// skip the dense matrix (rows on the fly); `hierarchical-fine` then runs the stand-in. A
// tolerance without the certified reference is a UsageError. `rows_read` false (the run's
// solvers are all matrix-free, SolverInfo::matrix_free) prepares rows on the fly too: no matrix
// is built for the solver, and the certified reference, when the cache holds it, is certified
// with rows on the fly (as --ff-mode on-the-fly); only a reference missing from the cache builds
// the matrix, for itself.
std::unique_ptr<Problem> prepare_run_problem(const ProblemSpec& spec,
                                             const ReferenceChoice& reference, const Budget& budget,
                                             bool rows_read = true);

// Runs the request on `problem` (shared by the runs of a sweep) and writes its outputs: trace,
// radiosities, image, run.json. Errors propagate (a caller owning outputs.trace_sink closes it).
RunOutcome execute_run(const RunRequest& request, const Problem& problem);

// The same on the request's own problem, prepared first (prepare_run_problem).
RunOutcome execute_run(const RunRequest& request);

// Opens a run's run.json with what identifies it: the run, the build, the problem and the
// solver's options (the last two when known: a run can fail before either exists).
void begin_run_json(JsonWriter& json, const RunRequest& request, const Problem* problem,
                    const std::map<std::string, std::string>* options);

}  // namespace radlab
