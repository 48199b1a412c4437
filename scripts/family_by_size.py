#!/usr/bin/python3
"""Which family wins, by scene size (issue 32): every family against one certified reference.

Usage: family_by_size.py OUT [--radlab PATH] [--scenes cornell,classroom,office3,hospital]
                             [--seeds K] [--threads N] [--plot-only | --floor]

On each scene it runs, with `radlab solve ... --trace`, against the certified reference of the
method's own raycast F (`--ff-set symmetrise=false` for the runs that read the dense matrix, so
that every family is measured against the same reference: the one a matrix-free run reads):

  sorted-shooting, cached     rows from the dense matrix; seconds_with_setup charges the matrix's
                              build time (the cache's record of it) from the first row read
  sorted-shooting, on the fly every row computed when shot (its rays inside the solver's time)
  hierarchical                feps 0.04, clustering none and isotropic (refinement = its steps)
  stochastic-jacobi           1,000 rays per element per step, 10 steps, K seeds
  random-walk                 shooting walks, collision estimator, about as many rays, K seeds

and writes OUT/traces/*.csv, OUT/family_by_size.csv (per run: the final rms_rel_reflected and
seconds_with_setup, and the seconds_with_setup at which rms_rel_reflected first reaches 0.2, 0.1,
0.05, 0.02 and 0.01, linear in log error between checkpoints) and OUT/family_by_size.png
(rms_rel_reflected, mean of the channels, against seconds_with_setup, log-log, one panel per
scene; the seed repeats of a Monte Carlo configuration as their mean and min-max band).

The first run on a scene builds (or loads) the matrix and the certified reference into the cache
($RADLAB_CACHE_DIR or ~/.cache/radlab) and stores the reference's residual pass, so the
matrix-free runs after it read the reference without computing a row (`reference checked`).
Nothing is downloaded; the scene files come from ../shared/scenes beside the checkout.

--floor instead measures what the Monte Carlo solvers cannot get below against this reference:
their expectation is the exact-F system's solution (floor() below).
"""
import argparse
import csv
import math
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
SHARED = os.path.join(os.path.dirname(ROOT), "shared", "scenes", "renderpark")

# name: (scene spec, mesh arguments)
SCENES = {
    "cornell": ("builtin:cornell", ["--subdiv", "8"]),
    "classroom": (os.path.join(SHARED, "salon", "classroom.mgf"), []),
    "office3": (os.path.join(SHARED, "office3", "office.mgf"), []),
    "hospital": (os.path.join(SHARED, "hospital", "hosp.mgf"), []),
}
THRESHOLDS = [0.2, 0.1, 0.05, 0.02, 0.01]


def configurations(n, seeds):
    """(label, solve arguments, seed or None) of every run on a scene of n elements."""
    dense = ["--ff-set", "symmetrise=false"]
    runs = [
        ("sorted-shooting cached", dense + ["--solver", "sorted-shooting", "--rows", str(4 * n)],
         None),
        ("sorted-shooting on the fly", ["--ff-mode", "on-the-fly", "--solver", "sorted-shooting",
                                        "--rows", str(2 * n), "--seconds", "600"], None),
    ]
    for clustering in ["none", "isotropic"]:
        runs.append((f"hierarchical {clustering}",
                     dense + ["--solver", "hierarchical", "--set", "feps=0.04", "--set",
                              f"clustering={clustering}", "--steps", "100000"], None))
    for seed in range(seeds):
        runs.append(("stochastic-jacobi",
                     ["--solver", "stochastic-jacobi", "--set", f"rays={1000 * n}", "--set",
                      f"seed={seed}", "--steps", "10"], seed))
        runs.append(("random-walk shooting",
                     ["--solver", "random-walk", "--set", "walks=shooting", "--set",
                      "estimator=collision", "--set", f"paths={400 * n}", "--set", f"seed={seed}",
                      "--steps", "10"], seed))
    return runs


