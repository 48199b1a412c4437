#!/usr/bin/python3
"""p-error against accumulated shot form factors (Wu & Wang 2002, Figs 2 and 4).

Usage: plot_coverage.py OUT_DIR [--formats png,pdf] [--out FOLDER]

--out FOLDER writes the figures there instead of OUT_DIR/plots (e.g. docs/figures/NAME).

Reads OUT_DIR/coverage/<run>_step<NNNNNN>.csv (written by `radlab run` with a [coverage] table,
for solvers that track coverage; only of the runs sweep.json lists, and only of a complete sweep,
see sweep_runs.py) and writes OUT_DIR/plots/<run>_coverage.{png,pdf}: one panel per
step, elements sorted by their summed form factor dff from this session's shooters (the paper's
f(a)), p-error of each element against it. Elements that shot in the session are left out (their
dff is not meaningful), as in the paper's gathering criterion.
"""
import argparse
import glob
import os
import re
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402
from sweep_runs import listed_runs  # noqa: E402

PATTERN = re.compile(r"^(?P<run>.+)_step(?P<step>\d{6})\.csv$")


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out_dir")
    parser.add_argument("--formats", default="png,pdf")
    parser.add_argument("--out", help="folder for the figures (default OUT_DIR/plots)")
    args = parser.parse_args(argv)
    formats = [f for f in args.formats.split(",") if f]
    _, listed = listed_runs(args.out_dir, "plot_coverage")
    run_ids = {re.sub(r"[/: ,=]", "_", r): r for r in listed}  # file stem -> run id
    runs = {}
    for path in sorted(glob.glob(os.path.join(args.out_dir, "coverage", "*_step*.csv"))):
        match = PATTERN.match(os.path.basename(path))
        if match and match["run"] in run_ids:
            runs.setdefault(match["run"], []).append((int(match["step"]), path))
    if not runs:
        sys.exit(f"plot_coverage: no coverage files in {args.out_dir}/coverage")
    plots = args.out or os.path.join(args.out_dir, "plots")
    os.makedirs(plots, exist_ok=True)
    for run, files in runs.items():
        files.sort()
        fig, axes = plt.subplots(1, len(files), figsize=(4.2 * len(files), 3.8), squeeze=False)
        for ax, (step, path) in zip(axes[0], files):
            data = pd.read_csv(path)
            data = data[data["shot"] == 0].sort_values("dff")
            columns = [c for c in ["p_r", "p_g", "p_b"] if c in data] or ["p_mean"]
            colours = {"p_r": "tab:red", "p_g": "tab:green", "p_b": "tab:blue", "p_mean": "k"}
            for c in columns:
                ax.plot(range(len(data)), data[c], ".", ms=1.5, color=colours[c], label=c)
            ax.axhline(0.0, color="grey", lw=0.6)
            ax.set_xlabel("elements sorted by dff (increasing)")
            ax.set_ylabel("p-error")
            session = int(data["session"].iloc[0]) if len(data) else 0
            ax.set_title(f"step {step} (session {session})", fontsize=9)
            ax.legend(fontsize=7, markerscale=6)
        fig.suptitle(f"{run_ids.get(run, run)}: p-error against shot coverage "
                     "(Wu & Wang Figs 2/4)", fontsize=9)
        fig.tight_layout()
        stem = os.path.join(plots, f"{run}_coverage")
        for fmt in formats:
            fig.savefig(f"{stem}.{fmt}", dpi=120)
        plt.close(fig)
        print(f"wrote {stem}.{{{','.join(formats)}}}")


if __name__ == "__main__":
    main(sys.argv[1:])
