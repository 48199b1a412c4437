#!/usr/bin/python3
"""Accuracy versus cost of the form-factor methods on closed forms from Howell's catalogue.

Usage: scripts/formfactor_catalogue.py [RADLAB] [--out-dir docs/figures] [--repeats 3]

RADLAB is the radlab binary (default build/cli/radlab). Needs Debian's python3-numpy and
python3-matplotlib. Writes OUT_DIR/formfactors_catalogue.csv and
OUT_DIR/formfactors_accuracy_cost.png, and prints the Markdown table of docs/formfactors.md.
Takes about 30 s.

Cases: two unit squares, one element each (no --subdiv), written as OBJ + MTL (the first square
emits: Ke) into a temporary folder:
  parallel squares facing each other at distance d = 0.1, 0.5, 1, 2 (Howell C-11), and
  perpendicular squares sharing an edge (Howell C-14).
For each method and setting the script runs
  radlab formfactors SCENE --ff METHOD [--ff-set k=v ...] --ff-set symmetrise=false \
      --precision double --out F.csv
reads F_01 from F.csv and compares it with the closed form. symmetrise=false and double precision
so that the table shows the method's own value (symmetrising averages F_01 with F_10, which are
equal here by symmetry anyway; float storage would put a floor of ~6e-8 under every error).

The hemicube of row i sits at the centre of element i, so with one element per square it computes the form
factor from that centre point to the other square, not the area-to-area one: its error against
the catalogue is mostly that point approximation. The CSV and table therefore also give its error
against the exact point-to-square form factor (Lambert's formula, computed here; 0.239456470 at
d = 1, the catalogue's differential element under the centre of a unit square), which isolates the pixel (aliasing) error.

Time per row. In a 2-element scene a row is one pair integration (raycast, exact) or one
hemicube; a whole 2-row build takes microseconds to milliseconds and is dominated by thread
start-up, below what `radlab formfactors` can time. So each setting is also run as
  radlab solve SCENE --ff METHOD [--ff-set k=v ...] --ff-mode on-the-fly --solver jacobi \
      --rows N --json run.json
which recomputes a row for every Jacobi step and charges its time to the solver: the time per row
is run.seconds / run.ff_rows (solver steps only; a 2-element Jacobi step adds nanoseconds). N is
chosen for about 0.1 s of rows after a probe of 4 rows; radlab runs on one CPU (the child's
affinity is one core, so it uses one thread) and the time is the minimum of --repeats runs.
Kernel evaluations (point-to-polygon evaluations; for the hemicube, depth tests) and rays per row
come from the formfactors run (its totals over the two rows, halved: both rows are the same work
by symmetry). No method casts rays here: two squares form a convex enclosure, so nothing can
occlude.
"""
import argparse
import csv
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

TARGET_SECONDS = 0.1  # timing: rows enough for about this long (after a probe of PROBE_ROWS)
PROBE_ROWS = 4
MAX_ROWS = 100000

CASES = [
    # name, label, distance (None: perpendicular), closed form (Howell's catalogue)
    ("parallel_0.1", "parallel, d = 0.1", 0.1, 0.826994522397),
    ("parallel_0.5", "parallel, d = 0.5", 0.5, 0.415253283577),
    ("parallel_1", "parallel, d = 1", 1.0, 0.199824895698),
    ("parallel_2", "parallel, d = 2", 2.0, 0.0685895888186),
    ("perpendicular", "perpendicular, shared edge", None, 0.200043776075),
]

SETTINGS = [
    # method, --ff-set assignments, label
    ("raycast", [], "raycast (default: tolerance=1e-4)"),
    ("raycast", ["tolerance=1e-6"], "raycast tolerance=1e-6"),
    ("raycast", ["tolerance=1e-8"], "raycast tolerance=1e-8"),
    ("hemicube", ["resolution=50"], "hemicube R=50, midpoint"),
    ("hemicube", [], "hemicube R=150 (default), midpoint"),
    ("hemicube", ["resolution=500"], "hemicube R=500, midpoint"),
    ("hemicube", ["resolution=50", "weights=exact"], "hemicube R=50, exact weights"),
    ("hemicube", ["weights=exact"], "hemicube R=150, exact weights"),
    ("hemicube", ["resolution=500", "weights=exact"], "hemicube R=500, exact weights"),
    ("exact", [], "exact (default: tolerance=1e-10)"),
]

MTL = """# radlab form-factor catalogue: the first square emits
newmtl emitter
Kd 0.5 0.5 0.5
Ke 1 1 1
newmtl receiver
Kd 0.5 0.5 0.5
"""

SQUARE_A = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)  # z = 0, faces +z


def square_b(distance):
    """The second square: parallel at height d facing -z, or in the plane x = 0 facing +x."""
    if distance is None:
        return np.array([[0, 0, 0], [0, 1, 0], [0, 1, 1], [0, 0, 1]], float)
    return np.array([[0, 0, distance], [0, 1, distance], [1, 1, distance], [1, 0, distance]])


