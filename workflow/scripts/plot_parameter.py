#!/usr/bin/env python3
"""Work to reach an error against a numeric solver parameter (e.g. omega), from summary.csv.

For every solver with a numeric parameter axis of three or more values (read from the `params`
column, "key=value,..."), one figure: a panel per scene, a line per mesh (elements), the rows to
reach the threshold divided by the elements (sweeps' worth of rows) against the parameter; every
other solver setting on the same problems (no numeric axis: e.g. overshooting's variants,
Jacobi) as a dashed horizontal line at its own value. Runs that never reached the threshold within
the budget are left out of the line (gaps, said in the title). Writes nothing, successfully, when
the sweep has no such axis.

    plot_parameter.py MERGED_DIR [--out FOLDER] [--metric rows_to_rms_rel_1e-3] [--formats png]
"""
import argparse
import os
import re
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402


def parse_params(text):
    if not isinstance(text, str) or not text:
        return {}
    return dict(part.split("=", 1) for part in text.split(",") if "=" in part)


def as_number(value):
    try:
        return float(value)
    except (TypeError, ValueError):
        return None


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sweep_dir")
    parser.add_argument("--out", help="folder for the figures (default SWEEP_DIR/plots)")
    parser.add_argument("--metric", default="rows_to_rms_rel_1e-3")
    parser.add_argument("--formats", default="png,pdf")
    args = parser.parse_args(argv)
    summary_path = os.path.join(args.sweep_dir, "summary.csv")
    if not os.path.exists(summary_path):
        sys.exit(f"plot_parameter: {summary_path}: no such file")
    s = pd.read_csv(summary_path)
    if args.metric not in s:
        sys.exit(f"plot_parameter: {summary_path} has no column {args.metric}")
    s["parsed"] = s["params"].map(parse_params)
    s["work"] = s[args.metric] / s["elements"]
    out = args.out or os.path.join(args.sweep_dir, "plots")
    scenes = list(dict.fromkeys(s["scene"]))
    written = []
    for solver, runs in s.groupby("solver", sort=False):
        keys = set().union(*runs["parsed"].map(set))
        for key in sorted(keys):
            values = {as_number(p.get(key)) for p in runs["parsed"]}
            if None in values or len(values) < 3:
                continue
            fig, axes = plt.subplots(1, len(scenes), figsize=(4.2 * len(scenes), 3.8),
                                     squeeze=False, sharey=True)
            missing = 0
            for ax, scene in zip(axes[0], scenes):
                on_scene = s[s["scene"] == scene]
                for elements, problem in on_scene.groupby("elements"):
                    mine = problem[problem["solver"] == solver].copy()
                    mine["x"] = mine["parsed"].map(lambda p: float(p[key]))
                    mine = mine.sort_values("x")
                    missing += int(mine["work"].isna().sum())
                    line, = ax.plot(mine["x"], mine["work"], "o-", ms=3,
                                    label=f"{solver}, {elements} elements")
                    others = problem[problem["solver"] != solver]
                    for _, other in others.iterrows():
                        if key in other["parsed"] and as_number(other["parsed"][key]) is not None:
                            continue  # another solver's own axis: its own figure
                        if pd.isna(other["work"]):
                            continue
                        ax.axhline(other["work"], color=line.get_color(), lw=0.6, ls="--",
                                   alpha=0.6)
                        if elements == on_scene["elements"].max():
                            label = other["solver"] + (
                                " " + other["params"] if isinstance(other["params"], str) else "")
                            ax.annotate(label, (mine["x"].max(), other["work"]), fontsize=5.5, ha="right",
                                        va="bottom", color="0.3")
                ax.set_title(scene.replace("builtin:", ""), fontsize=9)
                ax.set_xlabel(key)
                ax.set_yscale("log")
                ax.grid(True, which="both", alpha=0.3)
                ax.legend(fontsize=7)
            axes[0][0].set_ylabel(f"{args.metric} / elements (sweeps of rows)")
            title = f"{solver}: {args.metric} against {key}; dashed: the other solvers"
            if missing:
                title += f" ({missing} runs did not reach it within the budget: gaps)"
            fig.suptitle(title, fontsize=9)
            fig.tight_layout()
            os.makedirs(out, exist_ok=True)
            stem = os.path.join(out, re.sub(r"[^A-Za-z0-9._-]", "_", f"{solver}_{key}_{args.metric}"))
            for fmt in [f for f in args.formats.split(",") if f]:
                fig.savefig(f"{stem}.{fmt}", dpi=130)
            plt.close(fig)
            written.append(stem)
    for stem in written:
        print(f"wrote {stem}.{{{args.formats}}}")


if __name__ == "__main__":
    main(sys.argv[1:])
