"""radlab from Python: scenes, form factors, certified references and solver runs.

    import radlab
    scene = radlab.load("builtin:cornell", subdiv=8)
    F = radlab.form_factors(scene, method="raycast")    # scipy.sparse CSR, F.diagnostics
    ref = radlab.reference(scene)                        # ref.B (n x 3), ref.bound
    r = radlab.solve(scene, solver="gauss-seidel", steps=500, params={"omega": 1.2})
    r.B, r.trace                                         # numpy (n x 3), pandas DataFrame

Every call runs the C++ library the command line runs (docs/python.md): `solve` builds the same
run request as `radlab solve` and gives the same numbers bit for bit. Solvers written in Python
subclass radlab.Solver.
"""

import os as _os
import sys as _sys

# The extension is loaded with RTLD_GLOBAL so that solver plugins (load_plugin) resolve radlab's
# symbols against it, as they do against the radlab executable.
_flags = _sys.getdlopenflags()
_sys.setdlopenflags(_flags | _os.RTLD_GLOBAL)
try:
    from . import _radlab
finally:
    _sys.setdlopenflags(_flags)

from ._radlab import (Error, InputError, NumericalError, ToleranceNotReached, UsageError,
                      __version__)
from .scene import Scene, load, load_dict
from .matrices import Reference, errors, form_factors, reference
from .run import (Experiment, Result, read_solution, run_experiment, solve, solvers,
                  time_columns, trace_columns)
from .solver import Solver, load_plugin, register_solver

__all__ = [
    "Error", "InputError", "NumericalError", "ToleranceNotReached", "UsageError", "__version__",
    "Scene", "load", "load_dict", "Reference", "errors", "form_factors", "reference", "Result", "solve",
    "Experiment", "run_experiment", "read_solution",
    "solvers", "trace_columns", "time_columns", "Solver", "register_solver", "load_plugin",
]