def normal(polygon):
    n = np.cross(polygon[1] - polygon[0], polygon[2] - polygon[0])
    return n / np.linalg.norm(n)


def write_scene(path, distance):
    b = square_b(distance)
    lines = ["# two unit squares (radlab form-factor catalogue)", "mtllib catalogue.mtl"]
    lines += ["v %.17g %.17g %.17g" % tuple(p) for p in np.vstack([SQUARE_A, b])]
    lines += ["usemtl emitter", "f 1 2 3 4", "usemtl receiver", "f 5 6 7 8"]
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def point_to_polygon(x, n, polygon):
    """Lambert's contour formula: the form factor from a differential area at x (normal n) to a
    polygon wholly on or above x's tangent plane."""
    a = polygon - x
    total = 0.0
    for k in range(len(a)):
        p, q = a[k], a[(k + 1) % len(a)]
        c = np.cross(p, q)
        gamma = math.atan2(np.linalg.norm(c), float(np.dot(p, q)))
        total += gamma * float(np.dot(n, c)) / np.linalg.norm(c)
    return abs(total) / (2 * math.pi)


class Radlab:
    def __init__(self, binary, work):
        self.binary = binary
        self.work = work
        self.cpu = sorted(os.sched_getaffinity(0))[-1]

    def call(self, arguments):
        """Runs radlab on one CPU with an empty cache; returns (stdout, log)."""
        cache = os.path.join(self.work, "cache")
        shutil.rmtree(cache, ignore_errors=True)
        env = dict(os.environ, RADLAB_CACHE_DIR=cache)
        command = [self.binary] + arguments
        result = subprocess.run(command, env=env, capture_output=True, text=True,
                                preexec_fn=lambda: os.sched_setaffinity(0, {self.cpu}))
        if result.returncode != 0:
            sys.exit("failed (exit %d): %s\n%s" % (result.returncode, " ".join(command),
                                                     result.stderr))
        return result.stdout, result.stderr

    def formfactors(self, scene, method, assignments):
        """`radlab formfactors`: the method's own F (not symmetrised, stored in double)."""
        command = ["formfactors", scene, "--ff", method]
        for assignment in assignments + ["symmetrise=false"]:
            command += ["--ff-set", assignment]
        command += ["--precision", "double", "--out", os.path.join(self.work, "F.csv")]
        return self.call(command)

    def seconds_per_row(self, scene, method, assignments, rows, repeats):
        """Solver time per form-factor row computed on the fly (minimum of `repeats` runs)."""
        best = math.inf
        run_json = os.path.join(self.work, "run.json")
        for _ in range(repeats):
            command = ["solve", scene, "--ff", method]
            for assignment in assignments:
                command += ["--ff-set", assignment]
            command += ["--ff-mode", "on-the-fly", "--solver", "jacobi", "--rows", str(rows),
                        "--json", run_json]
            self.call(command)
            with open(run_json) as f:
                run = json.load(f)["run"]
            best = min(best, run["seconds"] / run["ff_rows"])
        return best

    def entry(self, i, j):
        with open(os.path.join(self.work, "F.csv")) as f:
            for row in csv.DictReader(f):
                if int(row["i"]) == i and int(row["j"]) == j:
                    return float(row["F"])
        return 0.0


def measure(radlab, case, setting, repeats):
    name, _, distance, closed = case
    method, assignments, label = setting
    work = radlab.work
    scene = os.path.join(work, "pair.obj")
    write_scene(scene, distance)
    out, log = radlab.formfactors(scene, method, assignments)
    value = radlab.entry(0, 1)
    rays = int(re.search(r"^rays\s+(\d+)", out, re.M).group(1))
    evaluations = int(re.search(r"(\d+) kernel evaluations", log).group(1))
    parameters = re.search(r"^method\s+\S+ \((.*)\)", out, re.M).group(1)

    # Timing: rows computed on the fly by a solver, on one core.
    probe = radlab.seconds_per_row(scene, method, assignments, PROBE_ROWS, 1)
    rows_timed = int(min(MAX_ROWS, max(PROBE_ROWS, math.ceil(TARGET_SECONDS / max(probe, 1e-9)))))
    per_row = radlab.seconds_per_row(scene, method, assignments, rows_timed, repeats)

    centre = SQUARE_A.mean(axis=0)
    point = point_to_polygon(centre, normal(SQUARE_A), square_b(distance))
    return {
        "case": name,
        "closed_form": "%.12g" % closed,
        "method": method,
        "settings": " ".join(assignments),
        "label": label,
        "parameters": parameters,
        "F01": "%.17g" % value,
        "relative_error": "%.3e" % (abs(value - closed) / closed),
        "point_to_square": "%.12g" % point,
        "relative_error_vs_point": "%.3e" % (abs(value - point) / point),
        "seconds_per_row": "%.3e" % per_row,
        "rows_timed": rows_timed,
        "kernel_evaluations_per_row": evaluations // 2,
        "rays": rays,
    }


