#include "experiments/run/runner.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "core/cpu_time.h"
#include "core/error.h"
#include "core/log.h"
#include "core/progress.h"
#include "core/text.h"
#include "experiments/problem/two_level_problem.h"
#include "solvers/registry.h"

namespace radlab {

std::optional<BudgetViolation> budget_violation(const Budget& budget) {
  if (budget.steps && *budget.steps < 1)
    return BudgetViolation{"steps", "must be >= 1", std::to_string(*budget.steps)};
  if (budget.rows && *budget.rows < 1)
    return BudgetViolation{"rows", "must be >= 1", std::to_string(*budget.rows)};
  if (budget.seconds && !(*budget.seconds > 0 && std::isfinite(*budget.seconds)))
    return BudgetViolation{"seconds", "must be a finite number > 0",
                           text::format_double(*budget.seconds)};
  if (budget.tol && !(*budget.tol > 0 && *budget.tol < 1))
    return BudgetViolation{"tol", "must lie in (0,1) (a bound relative to max B*)",
                           text::format_double(*budget.tol)};
  return std::nullopt;
}

const char* Budget::exhausted(long long step, unsigned long long rows_used,
                              double seconds_used) const {
  if (steps && step >= *steps) return "step budget";
  if (rows && static_cast<long long>(rows_used) >= *rows) return "row budget";
  if (seconds && seconds_used >= *seconds) return "time budget";
  return nullptr;
}

std::string Budget::describe() const {
  std::vector<std::string> parts;
  if (steps) parts.push_back(std::to_string(*steps) + " steps");
  if (rows) parts.push_back(std::to_string(*rows) + " rows");
  if (seconds) parts.push_back(text::format_double(*seconds) + " s");
  // The scale is part of the claim: 1e-9 of max B* and 1e-9 of the reflected light differ by
  // orders of magnitude on a scene with a small bright lamp.
  if (tol)
    parts.push_back("bound <= " + text::format_double(*tol) +
                    (tol_of_reflected ? " of max(B* - E)" : " of max B*"));
  return parts.empty() ? "none" : text::join(parts, ", ");
}

double setup_seconds(const Problem& problem, unsigned long long rows) {
  if (rows == 0 || !problem.system) return 0.0;
  if (problem.system->two_level()) return problem.patch_row_report.seconds;
  // Rows from the dense matrix (cached rows); on the fly they cost their steps' time.
  if (problem.system->matrix() != nullptr) return problem.build.seconds;
  return 0.0;
}

long long CheckpointSchedule::next_after(long long step) const {
  long long next = step + 1;
  if (next > every_step_until) {
    // Geometric: the smallest step of the form ceil(every_step_until * growth^k) beyond `step`.
    double s = double(std::max<long long>(every_step_until, 1));
    while (static_cast<long long>(std::ceil(s)) <= step) s *= growth;
    next = static_cast<long long>(std::ceil(s));
  }
  for (long long e : extra)
    if (e > step) next = std::min(next, e);
  return next;
}

void check_solver_field(const Radiosity& field, const System& system, const RunLabels& labels,
                        const char* what) {
  if (field.size() == system.size() && field.channels() == system.channels() &&
      field.raw().size() == system.size() * size_t(system.channels()))
    return;
  throw NumericalError(
      labels.run_id + ": solver '" + labels.solver + "' returned from " + what + " " +
      std::to_string(field.size()) + " elements x " + std::to_string(field.channels()) +
      " channels; the system has " + std::to_string(system.size()) + " x " +
      std::to_string(system.channels()) +
      " (a solver must return one value per element and channel: solvers/solver.h)");
}

namespace {

bool all_finite(const Radiosity& field) {
  for (double v : field.raw())
    if (!std::isfinite(v)) return false;
  return true;
}

class Evaluator {
 public:
  Evaluator(const Problem& problem, const RunLabels& labels, TraceWriter* trace)
      : problem_(problem), labels_(labels), trace_(trace) {
    if (problem.reference) {
      const Radiosity& emission = problem.system->emission();
      for (int c = 0; c < problem.reference->B.channels(); ++c) {
        const auto b = problem.reference->B.channel(c);
        const auto e = emission.channel(c);
        for (size_t i = 0; i < b.size(); ++i) {
          max_reference_ = std::max(max_reference_, b[i]);
          max_reflected_ = std::max(max_reflected_, b[i] - e[i]);
        }
      }
    }
    for (double v : problem.system->emission().raw())
      max_emission_ = std::max(max_emission_, std::abs(v));
  }

