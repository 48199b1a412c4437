// radlab.solve's C++ side: one RunRequest, built as `radlab solve` builds its own (run id, budget
// rules, outputs), carried out by execute_run on the scene's prepared problem, as a sweep's runs
// are. The run releases the GIL; at every checkpoint the hook takes it back to check for Ctrl-C
// (PyErr_CheckSignals: a KeyboardInterrupt unwinds the run, and the trace and other outputs,
// written through temporaries, are never left half-written) and to call the Python callback.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <chrono>
#include <optional>

#include "core/error.h"
#include "experiments/run/report_page.h"
#include "experiments/run/run_request.h"
#include "experiments/sweep/experiment_spec.h"
#include "experiments/sweep/sweep.h"
#include "python/src/arrays.h"
#include "python/src/bindings.h"
#include "python/src/scene_handle.h"
#include "solvers/plugin_loader.h"
#include "solvers/registry.h"

namespace py = pybind11;

namespace radlab::python {
namespace {

struct SolveArguments {
  std::string solver;
  std::vector<std::string> set;  // key=value, as --set gives them
  std::optional<long long> steps, rows;
  std::optional<double> seconds, tol;
  std::string tol_of = "max-b";
  std::string reference = "certified";
  double reference_feps = 0.0025, reference_aeps = 1e-5;
  long long every_step_until = 10;
  double growth = 1.2;
  std::vector<long long> extra_checkpoints;
  std::string trace, out, image, json;
  int width = 512, height = 512;
  bool display_image = true;
  bool announce = true;  // log each file written (not the temporary trace radlab.solve reads)
};

// The budget, checked with the command line's rules (budget_violation) in Python's words.
Budget budget_of(const SolveArguments& a) {
  Budget budget;
  budget.steps = a.steps;
  budget.rows = a.rows;
  budget.seconds = a.seconds;
  budget.tol = a.tol;
  if (a.tol_of != "max-b" && a.tol_of != "reflected")
    throw UsageError("tol_of must be 'max-b' or 'reflected', got '" + a.tol_of + "'");
  budget.tol_of_reflected = a.tol && a.tol_of == "reflected";
  if (auto violation = budget_violation(budget))
    throw UsageError(violation->field + " " + violation->requirement + ", got " + violation->given);
  return budget;
}

RunRequest request_of(const SceneHandle& scene, const SolveArguments& a) {
  if (!a.image.empty() && (a.width < 8 || a.height < 8 || a.width > 8192 || a.height > 8192))
    throw UsageError("width and height must lie in [8, 8192], got " + std::to_string(a.width) +
                     " x " + std::to_string(a.height));
  RunRequest request;
  request.problem = scene.spec();
  request.reference = {a.reference, a.reference_feps, a.reference_aeps};
  request.solver = a.solver;
  request.solver_parameters = ParamBag::from_assignments(a.set, "solver '" + a.solver + "'");
  request.budget = budget_of(a);
  request.schedule.every_step_until = a.every_step_until;
  request.schedule.growth = a.growth;
  request.schedule.extra = a.extra_checkpoints;
  // The run id of `radlab solve` and `radlab run` (experiment_spec.h).
  request.labels = {make_run_id(a.solver, "scene:" + scene_label(scene.spec().scene),
                                request.solver_parameters.values()),
                    scene.spec().scene, a.solver, request.solver_parameters.canonical()};
  request.identity.command = "radlab.solve (Python)";
  request.outputs.trace = a.trace;
  request.outputs.radiosity = a.out;
  request.outputs.image = a.image;
  request.outputs.width = a.width;
  request.outputs.height = a.height;
  request.outputs.display_image = a.display_image;
  request.outputs.json = a.json;
  request.outputs.announce = a.announce;
  return request;
}

py::dict result_of(const RunOutcome& run) {
  const RunResult& r = run.result;
  py::dict out;
  out["B"] = rgb_array(run.solver->solution());
  out["display"] = rgb_array(run.solver->display());
  out["run_id"] = py::none();
  out["stop_reason"] = r.stop_reason;
  out["steps"] = r.steps;
  out["rows"] = r.rows;
  out["rays"] = r.rays;
  out["pair_evaluations"] = r.pair_evals;
  out["seconds"] = r.seconds;
  out["reference_kind"] = r.reference_kind;
  out["rms_rel"] = r.final_errors.rms_rel;
  out["p_mean"] = r.final_errors.p_mean;
  out["p_max"] = r.final_errors.p_max;
  out["bound_relative"] = r.final_bound_relative;
  out["bound_relative_reflected"] = r.final_bound_relative_reflected;
  out["tolerance_asked"] = r.tolerance_asked;
  out["tolerance_reached"] = r.tolerance_reached;
  out["tolerance_message"] = r.tolerance_message;
  out["statistics"] = r.statistics;
  return out;
}

// The hook of a run from Python: Ctrl-C first, then the callback with this checkpoint's state.
// `seconds` accumulates the wall time spent in it (taking the GIL included): the boundary's cost
// at checkpoints, reported as Result.boundary_seconds.
CheckpointHook python_hook(const Problem*& problem, py::object callback, double& seconds) {
  return [&problem, callback, &seconds](long long step, const Solver& solver) {
    const auto start = std::chrono::steady_clock::now();
    {
      py::gil_scoped_acquire gil;
      if (PyErr_CheckSignals() != 0) throw py::error_already_set();
      if (!callback.is_none()) {
        const System& system = *problem->system;
        py::dict checkpoint;
        checkpoint["step"] = step;
        checkpoint["rows"] = system.rows_used();
        checkpoint["pair_evaluations"] = system.pair_evaluations();
        checkpoint["rays"] = system.rays_used();
        checkpoint["B"] = rgb_array(solver.solution());
        callback(checkpoint);
      }
    }
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
}

py::dict solve(SceneHandle& scene, const SolveArguments& arguments, py::object callback) {
  RunRequest request = request_of(scene, arguments);
  {
    // The solver's name and parameters are checked before any work, as execute_run(request)
    // checks them before it prepares the problem.
    ParamBag parameters = request.solver_parameters;
    make_solver(request.solver, parameters);
  }
  const Problem* problem = nullptr;
  double hook_seconds = 0.0, run_seconds = 0.0;
  request.hook = python_hook(problem, std::move(callback), hook_seconds);
  std::optional<RunOutcome> run;
  {
    LongWork work;  // GIL released, Ctrl-C checked
    problem = &scene.run_problem(request.reference, request.budget);
    const auto start = std::chrono::steady_clock::now();
    run = execute_run(request, *problem);
    run_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  py::dict out = result_of(*run);
  out["run_id"] = request.labels.run_id;
  // Wall time of execute_run (the run as `radlab solve` runs it, with the hooks) and of the
  // hooks alone.
  out["run_wall_seconds"] = run_seconds;
  out["boundary_seconds"] = hook_seconds;
  {
    // The solver (a Python one holds Python objects) goes with the GIL held.
    RunOutcome finished = std::move(*run);
  }
  return out;
}

}  // namespace

void bind_run(py::module_& m) {
  py::class_<SolveArguments>(m, "SolveArguments")
      .def(py::init<>())
      .def_readwrite("solver", &SolveArguments::solver)
      .def_readwrite("set", &SolveArguments::set)
      .def_readwrite("steps", &SolveArguments::steps)
      .def_readwrite("rows", &SolveArguments::rows)
      .def_readwrite("seconds", &SolveArguments::seconds)
      .def_readwrite("tol", &SolveArguments::tol)
      .def_readwrite("tol_of", &SolveArguments::tol_of)
      .def_readwrite("reference", &SolveArguments::reference)
      .def_readwrite("reference_feps", &SolveArguments::reference_feps)
      .def_readwrite("reference_aeps", &SolveArguments::reference_aeps)
      .def_readwrite("every_step_until", &SolveArguments::every_step_until)
      .def_readwrite("growth", &SolveArguments::growth)
      .def_readwrite("extra_checkpoints", &SolveArguments::extra_checkpoints)
      .def_readwrite("trace", &SolveArguments::trace)
      .def_readwrite("out", &SolveArguments::out)
      .def_readwrite("image", &SolveArguments::image)
      .def_readwrite("json", &SolveArguments::json)
      .def_readwrite("width", &SolveArguments::width)
      .def_readwrite("height", &SolveArguments::height)
      .def_readwrite("display_image", &SolveArguments::display_image)
      .def_readwrite("announce", &SolveArguments::announce);
  m.def("solve", &solve, py::arg("scene"), py::arg("arguments"), py::arg("callback"));

  // `radlab run FILE --out OUT`: the sweep, then its report page. Failed runs do not raise (as
  // there, the others finish); the report lists them with their exit codes.
  m.def(
      "run_experiment",
      [](const std::string& path, const std::string& out, bool overwrite) {
        const ExperimentSpec spec = read_experiment(path);
        SweepOptions options;
        options.out_dir = out.empty() ? "out/" + spec.name : out;
        options.command = "radlab.run_experiment (Python)";
        options.overwrite = overwrite;
        SweepReport report;
        {
          LongWork work;  // GIL released, Ctrl-C checked
          report = run_sweep(spec, options);
          write_report_page(options.out_dir);
        }
        py::dict result;
        result["out"] = options.out_dir;
        result["runs_done"] = report.runs_done;
        result["runs_total"] = report.runs_total;
        result["runs_resumed"] = report.runs_resumed;
        result["exit_code"] = report.exit_code();
        py::list failures;
        for (const RunFailure& f : report.failures)
          failures.append(py::make_tuple(f.run_id, int(f.code), f.message));
        result["failures"] = failures;
        return result;
      },
      py::arg("path"), py::arg("out"), py::arg("overwrite"));

  // The trace's columns from its table (experiments/run/columns.h): name, meaning, and whether the
  // value measures the machine (time columns, left out when runs are compared).
  // A plugin's solvers and form-factor methods, registered in this process (solvers/plugin.h).
  // The plugin resolves radlab's symbols against this module, which the package imports with
  // RTLD_GLOBAL for that reason (python/radlab/__init__.py).
  m.def(
      "load_plugin",
      [](const std::string& path) {
        load_plugin(path);
        return loaded_plugin_provenance().back().solvers;
      },
      py::arg("path"));
  m.def("trace_columns", []() {
    std::vector<std::tuple<std::string, std::string, bool>> columns;
    for (const auto& c : trace_table()) columns.emplace_back(c.name, c.meaning, c.time);
    return columns;
  });

  // The solver registry: name, kind, summary, paper, cost of a step, parameters with defaults.
  m.def("solvers", []() {
    py::list out;
    for (const SolverInfo& info : solver_registry()) {
      py::dict entry;
      entry["name"] = info.name;
      entry["kind"] = to_string(info.kind);
      entry["summary"] = info.summary;
      entry["reference"] = info.reference;
      entry["cost"] = info.cost;
      py::dict parameters;
      for (const ParameterInfo& p : info.parameters) parameters[py::str(p.name)] = p.default_value;
      entry["parameters"] = parameters;
      out.append(entry);
    }
    return out;
  });
}

}  // namespace radlab::python