def short_time(seconds):
    if seconds >= 1e-3:
        return "%.3g ms" % (seconds * 1e3)
    return "%.3g µs" % (seconds * 1e6)


def table(rows):
    """Markdown: one line per setting; per case the relative error and the time per row, then a
    second table of kernel evaluations per row."""
    def find(case, setting):
        return next(r for r in rows if r["case"] == case[0] and r["label"] == setting[2])

    lines = ["| method, setting | " + " | ".join(c[1] for c in CASES) + " |",
             "|" + "---|" * (len(CASES) + 1)]
    for setting in SETTINGS:
        cells = []
        for case in CASES:
            r = find(case, setting)
            cell = "%s · %s" % (r["relative_error"], short_time(float(r["seconds_per_row"])))
            if r["method"] == "hemicube":
                cell += " (point: %s)" % r["relative_error_vs_point"]
            cells.append(cell)
        lines.append("| %s | %s |" % (setting[2], " | ".join(cells)))
    lines += ["", "| kernel evaluations per row | " + " | ".join(c[1] for c in CASES) + " |",
              "|" + "---|" * (len(CASES) + 1)]
    for setting in SETTINGS:
        cells = [str(find(case, setting)["kernel_evaluations_per_row"]) for case in CASES]
        lines.append("| %s | %s |" % (setting[2], " | ".join(cells)))
    return "\n".join(lines)


def plot(rows, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    markers = {"raycast": "o", "hemicube": "s", "exact": "*"}
    # One colour per raycast tolerance and per hemicube resolution; exact weights hollow.
    colours = ["#1f77b4", "#17becf", "#2ca02c", "#d62728", "#9467bd", "#8c564b",
               "#d62728", "#9467bd", "#8c564b", "#ff7f0e"]
    fig, axes = plt.subplots(1, 2, figsize=(13, 6.2), sharey=True)
    floor = 1e-16  # an exact match plots here
    for ax, key, title in [
        (axes[0], "relative_error", "relative error of F_01 against the closed form"),
        (axes[1], "relative_error_vs_point",
         "hemicube only: error against the form factor from the first square's centre point"),
    ]:
        for s, setting in enumerate(SETTINGS):
            method, assignments, label = setting
            if key == "relative_error_vs_point" and method != "hemicube":
                continue
            xs, ys = [], []
            for case in CASES:
                r = next(r for r in rows if r["case"] == case[0] and r["label"] == label)
                xs.append(float(r["seconds_per_row"]))
                ys.append(max(float(r[key]), floor))
            hollow = "weights=exact" in assignments
            ax.loglog(xs, ys, linestyle="none", marker=markers[method],
                      markersize=12 if method == "exact" else 9, color=colours[s],
                      markeredgewidth=1.5, label=label,
                      markerfacecolor="none" if hollow else colours[s])
        ax.set_xlabel("time per row on one core [s] (raycast, exact: one pair; hemicube: one "
                      "hemicube)")
        ax.set_title(title, fontsize=10)
        ax.grid(True, which="major", alpha=0.3)
    axes[0].set_ylabel("relative error (one marker per catalogue case)")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=4, fontsize=8, frameon=False)
    fig.suptitle("Form factors against Howell's catalogue: two unit squares (parallel at d = 0.1, "
                 "0.5, 1, 2; perpendicular with a shared edge), one element each; errors below "
                 "1e-16 plot at 1e-16", fontsize=10)
    fig.tight_layout(rect=(0, 0.1, 1, 1))
    fig.savefig(path, dpi=110)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("radlab", nargs="?", default="build/cli/radlab")
    parser.add_argument("--out-dir", default="docs/figures")
    parser.add_argument("--repeats", type=int, default=3, help="timing runs per point (minimum)")
    args = parser.parse_args()
    binary = os.path.abspath(args.radlab)
    if not os.access(binary, os.X_OK):
        sys.exit("%s: not an executable (build radlab first, or pass its path)" % binary)
    start = time.time()
    rows = []
    with tempfile.TemporaryDirectory(prefix="radlab-catalogue-") as work:
        with open(os.path.join(work, "catalogue.mtl"), "w") as f:
            f.write(MTL)
        radlab = Radlab(binary, work)
        for case in CASES:
            for setting in SETTINGS:
                rows.append(measure(radlab, case, setting, args.repeats))
                r = rows[-1]
                print("%-14s %-38s F=%-20s err=%s  %s/%s" % (
                    r["case"], r["label"], r["F01"], r["relative_error"],
                    short_time(float(r["seconds_per_row"])), "row"), file=sys.stderr)
    os.makedirs(args.out_dir, exist_ok=True)
    csv_path = os.path.join(args.out_dir, "formfactors_catalogue.csv")
    with open(csv_path, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0].keys()), lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
    png_path = os.path.join(args.out_dir, "formfactors_accuracy_cost.png")
    plot(rows, png_path)
    print(table(rows))
    print("\nwrote %s and %s in %.0f s" % (csv_path, png_path, time.time() - start),
          file=sys.stderr)


if __name__ == "__main__":
    main()