def read_trace(path):
    """[(seconds_with_setup, rms_rel_reflected, rays, pair_evals)] of the `mean` channel rows."""
    points = []
    with open(path, newline="") as f:
        for row in csv.DictReader(f):
            if row["channel"] != "mean":
                continue
            try:
                points.append((float(row["seconds_with_setup"]), float(row["rms_rel_reflected"]),
                               float(row["rays"] or 0), float(row["pair_evals"] or 0)))
            except (KeyError, ValueError):
                continue
    return points


def seconds_to(points, level):
    """seconds_with_setup at which rms_rel_reflected first reaches `level` (log-linear)."""
    for (t0, e0, *_), (t1, e1, *_) in zip(points, points[1:]):
        if e1 <= level < e0 and e0 > 0 and e1 > 0:
            w = (math.log(e0) - math.log(level)) / (math.log(e0) - math.log(e1))
            return t0 + w * (t1 - t0)
    if points and points[0][1] <= level:
        return points[0][0]
    return None


def element_count(radlab, scene, mesh):
    """The mesh's element count, from `radlab scenes` describing the scene and mesh."""
    out = subprocess.run([radlab, "--mgf-include-root", SHARED, "scenes", scene] + mesh,
                         capture_output=True, text=True)
    for line in out.stdout.splitlines():
        words = line.split()
        if len(words) >= 2 and words[0] == "elements" and words[1].isdigit():
            return int(words[1])
    sys.exit(f"family_by_size: cannot read the element count of {scene}:\n{out.stdout}{out.stderr}")


def run_all(args):
    os.makedirs(os.path.join(args.out, "traces"), exist_ok=True)
    for name in args.scenes:
        scene, mesh = SCENES[name]
        n = element_count(args.radlab, scene, mesh)
        print(f"== {name}: {n} elements", flush=True)
        for label, solve, seed in configurations(n, args.seeds):
            stem = f"{name}__{label.replace(' ', '_')}" + (f"__seed{seed}" if seed is not None else "")
            trace = os.path.join(args.out, "traces", stem + ".csv")
            refused = os.path.join(args.out, "traces", stem + ".refused")
            if os.path.exists(trace) or os.path.exists(refused):
                continue  # resumable: a finished (or refused) run is kept
            partial = trace + ".partial"
            command = [args.radlab, "--threads", str(args.threads), "--mgf-include-root", SHARED,
                       "solve", scene] + mesh + solve + [
                           "--trace", partial, "--json", os.path.join(args.out, "traces",
                                                                      stem + ".run.json")]
            start = time.time()
            done = subprocess.run(command, capture_output=True, text=True)
            print(f"   {label}{'' if seed is None else f' seed {seed}'}: exit {done.returncode} "
                  f"in {time.time() - start:.1f} s wall", flush=True)
            if done.returncode == 3:  # the scene is invalid input for this solver: say why
                message = [l for l in done.stderr.splitlines() if "error:" in l][-1:]
                with open(refused, "w") as f:
                    f.write((message[0] if message else done.stderr[-500:]) + "\n")
                print(f"   refused: {message[0] if message else '?'}", flush=True)
                continue
            if done.returncode not in (0, 5):  # 5: tolerance not reached (a budget stop)
                sys.stderr.write(done.stderr[-2000:])
                sys.exit(f"family_by_size: {' '.join(command)} failed")
            os.replace(partial, trace)


