"""radlab.solve and `radlab solve` are one run (issue 34): for the same request they write the
same solution file byte for byte and the same trace rows (time columns aside), and r.B and
r.trace hold exactly the numbers of those files."""

import csv
import subprocess

import numpy as np
import pandas as pd
import pytest

import radlab

# Three solvers of three kinds (gathering with a parameter, shooting, matrix-vector), on a grey
# closed scene and an RGB open one.
RUNS = [
    ("gauss-seidel", {"omega": 1.2}, ["--set", "omega=1.2"]),
    ("sorted-shooting", {}, []),
    ("conjugate-gradient", {}, []),
]
SCENES = [("builtin:cube", 4), ("builtin:cornell", 4)]


def rows_without_time(path):
    time = set(radlab.time_columns())
    with open(path, newline="") as f:
        table = list(csv.reader(f))
    keep = [i for i, name in enumerate(table[0]) if name not in time]
    return [[row[i] for i in keep] for row in table]


@pytest.mark.parametrize("scene_spec,subdiv", SCENES)
@pytest.mark.parametrize("solver,params,cli_set", RUNS)
def test_python_solve_equals_the_command_line(tmp_path, radlab_binary, scene_spec, subdiv,
                                              solver, params, cli_set):
    steps = "300"
    cli_out, cli_trace = tmp_path / "cli_B.csv", tmp_path / "cli_trace.csv"
    subprocess.run([radlab_binary, "solve", scene_spec, "--subdiv", str(subdiv), "--solver",
                    solver, *cli_set, "--steps", steps, "--out", str(cli_out), "--trace",
                    str(cli_trace)], check=True, capture_output=True)

    scene = radlab.load(scene_spec, subdiv=subdiv)
    py_out, py_trace = tmp_path / "py_B.csv", tmp_path / "py_trace.csv"
    r = radlab.solve(scene, solver=solver, steps=int(steps), params=params, out=py_out,
                     trace=py_trace)

    assert py_out.read_bytes() == cli_out.read_bytes()
    assert rows_without_time(py_trace) == rows_without_time(cli_trace)
    # r.B is the file's numbers (written %.17g, which round-trips a double).
    cli_B = pd.read_csv(cli_out, float_precision="round_trip")[["B_r", "B_g", "B_b"]].to_numpy()
    assert np.array_equal(r.B, cli_B)
    # radlab.read_solution reads such a file back in element order.
    assert np.array_equal(radlab.read_solution(cli_out, scene.size), cli_B)
    # r.trace is the file's table, value for value (time columns aside).
    cli = pd.read_csv(cli_trace, float_precision="round_trip", keep_default_na=False,
                      na_values=[""])
    keep = [c for c in cli.columns if c not in radlab.time_columns()]
    pd.testing.assert_frame_equal(r.trace[keep], cli[keep], check_exact=True)
