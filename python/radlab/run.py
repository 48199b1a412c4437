"""radlab.solve: one run, the same request `radlab solve` makes, with its trace as a DataFrame."""

import os
import tempfile
import time
from collections.abc import Mapping

import numpy as np

from . import _checks, _radlab
from .matrices import _scene


def trace_columns():
    """trace.csv's columns from radlab's column table (experiments/run/columns.h): a list of
    (name, meaning, time) with time True for the columns that measure the machine (seconds)."""
    return list(_radlab.trace_columns())


def time_columns():
    """The trace columns that measure the machine: left out when two runs are compared."""
    return [name for name, _, time in _radlab.trace_columns() if time]


def solvers():
    """The registered solvers (built-in, then registered from Python) as a pandas DataFrame:
    name, kind, summary, reference, cost, parameters (dict of name: default)."""
    import pandas as pd
    return pd.DataFrame(_radlab.solvers())


class Result:
    """A finished run.

    B: (n, 3) float64, the solver's solution (the numbers `radlab solve --out` writes);
    display: what the solver shows mid-run (e.g. with an ambient term);
    trace: pandas DataFrame with trace.csv's columns (one row per checkpoint and channel);
    stop_reason, steps, rows, rays, pair_evaluations, seconds: how and when it ended;
    rms_rel, p_mean, p_max, bound_relative: the final errors against the reference;
    tolerance_asked / tolerance_reached / tolerance_message: with tol=, whether it was reached
    (the command line exits 5 when not; here the result says it);
    statistics: the solver's own counters; run_id: as in trace.csv;
    run_wall_seconds: wall time of the run in C++ (execute_run, checkpoints' metrics and trace
    included); boundary_seconds: of it, the time at the Python boundary at checkpoints (taking
    the GIL, Ctrl-C check, callback); python_seconds: the rest of radlab.solve (request, problem
    lookup, result and trace conversion; the problem's first preparation included).
    """

    def __init__(self, fields, trace):
        self.__dict__.update(fields)
        self.trace = trace

    def __repr__(self):
        return (f"radlab.Result({self.run_id}: {self.stop_reason} after {self.steps} steps, "
                f"{self.rows} rows; rms_rel {self.rms_rel:.3g})")


def read_solution(path, size):
    """A radiosity file as `radlab solve --out` writes it (element,B_r,B_g,B_b): an array of
    `size` x 3 in element order. InputError when it does not hold each of the scene's `size`
    elements exactly once."""
    import csv
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if len(rows) != size:
        raise _radlab.InputError(f"{path}: {len(rows)} elements, the scene has {size}")
    B = np.zeros((size, 3))
    seen = np.zeros(size, dtype=bool)
    for row in rows:
        i = int(row["element"])
        if not 0 <= i < size or seen[i]:
            raise _radlab.InputError(f"{path}: element {i} outside 0..{size - 1} or repeated")
        seen[i] = True
        B[i] = [float(row["B_r"]), float(row["B_g"]), float(row["B_b"])]
    return B


def _read_trace(path):
    import pandas as pd
    names = [name for name, _, _ in _radlab.trace_columns()]
    # round_trip: the %.17g fields parse back to the very doubles radlab wrote; only empty fields
    # (not applicable) are NaN, never a string such as "NA".
    frame = pd.read_csv(path, float_precision="round_trip", keep_default_na=False,
                        na_values=[""])
    if list(frame.columns) != names:
        raise _radlab.Error(f"{path}: columns {list(frame.columns)} differ from the trace "
                            f"table's {names}")
    return frame


def _checkpoints(checkpoints):
    defaults = dict(every_step_until=10, growth=1.2, extra=[])
    if checkpoints is None:
        return defaults
    if not isinstance(checkpoints, dict):
        raise TypeError("checkpoints must be a dict (every_step_until, growth, extra)")
    unknown = set(checkpoints) - set(defaults)
    if unknown:
        raise ValueError(f"checkpoints: unknown keys {sorted(unknown)}; "
                         "known: every_step_until, growth, extra")
    out = dict(defaults, **checkpoints)
    out["every_step_until"] = _checks.integer("checkpoints['every_step_until']",
                                              out["every_step_until"], 0)
    out["growth"] = _checks.number("checkpoints['growth']", out["growth"])
    if not out["growth"] > 1.0:
        raise ValueError(f"checkpoints['growth'] must be > 1, got {out['growth']}")
    out["extra"] = [_checks.integer("checkpoints['extra']", s, 0) for s in out["extra"]]
    return out