  // Writes the checkpoint rows; returns the certified relative bound (NaN if unavailable).
  double evaluate(const Solver& solver, long long step, unsigned long long rows, double seconds,
                  double cpu_seconds, unsigned long long rays, unsigned long long pair_evals,
                  RunResult& result) {
    const System& system = *problem_.system;
    const double with_setup = seconds + setup_seconds(problem_, rows);
    const Radiosity& B =
        call_solver(labels_, "solution()", [&]() -> const Radiosity& { return solver.solution(); });
    check_solver_field(B, system, labels_, "solution()");
    if (!all_finite(B))
      throw NumericalError(labels_.run_id + ": non-finite radiosity at step " +
                           std::to_string(step) + " (the solver diverged)");
    const Radiosity display = call_solver(labels_, "display()", [&] { return solver.display(); });
    check_solver_field(display, system, labels_, "display()");
    if (!all_finite(display))
      throw NumericalError(labels_.run_id + ": non-finite display() values at step " +
                           std::to_string(step) + " from solver '" + labels_.solver + "'");
    const Radiosity* unshot = call_solver(labels_, "unshot()", [&] { return solver.unshot(); });
    if (unshot) check_solver_field(*unshot, system, labels_, "unshot()");
    const std::vector<double> residual = residual_of(B);
    const double inverse_norm =
        problem_.reference ? problem_.reference->inverse_norm_bound : std::nan("");
    const auto area = problem_.system->area();
    const int channels = B.channels();
    double worst_residual = 0.0;
    for (double r : residual) worst_residual = std::max(worst_residual, r);
    if (!residual.empty()) check_divergence(worst_residual, step);

    // One row for the mean of the channels, then one per channel when there are three.
    std::vector<int> fields = {kMeanOfChannels};
    if (channels == 3) fields.insert(fields.end(), {0, 1, 2});
    const char* names[] = {"r", "g", "b"};
    const std::string statistics =
        statistics_field(call_solver(labels_, "statistics()", [&] { return solver.statistics(); }));
    for (int field : fields) {
      TraceCheckpoint row{.labels = labels_,
                          .problem = problem_,
                          .solver = solver,
                          .field = field,
                          .channel = field == kMeanOfChannels ? "mean" : names[field],
                          .step = step,
                          .ff_rows = rows,
                          .rays = rays,
                          .pair_evals = pair_evals,
                          .seconds = seconds,
                          .seconds_with_setup = with_setup,
                          .cpu_seconds = cpu_seconds,
                          .B = B,
                          .unshot = unshot,
                          .measured = problem_.reference.has_value(),
                          .errors = {},
                          .display = {},
                          .reflected = {},
                          .residual_inf = std::nan(""),
                          .bound_inf = std::nan(""),
                          .statistics = statistics};
      if (problem_.reference) {
        row.errors = compare(B, problem_.reference->B, area, field);
        row.display = compare(display, problem_.reference->B, area, field);
        row.reflected =
            compare_reflected(B, problem_.reference->B, problem_.system->emission(), area, field);
      }
      if (!residual.empty()) {
        row.residual_inf = field == kMeanOfChannels ? worst_residual : residual[size_t(field)];
        row.bound_inf = row.residual_inf * inverse_norm;
      }
      if (trace_) trace_->write(row);
      if (field == kMeanOfChannels) {
        result.final_errors = row.errors;
        result.final_display_errors = row.display;
        result.final_reflected = row.reflected;
      }
    }
    const double bound = residual.empty() ? std::nan("") : worst_residual * inverse_norm;
    return max_reference_ > 0 ? bound / max_reference_ : bound;
  }

  // ||E - (I - J) B||_inf per channel, from the matrix or the patch rows; empty without either.
  std::vector<double> residual_of(const Radiosity& B) const {
    if (problem_.has_matrix())
      return residual_inf(*problem_.system, problem_.certified_matrix(), B);
    if (problem_.system->two_level() && problem_.reference)
      return two_level_residual(problem_, B);  // from the patch rows (two_level_problem.h)
    return {};
  }

