"""Bad input from Python, tried as a new user makes it (issue 34; docs/python.md lists the
cases): each raises an exception with a message that names what is wrong, never a crash, hang or
silent NaN."""

import os
import signal
import threading

import numpy as np
import pytest

import radlab


class Returns(radlab.Solver):
    """A solver whose solution() returns what the test puts in `value` (a bad value)."""

    name = "py-returns"
    kind = "gathering"
    value = None

    def init(self, system):
        self.n = system.size

    def step(self):
        return False

    def solution(self):
        return type(self).value(self.n)


def solve_returning(scene, make):
    Returns.value = staticmethod(make)
    return radlab.solve(scene, solver=Returns, steps=3)


def test_list_instead_of_array(cornell4):
    with pytest.raises(TypeError, match=r"py-returns.solution\(\): expected a numpy float64 "
                                        r"array .* got list"):
        solve_returning(cornell4, lambda n: [[0.0] * 3] * n)
    with pytest.raises(TypeError, match="B: expected a numpy float64 array.*got list"):
        radlab.errors(cornell4, radlab.reference(cornell4).B.tolist())


def test_float32_is_refused_not_converted(cornell4):
    with pytest.raises(TypeError, match="got dtype float32.*astype"):
        solve_returning(cornell4, lambda n: np.zeros((n, 3), np.float32))


def test_wrong_shapes(cornell4):
    n = cornell4.size
    with pytest.raises(ValueError, match=rf"expected .*shape \({n}, 3\), got shape \({n},\)"):
        solve_returning(cornell4, lambda n: np.zeros(n))
    with pytest.raises(ValueError, match=rf"got shape \(3, {n}\)"):
        solve_returning(cornell4, lambda n: np.zeros((3, n)))
    with pytest.raises(ValueError, match=rf"got shape \({n - 1}, 3\)"):
        radlab.errors(cornell4, np.zeros((n - 1, 3)))


def test_nan_names_the_element(cornell4):
    def with_nan(n):
        B = np.zeros((n, 3))
        B[7, 1] = np.nan
        return B
    with pytest.raises(ValueError, match="element 7, channel 1 is nan"):
        solve_returning(cornell4, with_nan)


def test_closed_file_and_wrong_scene_types(tmp_path):
    path = tmp_path / "box.obj"
    path.write_text("v 0 0 0\n")
    with open(path) as f:
        pass
    with pytest.raises(ValueError, match="box.obj' is closed"):
        radlab.load(f)
    with pytest.raises(TypeError, match="scene must be a path"):
        radlab.load(42)
    with pytest.raises(TypeError, match=r"radlab.Scene \(from radlab.load\), got str"):
        radlab.solve("builtin:cornell", steps=1)


def test_negative_and_non_finite_sizes():
    with pytest.raises(ValueError, match="subdiv must be >= 1, got 0"):
        radlab.load("builtin:cube", subdiv=0)
    with pytest.raises(TypeError, match="subdiv must be an int, got float 2.5"):
        radlab.load("builtin:cube", subdiv=2.5)
    with pytest.raises(ValueError, match="element_size must be >= 0.0, got -0.1"):
        radlab.load("builtin:cube", element_size=-0.1)
    with pytest.raises(ValueError, match="element_size must be finite, got nan"):
        radlab.load("builtin:cube", element_size=float("nan"))


def test_radlab_errors_carry_message_and_exit_code(cornell4, tmp_path):
    with pytest.raises(radlab.UsageError, match="unknown solver 'gauss-siedel'") as e:
        radlab.solve(cornell4, solver="gauss-siedel", steps=1)
    assert e.value.exit_code == 2
    with pytest.raises(radlab.UsageError, match="steps must be >= 1, got 0"):
        radlab.solve(cornell4, steps=0)
    with pytest.raises(radlab.UsageError, match="omgea"):
        radlab.solve(cornell4, solver="gauss-seidel", steps=1, params={"omgea": 1.2})
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\nv 1 0 0\nf 1 2 9\n")
    with pytest.raises(radlab.InputError, match="bad.obj") as e:
        radlab.load(bad)
    assert e.value.exit_code == 3
    assert issubclass(radlab.NumericalError, radlab.Error) and radlab.NumericalError.exit_code == 4


