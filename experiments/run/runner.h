// The runner measures; solvers compute (DESIGN §4, like Ceres' iteration callbacks and pbrt's
// render loop). It times every step() (the clock excludes metric evaluation), evaluates the
// metrics at a checkpoint schedule (every step early on, then geometrically spaced), writes the
// trace, enforces the budget, and detects numerical trouble: non-finite values, divergence
// (absolute and relative), and stagnation when a tolerance is asked for (judged over a window
// long enough for the slowest stationary method at the scene's spectral radius; docs/reference.md).
#pragma once

#include <exception>
#include <functional>
#include <new>
#include <optional>
#include <string>
#include <vector>

#include "core/error.h"
#include "experiments/problem/problem.h"
#include "experiments/run/trace.h"
#include "metrics/error_metrics.h"
#include "solvers/solver.h"

namespace radlab {

struct Budget {
  std::optional<long long> steps;  // solver steps
  std::optional<long long> rows;   // form-factor rows
  std::optional<double> seconds;   // solver seconds (metric evaluation excluded)
  std::optional<double> tol;       // certified relative error bound ||B-B*||_inf / max B*
  // The tolerance is relative to the reflected light, max(B* - E), instead of max B*. A scene
  // lit by a tiny bright lamp has max B* at the lamp: a bound of 1e-9 of it can leave the room
  // (B - E) several per cent off (docs/stability.md, the tiny-light column).
  bool tol_of_reflected = false;

  bool empty() const { return !steps && !rows && !seconds && !tol; }
  std::string describe() const;
  // The stop reason ("step budget", "row budget", "time budget") once the step, row or time
  // budget is used up, else null. The tolerance is checked by the runner (it needs the bound).
  const char* exhausted(long long step, unsigned long long rows, double seconds) const;
};

// A budget field that can never be reached (a run would go on forever): steps or rows < 1,
// seconds not finite and > 0, tol outside (0,1). `field` is the Budget member's name
// ("steps", "rows", "seconds", "tol"), `requirement` what it must be, `given` its value.
struct BudgetViolation {
  std::string field, requirement, given;
};
// The rules, written once; whoever builds a run request (the command line, an experiment file)
// calls it and reports the violation in its user's words (--steps, file:line budget.steps).
std::optional<BudgetViolation> budget_violation(const Budget& budget);

struct CheckpointSchedule {
  long long every_step_until = 10;  // evaluate at steps 0..every_step_until
  double growth = 1.2;              // then at steps growing by this factor
  std::vector<long long> extra;     // and at these steps

  // The first checkpoint after `step`.
  long long next_after(long long step) const;
};

struct RunLabels {
  std::string run_id, scene, solver, params;
};

// The mean-of-channels metrics at one checkpoint, kept for the summary and the fits.
struct CheckpointRecord {
  long long step = 0;
  unsigned long long rows = 0;
  unsigned long long pair_evals = 0;
  double seconds = 0.0;
  double seconds_with_setup = 0.0;  // seconds + the set-up the run has depended on so far
  double cpu_seconds = 0.0;         // the process's CPU time over the span of `seconds`
  double rms_rel = 0.0, p_mean = 0.0, rms_rel_display = 0.0, p_mean_display = 0.0;
  double rms_rel_reflected = 0.0;
  double bound_relative = 0.0;
};

struct RunResult {
  std::vector<CheckpointRecord> history;
  long long steps = 0;
  unsigned long long rows = 0, rays = 0, pair_evals = 0;
  double seconds = 0.0;
  // The set-up the run depended on (setup_seconds(): the matrix's or the patch rows' build time
  // once the run has read a row of them, else 0) and seconds plus it.
  double setup_seconds = 0.0, seconds_with_setup = 0.0;
  // The process's CPU time over the span of `seconds` (core/cpu_time.h): every thread's.
  double cpu_seconds = 0.0;
  std::string stop_reason;
  std::string reference_kind = "none";  // Reference::kind, or "none" without a reference
  ErrorMetrics final_errors;            // on the mean of the channels, solution()
  ErrorMetrics final_display_errors;    // on the mean of the channels, display()
  ReflectedRms final_reflected;         // on the mean of the channels, solution() - E
  double final_bound_relative = 0.0;    // certified ||B-B*||_inf / max B*, if a matrix exists
  // The same bound relative to the reflected light: ||B-B*||_inf / max(B* - E); NaN without a
  // reference or when nothing is reflected.
  double final_bound_relative_reflected = 0.0;
  bool tolerance_of_reflected = false;  // the tolerance was relative to max(B* - E)
  // With a tolerance in the budget: whether the certified bound reached it. False means another
  // budget (or the 1,000-sweep cap of a tolerance alone) stopped the run first; `radlab solve`
  // then exits 5 (docs/outputs.md).
  bool tolerance_asked = false;
  bool tolerance_reached = false;
  // "tolerance 1e-10 not reached: ..." when asked and not reached, else empty.
  std::string tolerance_message;
  // The solver's own counters at the end (Solver::statistics(): links, rays, refinements ...),
  // and what execute_run adds (adaptive-shooting's final system on two levels): run.json's
  // solver_statistics and the summary's solver_statistics column.
  std::vector<std::pair<std::string, double>> statistics;
};

// Calls `f` (solver code: a plugin's, maybe) so that what it throws stays this run's failure: a
// radlab Error and std::bad_alloc pass unchanged; any other exception becomes a NumericalError
// (exit 4) naming the run, the solver, `call` and the exception's message, so that a sweep
// records the run as failed and goes on instead of ending as an internal error.
template <class F>
auto call_solver(const RunLabels& labels, const char* call, F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const Error&) {
    throw;
  } catch (const std::bad_alloc&) {
    throw;
  } catch (const std::exception& e) {
    throw NumericalError(labels.run_id + ": solver '" + labels.solver + "' threw from " + call +
                         ": " + e.what());
  } catch (...) {
    throw NumericalError(labels.run_id + ": solver '" + labels.solver + "' threw from " + call +
                         " something that is not a std::exception");
  }
}

// The solver interface's contract on a field the runner reads (solution(), display(),
// unshot()): one value per element of the system and one channel or three per the system,
// checked before anything reads it (a plugin returning the wrong size made radlab read out of
// bounds). NumericalError naming the run, the solver and `what` otherwise.
void check_solver_field(const Radiosity& field, const System& system, const RunLabels& labels,
                        const char* what);

// The set-up seconds a run on `problem` depends on once it has read `rows` form-factor rows: the
// build time of the dense matrix the System serves rows from (BuildReport::seconds, the original
// build's when the matrix came from the cache) or of the two-level patch rows; 0 before the first
// row, and 0 for rows on the fly (computed, and timed, inside the steps), for solvers that read no
// row (the Monte Carlo ones, hierarchical: their rays and refinement are in their steps) and for
// a matrix built only for the reference. Docs: docs/outputs.md (`seconds_with_setup`).
double setup_seconds(const Problem& problem, unsigned long long rows);

// Called at every checkpoint after the metrics are written (e.g. to save images).
using CheckpointHook = std::function<void(long long step, const Solver& solver)>;

RunResult run_solver(Solver& solver, const Problem& problem, const Budget& budget,
                     const CheckpointSchedule& schedule, const RunLabels& labels,
                     TraceWriter* trace, const CheckpointHook& hook = {});

}  // namespace radlab