  // Divergence: the residual grew by 1e8 over the initial one AND over ||E||_inf, the residual
  // of B = 0. The absolute scale matters when the initial residual is near zero: a matrix whose
  // rows never see a tiny lamp has residual ~0 at B = E, and any light the lamp's own row shoots
  // "grows" it by orders of magnitude without anything diverging.
  void check_divergence(double worst_residual, long long step) {
    if (initial_residual_ < 0) initial_residual_ = worst_residual;
    const double scale = std::max(initial_residual_, max_emission_);
    if (worst_residual > 1e8 * std::max(scale, 1e-300) && worst_residual > 0)
      throw NumericalError(labels_.run_id + ": diverging: residual grew from " +
                           text::format_double(initial_residual_) + " to " +
                           text::format_double(worst_residual) + " by step " +
                           std::to_string(step) + ", 1e8 times both the initial residual and " +
                           "||E||_inf = " + text::format_double(max_emission_));
  }

  // max B* / max(B* - E): turns a bound relative to max B* into one relative to the reflected
  // light (NaN when there is no reference or nothing is reflected).
  double reflected_scale() const {
    return max_reflected_ > 0 && max_reference_ > 0 ? max_reference_ / max_reflected_
                                                    : std::nan("");
  }

 private:
  const Problem& problem_;
  const RunLabels& labels_;
  TraceWriter* trace_;
  double max_reference_ = 0.0;
  double max_reflected_ = 0.0;  // max over elements and channels of B* - E
  double max_emission_ = 0.0;
  double initial_residual_ = -1.0;
};

// Stagnation, with a tolerance to reach: the best certified bound of the second half of the
// work is not 1% below the best of the first half. Judged only once that half spans
// max(20, ln 2 / -ln r) sweeps, r the reference's upper bound on the spectral radius of
// diag(rho)F: Jacobi, the slowest stationary method here, gains a factor r per sweep, so over
// that window it halves its error. A slower solver (damped Jacobi at omega = 1/2 gains
// 1 - (1-r)/2) still gains ~30%, far above 1%. Best-of-half, not the bound at one checkpoint:
// mid-sweep a gathering solver's iterate mixes two sweeps and its inf-norm residual oscillates.
// Returns a stop reason instead of throwing when the run has converged to the certifiable floor
// (issue 35.3): its best bound is within kFloorBand of the reference's own certified bound,
// which a double iterate cannot beat (its residual holds the same rounding of B* to double and
// the same rounding bound of the residual sum), so it is not stagnant.
constexpr double kFloorBand = 10.0;
std::string check_stagnation(const Problem& problem, const RunResult& result, double bound,
                             const std::string& tolerance, const std::string& run_id) {
  const double n = double(problem.system->size());
  const double rows_now = double(problem.system->rows_used());
  const double r = problem.reference ? problem.reference->spectral_radius_upper : 0.0;
  const double sweeps = r > 0.0 && r < 1.0 ? std::max(20.0, std::log(2.0) / -std::log(r)) : 20.0;
  if (rows_now < 2.0 * sweeps * n) return {};
  double before = std::numeric_limits<double>::infinity(), after = bound;
  for (const CheckpointRecord& c : result.history) {
    if (!std::isfinite(c.bound_relative)) continue;
    if (double(c.rows) <= 0.5 * rows_now)
      before = std::min(before, c.bound_relative);
    else
      after = std::min(after, c.bound_relative);
  }
  if (!std::isfinite(before) || after < 0.99 * before) return {};
  const double floor = problem.reference ? problem.reference->bound_relative : 0.0;
  if (after <= kFloorBand * floor)
    return "converged: the tolerance is below the certifiable floor (the reference's own bound " +
           text::format_double(floor) + " of max B*; a solution in double is certified within " +
           text::format_double(kFloorBand) + "x of it at best)";
  std::string why =
      "the best bound of the last " + text::format_double(0.5 * rows_now) + " rows (" +
      text::format_double(after) + ") is not 1% below the best before (" +
      text::format_double(before) + "), over " + std::to_string(long(std::ceil(sweeps))) +
      "+ sweeps in which a solver converging at the spectral radius (<= " + text::format_double(r) +
      " per sweep) halves its error";
  if (problem.computed.size() > 0 ||
      (problem.system->two_level() && problem.patch_rows.precision() == Precision::kFloat))
    why +=
        ". F is stored in float and the certificate is of the double-precision F: float "
        "rounding floors the bound (use --precision double to go lower)";
  throw NumericalError(run_id + ": stagnated at certified relative bound " +
                       text::format_double(bound) + " of max B* (tolerance " + tolerance +
                       "): " + why);
}

// The mean-of-channels metrics of the checkpoint just evaluated, for the summary and the fits.
CheckpointRecord checkpoint_record(const Problem& problem, const RunResult& result, long long step,
                                   double seconds, double cpu_seconds, double bound) {
  const System& system = *problem.system;
  CheckpointRecord record;
  record.step = step;
  record.rows = system.rows_used();
  record.pair_evals = system.pair_evaluations();
  record.seconds = seconds;
  record.seconds_with_setup = seconds + setup_seconds(problem, record.rows);
  record.cpu_seconds = cpu_seconds;
  const double nan = std::nan("");
  const bool measured = problem.reference.has_value();
  record.rms_rel = measured ? result.final_errors.rms_rel : nan;
  record.p_mean = measured ? result.final_errors.p_mean : nan;
  record.rms_rel_display = measured ? result.final_display_errors.rms_rel : nan;
  record.p_mean_display = measured ? result.final_display_errors.p_mean : nan;
  record.rms_rel_reflected = measured ? result.final_reflected.rms_rel : nan;
  record.bound_relative = bound;
  return record;
}

// The budget the run keeps: never unbounded (no budget: 3n steps; a tolerance alone: capped at
// 1000 sweeps' worth of rows, and stagnation stops it sooner), and a tolerance on the reflected
// light converted once to the max-B* scale the bounds are computed in (`scale` = max B* /
// max(B* - E)), so the stop test and the stagnation test need no second scale.
Budget kept_budget(const Budget& asked, const Problem& problem, double scale) {
  const System& system = *problem.system;
  Budget budget = asked;
  if (budget.tol && !problem.reference)
    throw UsageError("--tol needs the reference (it bounds the error with its certificate)");
  if (budget.empty()) budget.steps = 3 * static_cast<long long>(system.size());
  if (!budget.steps && !budget.rows && !budget.seconds)
    budget.rows = 1000 * static_cast<long long>(system.size());
  if (budget.tol && budget.tol_of_reflected) {
    if (!std::isfinite(scale))
      throw UsageError("--tol-of reflected: the reference reflects no light (max(B* - E) = 0)");
    budget.tol = *budget.tol / scale;
  }
  // No bound can go below the reference's own (issue 35.3): refuse such a tolerance up front.
  if (budget.tol && problem.reference && problem.reference->kind == "certified" &&
      *budget.tol < problem.reference->bound_relative) {
    const double floor = problem.reference->bound_relative;
    throw UsageError("--tol " + text::format_double(*asked.tol) +
                     (budget.tol_of_reflected ? " of max(B* - E)" : " of max B*") +
                     " is below the certifiable floor: the reference's own certified bound is " +
                     text::format_double(floor) + " of max B*" +
                     (budget.tol_of_reflected
                          ? " (" + text::format_double(floor * scale) + " of max(B* - E))"
                          : std::string()) +
                     ", and no solution in double can be certified closer");
  }
  return budget;
}

// The tolerance as the messages say it: "1e-06 of max B*", or "... i.e. 1e-3 of max(B* - E)".
std::string tolerance_text(const Budget& budget, const Budget& asked) {
  if (!budget.tol) return std::string();
  if (!budget.tol_of_reflected) return text::format_double(*budget.tol) + " of max B*";
  return text::format_double(*budget.tol) + " of max B*, i.e. " + text::format_double(*asked.tol) +
         " of max(B* - E)";
}

// The run's totals and, with a tolerance, its verdict.
void finish_result(RunResult& result, const Problem& problem, const Solver& solver,
                   const RunLabels& labels, const Budget& budget, const Budget& asked, double bound,
                   double scale, double seconds, double cpu_seconds, long long step) {
  const System& system = *problem.system;
  result.steps = step;
  result.rows = system.rows_used();
  result.rays = system.rays_used();
  result.pair_evals = system.pair_evaluations();
  result.reference_kind = problem.reference ? problem.reference->kind : "none";
  result.seconds = seconds;
  result.setup_seconds = setup_seconds(problem, result.rows);
  result.seconds_with_setup = seconds + result.setup_seconds;
  result.cpu_seconds = cpu_seconds;
  result.final_bound_relative = bound;
  result.final_bound_relative_reflected = bound * scale;
  result.tolerance_of_reflected = budget.tol_of_reflected;
  result.statistics = call_solver(labels, "statistics()", [&] { return solver.statistics(); });
  if (!budget.tol) return;
  result.tolerance_asked = true;
  result.tolerance_reached = bound <= *budget.tol;
  if (result.tolerance_reached) return;
  const std::string of = budget.tol_of_reflected ? " of max(B* - E)" : " of max B*";
  const double reached = budget.tol_of_reflected ? bound * scale : bound;
  result.tolerance_message = "tolerance " + text::format_double(asked.tol.value_or(0.0)) + of +
                             " not reached: certified bound " + text::format_double(reached) + of +
                             " when the run stopped (" + result.stop_reason + ")" +
                             (asked.steps || asked.rows || asked.seconds
                                  ? ""
                                  : " (a tolerance alone is capped at 1000 sweeps' worth of rows)");
}

}  // namespace

RunResult run_solver(Solver& solver, const Problem& problem, const Budget& budget_in,
                     const CheckpointSchedule& schedule, const RunLabels& labels,
                     TraceWriter* trace, const CheckpointHook& hook) {
  // The budget was validated where the run's request was built (budget_violation).
  const System& system = *problem.system;
  RunResult result;
  Evaluator evaluator(problem, labels, trace);
  const double scale = evaluator.reflected_scale();
  const Budget budget = kept_budget(budget_in, problem, scale);
  if (!budget.steps && !budget.seconds && needs_step_or_time_budget(labels.solver))
    throw UsageError(labels.solver +
                     " reads no form-factor rows and never finishes by itself: a budget in rows "
                     "(or a tolerance alone) cannot end its run; give steps or seconds");
  const std::string tolerance = tolerance_text(budget, budget_in);
  using Clock = std::chrono::steady_clock;
  system.reset_counters();
  // CPU time is read at the checkpoints only, less the evaluations' own: a read costs ~0.2 us (a
  // system call, where the wall clock's is ~20 ns), more than a step of a small cached solve.
  // What it counts beyond the steps is the runner's budget check between them.
  const double cpu0 = process_cpu_seconds();
  double cpu_in_evaluations = 0.0;
  auto t0 = Clock::now();
  call_solver(labels, "init()", [&] { solver.init(system); });
  double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  double cpu_seconds = 0.0;  // at the last checkpoint

  const double total = budget.steps  ? double(*budget.steps)
                       : budget.rows ? double(*budget.rows)
                                     : 0.0;
  Progress progress(labels.run_id, budget.steps ? "steps" : "rows", total);
  long long step = 0;
  long long next_checkpoint = schedule.next_after(0);
  auto checkpoint = [&]() {
    const double cpu_now = process_cpu_seconds();
    cpu_seconds = cpu_now - cpu0 - cpu_in_evaluations;
    const double bound = evaluator.evaluate(solver, step, system.rows_used(), seconds, cpu_seconds,
                                            system.rays_used(), system.pair_evaluations(), result);
    result.history.push_back(checkpoint_record(problem, result, step, seconds, cpu_seconds, bound));
    if (hook) hook(step, solver);
    cpu_in_evaluations += process_cpu_seconds() - cpu_now;
    return bound;
  };

  double bound = checkpoint();
  for (;;) {
    if (budget.tol && bound <= *budget.tol) {
      result.stop_reason = "tolerance reached";
      break;
    }
    if (const char* reason = budget.exhausted(step, system.rows_used(), seconds)) {
      result.stop_reason = reason;
      // Said, not left to be read as convergence (issue 35.5: hierarchical on the rho 0.999
      // cube stopped at rms_rel 0.75 after the 3n default passes it cannot converge in).
      if (budget_in.empty())
        result.stop_reason += " (the default of 3n = " + std::to_string(*budget.steps) +
                              " steps, no budget given; the solver had not finished)";
      break;
    }
    auto start = Clock::now();
    const StepInfo info = call_solver(labels, "step()", [&] { return solver.step(); });
    seconds += std::chrono::duration<double>(Clock::now() - start).count();
    ++step;
    progress.update(budget.steps ? double(step) : double(system.rows_used()));

    const bool at_end =
        info.finished || budget.exhausted(step, system.rows_used(), seconds) != nullptr;
    if (step == next_checkpoint || at_end) {
      bound = checkpoint();
      next_checkpoint = schedule.next_after(step);
      if (budget.tol) {
        const std::string floor =
            check_stagnation(problem, result, bound, tolerance, labels.run_id);
        if (!floor.empty()) {
          result.stop_reason = floor;
          break;
        }
      }
    }
    if (info.finished) {
      result.stop_reason = "solver finished";
      break;
    }
  }
  progress.finish(result.stop_reason);
  finish_result(result, problem, solver, labels, budget, budget_in, bound, scale, seconds,
                cpu_seconds, step);
  if (trace) trace->flush();
  return result;
}

}  // namespace radlab
