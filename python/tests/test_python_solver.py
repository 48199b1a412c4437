"""A solver written in Python runs through radlab's runner like a built-in one: the Southwell
iteration in numpy reaches the certified reference of the Cornell box (issue 34)."""

import numpy as np
import pytest

import radlab


class NumpySouthwell(radlab.Solver):
    """Southwell relaxation (progressive refinement with sorting, Cohen et al. 1988): each step
    shoots the element with the largest unshot power A_i * max_c dB_i,c."""

    name = "py-southwell"
    summary = "Southwell relaxation in numpy"
    reference = "Cohen et al. 1988 'Shooting and Sorting'"
    kind = "shooting"
    parameters = {"omega": (1.0, "over-relaxation of each shot")}

    def __init__(self, omega=1.0):
        self.omega = omega

    def init(self, system):
        self.system = system
        self.area = system.area
        self.rho = system.rho
        self.B = system.E.copy()
        self.dB = system.E.copy()

    def step(self):
        power = self.area[:, None] * np.abs(self.dB)
        i = int(np.argmax(power.max(axis=1)))
        if power[i].max() == 0:
            return True  # nothing left to shoot
        F_i = self.system.row(i)  # F[i, j]; reciprocity: F[j, i] = F[i, j] A_i / A_j
        # Over-relaxed shot (omega = 1: the classic one): B_i counts its own extra part.
        shot = self.omega * self.dB[i]
        self.B[i] += (self.omega - 1) * self.dB[i]
        self.dB[i] -= shot
        received = self.rho * np.outer(F_i * self.area[i] / self.area, shot)
        self.B += received
        self.dB += received
        return False

    def solution(self):
        return self.B

    def unshot(self):
        return self.dB


def test_numpy_southwell_reaches_the_certified_reference():
    # Double-precision rows (--precision double): with float storage the solvers' system differs
    # from the certified one by the float-storage floor (~1e-7, docs/reference.md), far above
    # the 1e-9 this checks.
    scene = radlab.load("builtin:cornell", subdiv=8, precision="double")
    r = radlab.solve(scene, solver=NumpySouthwell, tol=1e-9)
    assert r.tolerance_reached, r.tolerance_message
    # The runner's certified bound, and independently the error against the reference itself.
    assert r.bound_relative <= 1e-9
    assert radlab.errors(scene, r.B)["max_relative"] <= 1e-9
    builtin = radlab.solve(scene, solver="sorted-shooting", steps=10)
    assert list(r.trace.columns) == list(builtin.trace.columns)
    # Every step read one row: the work columns count a Python solver's reads as a C++ one's.
    assert r.rows == r.steps
    assert (r.trace["ff_rows"] == r.trace["step"]).all()


def test_a_wrong_solver_fails_the_reference():
    # The same solver with the reciprocity factor left out converges to another system's
    # solution: the runner's certified bound must say so (the test above can fail).
    class Wrong(NumpySouthwell):
        name = "py-southwell-wrong"

        def step(self):
            power = self.area[:, None] * np.abs(self.dB)
            i = int(np.argmax(power.max(axis=1)))
            F_i = self.system.row(i)
            received = self.rho * np.outer(F_i, self.dB[i])
            self.B += received
            self.dB += received
            self.dB[i] = 0
            return False

    scene = radlab.load("builtin:cornell", subdiv=4, precision="double")
    r = radlab.solve(scene, solver=Wrong, steps=2000)
    assert radlab.errors(scene, r.B)["max_relative"] > 1e-3


def test_registered_python_solver_is_listed_with_its_defaults():
    radlab.register_solver(NumpySouthwell)
    table = radlab.solvers().set_index("name")
    assert table.loc["py-southwell", "kind"] == "shooting"
    assert table.loc["py-southwell", "parameters"] == {"omega": "1"}


def test_a_python_solver_runs_in_an_experiment(tmp_path):
    # Registered in this process, the solver is named in an experiment file like a built-in one;
    # the sweep shares the scene's matrix and reference among its runs.
    class SweepSouthwell(NumpySouthwell):
        name = "py-southwell-sweep"

    radlab.register_solver(SweepSouthwell)
    experiment = tmp_path / "e.toml"
    experiment.write_text('name = "py"\nscenes = ["builtin:cube"]\nsubdiv = 3\n'
                          'solvers = ["sorted-shooting", "py-southwell-sweep"]\n'
                          '[budget]\nsteps = 400\n')
    e = radlab.run_experiment(experiment, out=tmp_path / "out")
    assert e.failures == [] and e.runs_done == 2
    summary = e.summary.set_index("solver")
    # Both shoot the largest unshot power, one row a step: after 400 steps (7 sweeps of the
    # 54-element cube, rho 0.5: unshot power falls by about half a sweep) both are at least
    # 100 times below the error at step 0.
    first = e.trace[(e.trace["step"] == 0) & (e.trace["channel"] == "mean")]
    for solver in ["sorted-shooting", "py-southwell-sweep"]:
        assert summary.loc[solver, "ff_rows"] == 400
        start = first[first["solver"] == solver]["rms_rel"].iloc[0]
        assert summary.loc[solver, "rms_rel"] < start / 100
    assert list(e.trace.columns) == [name for name, _, _ in radlab.trace_columns()]
    assert set(e.trace["solver"]) == {"sorted-shooting", "py-southwell-sweep"}


def test_an_experiment_given_as_a_dict_runs_as_its_file_does(tmp_path):
    # The same experiment as a file and as a dict: the same runs and the same numbers (time
    # columns aside), and the dict's TOML is kept beside its output folder.
    text = ('name = "dict"\nscenes = ["builtin:cube"]\nsubdiv = 2\n'
            'solvers = ["jacobi", "gauss-seidel"]\n[budget]\nsteps = 20\n')
    as_dict = {"name": "dict", "scenes": ["builtin:cube"], "subdiv": 2,
               "solvers": ["jacobi", "gauss-seidel"], "budget": {"steps": 20}}
    (tmp_path / "file.toml").write_text(text)
    from_file = radlab.run_experiment(tmp_path / "file.toml", out=tmp_path / "file")
    from_dict = radlab.run_experiment(as_dict, out=tmp_path / "dict")
    assert (tmp_path / "dict.toml").is_file()
    keep = [c for c in from_file.trace.columns if c not in radlab.time_columns()]
    assert from_dict.runs_done == from_file.runs_done == 2
    assert from_dict.trace[keep].equals(from_file.trace[keep])
    with pytest.raises(ValueError, match="needs out="):
        radlab.run_experiment(as_dict)
    with pytest.raises(TypeError, match="cannot be written as TOML"):
        radlab.run_experiment({"name": object()}, out=tmp_path / "bad")