def summarise(args):
    rows = []
    for file in sorted(os.listdir(os.path.join(args.out, "traces"))):
        if not file.endswith(".csv"):
            continue
        parts = file[:-4].split("__")
        scene, label = parts[0], parts[1].replace("_", " ")
        seed = parts[2][4:] if len(parts) > 2 else ""
        points = read_trace(os.path.join(args.out, "traces", file))
        if not points:
            continue
        row = {"scene": scene, "family": label, "seed": seed,
               "final_rms_rel_reflected": points[-1][1], "seconds_with_setup": points[-1][0],
               "rays": points[-1][2], "pair_evals": points[-1][3]}
        for level in THRESHOLDS:
            t = seconds_to(points, level)
            row[f"seconds_to_{level:g}"] = "" if t is None else f"{t:.4g}"
        row["points"] = points
        rows.append(row)
    fields = [k for k in rows[0] if k != "points"] if rows else []
    with open(os.path.join(args.out, "family_by_size.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields, extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    return rows


def table(args, rows):
    """OUT/family_by_size.md: per scene and family (seeds averaged), the final error and time and
    the seconds to each error level (a dash where some seed never reached it)."""
    lines = ["| scene | family | final rms_rel_reflected | seconds with set-up | "
             + " | ".join(f"s to {level:g}" for level in THRESHOLDS) + " |",
             "|---|---|---|---|" + "---|" * len(THRESHOLDS)]
    for scene in args.scenes:
        for family in sorted({r["family"] for r in rows if r["scene"] == scene}):
            runs = [r for r in rows if r["scene"] == scene and r["family"] == family]
            mean = lambda key: sum(float(r[key]) for r in runs) / len(runs)  # noqa: E731
            cells = []
            for level in THRESHOLDS:
                reached = [r[f"seconds_to_{level:g}"] for r in runs]
                cells.append("—" if "" in reached else f"{sum(map(float, reached)) / len(runs):.3g}")
            seeds = f" ({len(runs)} seeds)" if len(runs) > 1 else ""
            lines.append(f"| {scene} | {family}{seeds} | {mean('final_rms_rel_reflected'):.3g} | "
                         f"{mean('seconds_with_setup'):.3g} | " + " | ".join(cells) + " |")
    folder = os.path.join(args.out, "traces")
    for scene in args.scenes:
        refusals = {}  # family: (seeds refused, why)
        for file in sorted(os.listdir(folder)):
            if file.startswith(scene + "__") and file.endswith(".refused"):
                family = file[:-8].split("__")[1].replace("_", " ")
                with open(os.path.join(folder, file)) as f:
                    why = f.read().strip().replace("|", "/")
                count, _ = refusals.get(family, (0, why))
                refusals[family] = (count + 1, why)
        for family, (count, why) in refusals.items():
            lines.append(f"| {scene} | {family} ({count} refused) | refused: {why} |"
                         + " |" * (1 + len(THRESHOLDS)))
    path = os.path.join(args.out, "family_by_size.md")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")
    print(f"family_by_size: wrote {path}")


def plot(args, rows):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    scenes = [s for s in args.scenes if any(r["scene"] == s for r in rows)]
    fig, axes = plt.subplots(1, len(scenes), figsize=(4.6 * len(scenes), 4.2), squeeze=False)
    colours = {}
    for ax, scene in zip(axes[0], scenes):
        families = sorted({r["family"] for r in rows if r["scene"] == scene})
        for family in families:
            runs = [r for r in rows if r["scene"] == scene and r["family"] == family]
            colour = colours.setdefault(family, f"C{len(colours)}")
            if len(runs) == 1:
                t, e = zip(*[(p[0], p[1]) for p in runs[0]["points"] if p[0] > 0 and p[1] > 0])
                ax.plot(t, e, color=colour, label=family)
                continue
            # Seeds: the same checkpoints (steps) in every repeat; mean seconds, mean and range.
            k = min(len(r["points"]) for r in runs)
            t = [sum(r["points"][i][0] for r in runs) / len(runs) for i in range(k)]
            e = [[r["points"][i][1] for r in runs] for i in range(k)]
            keep = [i for i in range(k) if t[i] > 0 and min(e[i]) > 0]
            ax.plot([t[i] for i in keep], [sum(e[i]) / len(e[i]) for i in keep], color=colour,
                    label=f"{family} ({len(runs)} seeds)")
            ax.fill_between([t[i] for i in keep], [min(e[i]) for i in keep],
                            [max(e[i]) for i in keep], color=colour, alpha=0.25, linewidth=0)
        ax.set_xscale("log")
        ax.set_yscale("log")
        # The range where the families compete; a cached flat run that goes on to 1e-9 leaves
        # the panel at its bottom edge (family_by_size.csv has its final error).
        ax.set_ylim(3e-4, 1.5)
        ax.legend(fontsize=7, loc="lower left")
        ax.set_title(scene)
        ax.set_xlabel("seconds including set-up")
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].set_ylabel("rms_rel_reflected against the certified reference")
    fig.tight_layout()
    path = os.path.join(args.out, "family_by_size.png")
    fig.savefig(path, dpi=110)
    print(f"family_by_size: wrote {path}")


def floor(args):
    """The Monte Carlo estimates' own floor against the certified reference: their expectation is
    the solution of the exact-F system, the reference the raycast-F one's. On the Cornell box at
    subdiv 4 (320 elements; `exact` with visibility=clip, every pair to 1e-10) both are solved to
    a certified bound and compared as rms_rel_reflected (E read off one sorted-shooting step: it
    shoots the lamp, which receives nothing from itself)."""
    import numpy as np
    folder = os.path.join(args.out, "floor")
    os.makedirs(folder, exist_ok=True)
    scene = ["builtin:cornell", "--subdiv", "4"]
    files = {k: os.path.join(folder, k + ".csv") for k in ("exact", "raycast", "emission")}
    commands = [
        ["reference"] + scene + ["--ff", "exact", "--ff-set", "visibility=clip", "--out",
                                 files["exact"]],
        ["reference"] + scene + ["--ff-set", "symmetrise=false", "--out", files["raycast"]],
        ["solve"] + scene + ["--solver", "sorted-shooting", "--steps", "1", "--reference", "none",
                             "--out", files["emission"]],
    ]
    for command in commands:
        done = subprocess.run([args.radlab, "-q"] + command, capture_output=True, text=True)
        if done.returncode != 0:
            sys.exit(f"family_by_size: radlab {' '.join(command)} failed:\n{done.stderr}")
    exact, raycast, first = (np.loadtxt(files[k], delimiter=",", skiprows=1, ndmin=2)
                             for k in ("exact", "raycast", "emission"))
    area = raycast[:, 1]
    lamp = first[:, 2] >= 0.5 * first[:, 2].max()
    emission = np.where(lamp[:, None], first[:, 2:], 0.0)
    per_channel = []
    for c in range(raycast.shape[1] - 2):
        reflected = raycast[:, 2 + c] - emission[:, c]
        difference = exact[:, 2 + c] - raycast[:, 2 + c]
        per_channel.append(math.sqrt((area * difference**2).sum() / (area * reflected**2).sum()))
    print("floor: rms_rel_reflected of the exact-F solution against the raycast-F reference, "
          f"Cornell subdiv 4: {np.mean(per_channel):.4g} (channels "
          + ", ".join(f"{v:.4g}" for v in per_channel) + ")")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out")
    parser.add_argument("--radlab", default=os.path.join(ROOT, "build", "cli", "radlab"))
    parser.add_argument("--scenes", default="cornell,classroom,office3,hospital")
    parser.add_argument("--seeds", type=int, default=4)
    parser.add_argument("--threads", type=int, default=0)
    parser.add_argument("--plot-only", action="store_true")
    parser.add_argument("--floor", action="store_true",
                        help="only measure the Monte Carlo floor (exact-F against raycast-F)")
    args = parser.parse_args()
    args.scenes = args.scenes.split(",")
    for s in args.scenes:
        if s not in SCENES:
            sys.exit(f"family_by_size: unknown scene '{s}' (known: {', '.join(SCENES)})")
    if args.seeds < 1:
        sys.exit("family_by_size: --seeds must be >= 1")
    if args.floor:
        return floor(args)
    if not args.plot_only:
        if not os.access(args.radlab, os.X_OK):
            sys.exit(f"family_by_size: {args.radlab}: not an executable (build radlab first)")
        run_all(args)
    rows = summarise(args)
    if not rows:
        sys.exit(f"family_by_size: no traces in {args.out}/traces")
    table(args, rows)
    plot(args, rows)


if __name__ == "__main__":
    main()
