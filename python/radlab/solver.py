"""Solvers written in Python: subclass radlab.Solver and run it with radlab.solve (or register it
for a sweep). It runs through radlab's runner exactly like a built-in solver: the same
checkpoints, metrics, certified reference, trace columns and output files."""

import numpy as np  # noqa: F401  (solvers use it; importing here fails early without numpy)

from . import _radlab


class Solver:
    """The base of a solver written in Python (radlab's solvers/solver.h in Python).

    Class attributes describe it, once: `name` (how solve() and experiments call it),
    `summary`, `reference` (the paper), `cost` (of one step), `kind` ('gathering': a step
    gathers at one element, in sweeps of n; 'shooting': a step shoots, and unshot() returns the
    unshot radiosity; 'other'), and `parameters`: {name: default} or {name: (default, help)};
    the default's type (float, int, bool, str) is the parameter's. The constructor receives the
    parameters as keywords (given or default).

    The runner calls init(system) once, then step() until a budget is used up or step()
    returns True (finished); solution() (and unshot()) at every checkpoint. `system` (radlab's
    System) gives size, channels, area, rho and E ((n, channels) float64 copies) and row(i),
    the form-factor row F[i, :] as a float64 copy: each call is charged as one form-factor row
    and n pair evaluations, as a C++ solver's read is. Work done otherwise is charged with
    system.charge_pair_evaluations(k) and system.charge_rays(k).

    solution() must return a float64 numpy array of shape (n, channels) (or (n,) for one
    channel), every value finite; anything else raises TypeError or ValueError naming the call.
    """

    name = None
    summary = "a solver written in Python"
    reference = ""
    cost = "one form-factor row"
    kind = "other"
    parameters = {}

    def __init__(self, **params):
        self.params = params

    def init(self, system):
        raise NotImplementedError(f"{type(self).__name__}.init(system)")

    def step(self):
        raise NotImplementedError(f"{type(self).__name__}.step()")

    def solution(self):
        raise NotImplementedError(f"{type(self).__name__}.solution()")

    def unshot(self):
        raise NotImplementedError(f"{type(self).__name__}.unshot() (kind 'shooting')")

    def statistics(self):
        """Optional counters, {name: number}, written to the trace's statistics column."""
        return None


# The Python solvers registered in this process, by name: the registry's factory makes the class
# registered last under the name, so a notebook can redefine a class and run it again.
_classes = {}
_signatures = {}


def _parameter_list(cls):
    out = []
    for key, value in dict(cls.parameters).items():
        default, help_text = value if isinstance(value, tuple) else (value, "")
        out.append((key, default, help_text))
    return out


def register_solver(cls):
    """Registers a radlab.Solver subclass in radlab's solver registry under cls.name (for
    solve(), `solvers()` and sweeps in this process); returns the name. Registering a class
    again under the same name with the same parameters and kind replaces it."""
    if not (isinstance(cls, type) and issubclass(cls, Solver)):
        raise TypeError(f"register_solver needs a radlab.Solver subclass, got {cls!r}")
    name = cls.name
    if not isinstance(name, str) or not name:
        raise TypeError(f"{cls.__name__}.name must be a non-empty str (the solver's name)")
    parameters = _parameter_list(cls)
    signature = (cls.kind, [(k, type(d), d) for k, d, _ in parameters])
    if name in _classes:
        if _signatures[name] != signature:
            raise _radlab.UsageError(
                f"a Python solver named '{name}' is registered already with other parameters "
                "or kind; choose another name (the registry cannot forget a solver)")
        _classes[name] = cls
        return name

    def make(**params):
        return _classes[name](**params)

    _classes[name] = cls
    _signatures[name] = signature
    try:
        _radlab.register_solver(name, cls.summary, cls.reference, cls.cost, cls.kind,
                                parameters, make)
    except BaseException:
        del _classes[name], _signatures[name]
        raise
    return name


def load_plugin(path):
    """Loads a solver plugin (a shared library built against the installed package, as for
    `radlab --plugin PATH`; docs/library.md) into this process: its solvers and form-factor
    methods are then named like the built-in ones, in solve and in experiments, and their runs
    record the plugin's path and SHA-256. Returns the names of the solvers it registered."""
    from . import _checks
    return list(_radlab.load_plugin(_checks.path("path", path)))