def solve(scene, solver="gauss-seidel", *, steps=None, rows=None, seconds=None, tol=None,
          tol_of="max-b", params=None, callback=None, reference="certified",
          reference_feps=0.0025, reference_aeps=1e-5, checkpoints=None, trace=None, out=None,
          image=None, json=None, width=512, height=512, display_image=True):
    """Runs `solver` on `scene` until a budget is used up (`radlab solve`).

    solver: a registered name, or a radlab.Solver subclass (registered on first use).
    steps / rows / seconds / tol / tol_of: the budget (--steps, --rows, --seconds, --tol,
    --tol-of); none: 3n steps. params: the solver's parameters (--set), a dict.
    callback(checkpoint): called at every checkpoint with a dict: step, rows, pair_evaluations,
    rays and B (an (n, 3) copy of the current solution). reference / reference_feps /
    reference_aeps: what the run is measured against (--reference ...). checkpoints: dict of
    every_step_until (10), growth (1.2), extra (steps). trace / out / image / json: files to
    write as the command line writes them (json defaults to beside the trace, as there).

    Runs without the GIL; Ctrl-C (KeyboardInterrupt) is honoured at every checkpoint and inside
    a Python solver's step, and leaves no file half-written.
    """
    from .solver import Solver, register_solver
    handle = _scene(scene)
    if isinstance(solver, type) and issubclass(solver, Solver):
        solver = register_solver(solver)
    elif not isinstance(solver, str):
        raise TypeError(f"solver must be a solver name or a radlab.Solver subclass, "
                        f"got {type(solver).__name__}")
    if callback is not None and not callable(callback):
        raise TypeError(f"callback must be callable, got {type(callback).__name__}")
    a = _radlab.SolveArguments()
    a.solver = solver
    a.set = _checks.assignments("params", params)
    # The budget's own rules (>= 1 step, finite seconds, 0 < tol < 1) are radlab's
    # (budget_violation), raised as radlab.UsageError; the types are checked here.
    a.steps = None if steps is None else _checks.integer("steps", steps)
    a.rows = None if rows is None else _checks.integer("rows", rows)
    a.seconds = None if seconds is None else _checks.number("seconds", seconds)
    a.tol = None if tol is None else _checks.number("tol", tol)
    a.tol_of = _checks.choice("tol_of", tol_of, ["max-b", "reflected"])
    a.reference = _checks.choice("reference", reference,
                                 ["certified", "none", "hierarchical-fine"])
    a.reference_feps = _checks.number("reference_feps", reference_feps, positive=True)
    a.reference_aeps = _checks.number("reference_aeps", reference_aeps, positive=True)
    schedule = _checkpoints(checkpoints)
    a.every_step_until = schedule["every_step_until"]
    a.growth = schedule["growth"]
    a.extra_checkpoints = schedule["extra"]
    a.width = _checks.integer("width", width)
    a.height = _checks.integer("height", height)
    a.display_image = bool(display_image)
    a.out = "" if out is None else _checks.path("out", out)
    a.image = "" if image is None else _checks.path("image", image)
    if trace is not None:
        a.trace = _checks.path("trace", trace)
        if json is None:
            json = os.path.splitext(a.trace)[0] + ".run.json"
    a.json = "" if json is None else _checks.path("json", json)
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="radlab-trace-") as folder:
        if not a.trace:
            # The trace is always written by radlab's TraceWriter and read back: one writer, the
            # same columns and digits as trace.csv (a documented copy).
            a.trace = os.path.join(folder, "trace.csv")
            a.announce = not (a.out or a.image or a.json)
        fields = _radlab.solve(handle, a, callback)
        frame = _read_trace(a.trace)
    fields["python_seconds"] = time.perf_counter() - start - fields["run_wall_seconds"]
    return Result(fields, frame)


class Experiment:
    """A finished sweep (`radlab run`): summary and trace as DataFrames (summary.csv and
    trace.csv of `out`, docs/outputs.md), `failures` as (run_id, exit_code, message) of the runs
    that failed (the others finished; the command line would exit with `exit_code`)."""

    def __init__(self, fields):
        import pandas as pd
        self.__dict__.update(fields)
        read = dict(float_precision="round_trip", keep_default_na=False, na_values=[""])
        self.summary = pd.read_csv(os.path.join(self.out, "summary.csv"), **read)
        self.trace = pd.read_csv(os.path.join(self.out, "trace.csv"), **read)

    def __repr__(self):
        return (f"radlab.Experiment({self.out}: {self.runs_done} of {self.runs_total} runs, "
                f"{len(self.failures)} failed)")


def run_experiment(experiment, out=None, overwrite=False):
    """Runs an experiment (`radlab run PATH --out OUT`, docs/experiments.md) in this process, so
    solvers registered from Python may be named in it. Returns an Experiment.

    `experiment` is an experiment file's path, or the same as a dict (the TOML file's tables as
    dicts, its arrays as lists). A dict needs `out`: it is written, as TOML, to the file OUT.toml
    beside the output folder, which the sweep then names as its experiment file (its bytes are
    part of the sweep's identity, as a file's are), so the run can be repeated from the command
    line."""
    if isinstance(experiment, Mapping):
        if out is None:
            raise ValueError("run_experiment: an experiment given as a dict needs out= (its TOML "
                             "is written beside the output folder, as OUT.toml)")
        out = _checks.path("out", out)
        try:
            import tomli_w
        except ImportError as e:
            raise ImportError("run_experiment: an experiment given as a dict is written with "
                              "tomli_w (Debian: apt-get install python3-tomli-w)") from e
        try:
            text = tomli_w.dumps(dict(experiment))
        except TypeError as e:
            raise TypeError(f"run_experiment: the experiment dict cannot be written as TOML: {e}")
        path = out.rstrip(os.sep) + ".toml"
        os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
        with open(path, "w", encoding="utf-8") as f:
            f.write(text)
    else:
        path = _checks.path("path", experiment)
        out = "" if out is None else _checks.path("out", out)
    return Experiment(_radlab.run_experiment(path, out, bool(overwrite)))