def test_ctrl_c_mid_solve_raises_and_writes_nothing(cornell4, tmp_path):
    # SIGINT from another thread while the run is in C++ without the GIL: the hook's
    # PyErr_CheckSignals at the next checkpoint raises KeyboardInterrupt. The budget (120 s) is
    # far beyond the signal, and a run that ignored it would end by writing its trace: the trace's
    # absence shows the run was interrupted, with no timing in the assertion.
    trace = tmp_path / "t.csv"
    timer = threading.Timer(0.5, os.kill, (os.getpid(), signal.SIGINT))
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            radlab.solve(cornell4, solver="gauss-seidel", seconds=120, trace=trace)
    finally:
        timer.cancel()
    assert not trace.exists()
    assert not [p for p in os.listdir(tmp_path)], "a temporary or partial file was left"


def box(**changes):
    from test_api import BOX_FACES, BOX_VERTICES
    scene = {"vertices": BOX_VERTICES, "polygons": BOX_FACES, "rho": np.full(6, 0.5),
             "E": np.ones(6)}
    scene.update(changes)
    return scene


def test_bad_arrays_in_a_scene_dict():
    from test_api import BOX_VERTICES
    with pytest.raises(TypeError, match="vertices: expected a numpy float64 array, got list"):
        radlab.load_dict(box(vertices=BOX_VERTICES.tolist()))
    with pytest.raises(TypeError, match="vertices: .*got dtype float32"):
        radlab.load_dict(box(vertices=BOX_VERTICES.astype(np.float32)))
    with pytest.raises(ValueError, match=r"vertices: expected shape \(N, 3\), got \(3, 8\)"):
        radlab.load_dict(box(vertices=BOX_VERTICES.T.copy()))
    nan = BOX_VERTICES.copy()
    nan[5, 2] = np.nan
    with pytest.raises(ValueError, match="vertices: row 5, column 2 is nan"):
        radlab.load_dict(box(vertices=nan))
    with pytest.raises(ValueError, match=r"rho: expected shape \(6, 3\) or \(6,\), got \(5,\)"):
        radlab.load_dict(box(rho=np.full(5, 0.5)))
    with pytest.raises(ValueError, match="rho: polygon 0 has reflectance .*outside"):
        radlab.load_dict(box(rho=np.array([1.5, .5, .5, .5, .5, .5])))
    with pytest.raises(ValueError, match="E: polygon 2 has emission .*below 0"):
        radlab.load_dict(box(E=np.array([1., 1., -1., 1., 1., 1.])))
    with pytest.raises(ValueError, match=r"polygons\[1\]: vertex index 8 out of range"):
        radlab.load_dict(box(polygons=[[0, 1, 3, 2], [4, 6, 7, 8]]))
    with pytest.raises(ValueError, match="keys must be exactly"):
        radlab.load_dict({"vertices": BOX_VERTICES})


def test_ctrl_c_mid_matrix_build_raises_and_caches_nothing(tmp_path):
    # SIGINT while the form-factor matrix is being built in C++ without the GIL (Cornell at
    # subdivision 16: 5,120 rows, tens of seconds here): the build checks the request where it
    # reports progress (core/interrupt.h) and unwinds; KeyboardInterrupt reaches Python, and the
    # cache holds no matrix, whole or partial (it is written atomically after the build). A build
    # that ignored the signal would store its matrix: the empty cache shows it was interrupted,
    # with no timing in the assertion.
    cache = tmp_path / "cache"
    scene = radlab.load("builtin:cornell", subdiv=16, cache_dir=cache)
    timer = threading.Timer(0.5, os.kill, (os.getpid(), signal.SIGINT))
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            radlab.form_factors(scene)
    finally:
        timer.cancel()
    stored = [p.name for p in cache.iterdir()] if cache.exists() else []
    assert not [name for name in stored if not name.endswith(".lock")], stored
