"""What the Python boundary costs (docs/python.md, "The cost of the boundary"), in one run:

1. A built-in solver's run from Python with a callback at every checkpoint. The boundary's cost
   is measured inside the run: Result.boundary_seconds (the hooks at checkpoints: taking the
   GIL, the Ctrl-C check, building the callback's dict and B, the callback) plus
   Result.python_seconds (before and after the run: the request, the result's arrays, the trace
   read back into pandas), against the run itself (run_wall_seconds - boundary_seconds: what
   `radlab solve` does). For context, the same run by `radlab solve`: its wall time for the
   budget minus its wall time for one step (both load the same cached matrix and reference).
2. The cost per step of a solver written in Python: an empty step (the call itself), and a step
   that reads one form-factor row (system.row(i), a float64 copy).

    PYTHONPATH=build/python python3 python/bench/boundary_cost.py --radlab build/cli/radlab \
        --scene builtin:computer-room --subdiv 3 --rows 20000

Each time is the best of --repeats runs. Not a test (timings depend on the machine).
"""

import argparse
import subprocess
import time

import radlab


def best(repeats, run):
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        result = run()
        times.append(time.perf_counter() - start)
    return min(times), result


class EmptyStep(radlab.Solver):
    name = "bench-empty-step"
    kind = "other"

    def init(self, system):
        self.B = system.E.copy()

    def step(self):
        return False

    def solution(self):
        return self.B


class RowStep(EmptyStep):
    name = "bench-row-step"

    def init(self, system):
        super().init(system)
        self.system, self.i = system, 0

    def step(self):
        self.system.row(self.i)
        self.i = (self.i + 1) % self.system.size
        return False


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--radlab", default="build/cli/radlab")
    parser.add_argument("--scene", default="builtin:computer-room")
    parser.add_argument("--subdiv", type=int, default=3)
    parser.add_argument("--solver", default="gauss-seidel")
    parser.add_argument("--rows", type=int, default=20000)
    parser.add_argument("--steps", type=int, default=5000, help="steps of the Python solvers")
    parser.add_argument("--repeats", type=int, default=3)
    a = parser.parse_args()

    scene = radlab.load(a.scene, subdiv=a.subdiv)
    radlab.reference(scene)  # prepares (or loads from the cache) the matrix and reference
    cli = [a.radlab, "solve", a.scene, "--subdiv", str(a.subdiv), "--solver", a.solver]
    one_step, _ = best(a.repeats, lambda: subprocess.run(cli + ["--steps", "1"], check=True,
                                                          capture_output=True))
    full, _ = best(a.repeats, lambda: subprocess.run(cli + ["--rows", str(a.rows)], check=True,
                                                      capture_output=True))
    cli_run = full - one_step
    calls = []

    def callback(checkpoint):
        calls.append(checkpoint["step"])

    plain, r = best(a.repeats, lambda: radlab.solve(scene, solver=a.solver, rows=a.rows))
    with_callback, r = best(a.repeats, lambda: radlab.solve(scene, solver=a.solver, rows=a.rows,
                                                            callback=callback))
    checkpoints = len(calls) // a.repeats
    run = r.run_wall_seconds - r.boundary_seconds
    boundary = r.boundary_seconds + r.python_seconds
    print(f"scene {a.scene} subdiv {a.subdiv}: {scene.size} elements; {a.solver}, "
          f"{a.rows} rows, {checkpoints} checkpoints")
    print(f"radlab.solve with a callback at every checkpoint (last of {a.repeats}): run "
          f"{run:.3f} s (solver {r.seconds:.3f} s, the rest the checkpoints' metrics); boundary "
          f"{boundary:.4f} s = {r.boundary_seconds:.4f} s at checkpoints + "
          f"{r.python_seconds:.4f} s before and after: {100 * boundary / run:.2f}% of the run")
    print(f"best wall of radlab.solve: {plain:.3f} s without callback, {with_callback:.3f} s "
          f"with; radlab solve's run: {cli_run:.3f} s (wall {full:.3f} s - {one_step:.3f} s for "
          "one step)")

    for cls in (EmptyStep, RowStep):
        wall, r = best(a.repeats, lambda: radlab.solve(scene, solver=cls, steps=a.steps))
        print(f"{cls.name}: {1e6 * r.seconds / r.steps:.2f} us per step (solver clock; the "
              f"wall, {1e6 * wall / r.steps:.0f} us per step, is the checkpoints' metrics)")
    builtin_step, r = best(a.repeats, lambda: radlab.solve(scene, solver="jacobi",
                                                           steps=a.steps))
    print(f"jacobi (C++, one row a step): {1e6 * r.seconds / r.steps:.2f} us per step")


if __name__ == "__main__":
    main()
