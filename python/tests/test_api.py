"""The calls of issue 34 as written, and what theory says of their results."""

import numpy as np
import pandas as pd
import pytest
import scipy.sparse

import radlab


def test_the_issues_calls_work_as_written():
    scene = radlab.load("builtin:cornell", subdiv=8)
    F = radlab.form_factors(scene, method="raycast")
    ref = radlab.reference(scene)
    r = radlab.solve(scene, solver="gauss-seidel", steps=500, params={"omega": 1.2})
    n = scene.size
    assert scipy.sparse.issparse(F) and F.shape == (n, n)
    assert F.diagnostics["method"] == "raycast"
    assert ref.B.shape == (n, 3) and ref.B.dtype == np.float64
    # The certificate: a bound relative to max B* of at most the reference's accepted 1e-8
    # (ReferenceOptions::acceptable; docs/reference.md), and non-negative.
    assert 0 <= ref.bound_relative <= 1e-8
    assert r.B.shape == (n, 3) and r.steps == 500
    assert isinstance(r.trace, pd.DataFrame)
    assert list(r.trace.columns) == [name for name, _, _ in radlab.trace_columns()]


def test_scene_arrays_describe_the_mesh(cornell4):
    s = cornell4
    n = s.size
    assert s.areas.shape == (n,) and s.centroids.shape == (n, 3) and s.normals.shape == (n, 3)
    # The Cornell box's published geometry: a 5.56 x 5.59 x 5.48 m box, open at the front
    # (floor, ceiling, 3 walls, minus nothing) plus two blocks: the areas are positive and the
    # normals unit vectors (to rounding).
    assert (s.areas > 0).all()
    np.testing.assert_allclose(np.linalg.norm(s.normals, axis=1), 1.0, rtol=1e-12)
    # The view is radlab's own array: read-only, so no one changes a prepared problem.
    with pytest.raises(ValueError):
        s.areas[0] = 1.0
    # The light is the only emitter: E > 0 exactly on its elements, and rho in [0, 1].
    emitting = (s.E > 0).any(axis=1)
    assert 0 < emitting.sum() < n
    assert ((s.rho >= 0) & (s.rho <= 1)).all()


def test_form_factor_rows_sum_to_at_most_one_within_the_stated_error(cube4):
    # The cube is closed: every row of the exact F sums to 1. Raycast states an error per row
    # sum (diagnostics['stated_row_sum_error']); the matrix's row sums must lie within it.
    F = radlab.form_factors(cube4, method="raycast")
    sums = np.asarray(F.sum(axis=1)).ravel()
    d = F.diagnostics
    assert sums.min() == pytest.approx(d["row_sum_min"], rel=1e-12)
    assert sums.max() == pytest.approx(d["row_sum_max"], rel=1e-12)
    assert d["rows_above_stated_error"] == 0
    assert abs(sums - 1).max() <= max(d["stated_row_sum_error"], 0.05)
    dense = radlab.form_factors(cube4, method="raycast", dense=True)
    assert np.array_equal(dense, F.toarray()) and dense.diagnostics == d


def test_reference_solves_the_system(cube4):
    # B* = E + diag(rho) F B*: the residual with the method's F (double) is within the
    # certificate's bound times (1 + max rho) (B - B* <= bound in every element).
    F = radlab.form_factors(cube4, method="raycast")
    ref = radlab.reference(cube4)
    B = ref.B[:, 0]
    residual = B - cube4.E[:, 0] - cube4.rho[:, 0] * (F @ B)
    assert np.abs(residual).max() <= 2 * ref.bound + 1e-12 * B.max()


def test_callback_sees_every_checkpoint_in_order(cornell4):
    seen = []
    r = radlab.solve(cornell4, solver="jacobi", steps=200,
                     callback=lambda c: seen.append((c["step"], c["rows"], c["B"].copy())))
    steps = [s for s, _, _ in seen]
    assert steps == sorted(set(r.trace["step"]))
    # The last checkpoint's B is the final solution; one row a step for Jacobi.
    assert np.array_equal(seen[-1][2], r.B)
    assert all(rows == step for step, rows, _ in seen)


def test_errors_of_the_reference_itself_are_zero(cornell4):
    ref = radlab.reference(cornell4)
    e = radlab.errors(cornell4, ref.B)
    assert e["rms_rel"] == 0 and e["max_relative"] == 0
    e = radlab.errors(cornell4, ref.B * 1.01)
    # A uniform 1% over-estimate: rms_rel and p-error are exactly 1% (to rounding).
    assert e["rms_rel"] == pytest.approx(0.01, rel=1e-9)
    assert e["p_mean"] == pytest.approx(0.01, rel=1e-9)


def test_solvers_lists_the_registry():
    table = radlab.solvers()
    assert {"jacobi", "gauss-seidel", "sorted-shooting"} <= set(table["name"])
    gs = table.set_index("name").loc["gauss-seidel"]
    assert gs["kind"] == "gathering" and "omega" in gs["parameters"]


def test_images_are_written_on_request(cornell4, tmp_path):
    radlab.solve(cornell4, solver="gauss-seidel", steps=100, image=tmp_path / "i.exr",
                 width=32, height=32)
    assert (tmp_path / "i.exr").stat().st_size > 0 and (tmp_path / "i.png").stat().st_size > 0


# A closed unit box from arrays, every face facing inward (counter-clockwise seen from inside).
BOX_VERTICES = np.array([[x, y, z] for z in (0.0, 1.0) for y in (0.0, 1.0) for x in (0.0, 1.0)])
BOX_FACES = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 2, 6, 4], [1, 5, 7, 3], [0, 4, 5, 1], [2, 3, 7, 6]]


def test_a_furnace_from_arrays_has_the_furnace_solution():
    # Every face emits E and reflects rho in a closed box: B = E / (1 - rho) everywhere (the
    # furnace; docs/validation.md). With the exact (analytic) form factors of a convex box the
    # row sums are 1 to rounding, so B is within 1e-9 of 2 for rho = 0.5, E = 1. Wrongly facing
    # polygons or a wrong material would move it far from 2. Double-precision rows: with float
    # storage the bound stagnates near 1.5e-8 (radlab says so), above the tolerance asked.
    scene = radlab.load_dict({"vertices": BOX_VERTICES, "polygons": BOX_FACES,
                              "rho": np.full(6, 0.5), "E": np.ones(6)}, subdiv=3, ff="exact",
                             precision="double")
    assert scene.size == 54 and scene.polygons == 6
    np.testing.assert_allclose(scene.areas.sum(), 6.0, rtol=1e-12)
    ref = radlab.reference(scene)
    np.testing.assert_allclose(ref.B, 2.0, rtol=1e-9)
    r = radlab.solve(scene, solver="gauss-seidel", tol=1e-10)
    assert r.tolerance_reached
    np.testing.assert_allclose(r.B, 2.0, rtol=1e-8)
