#!/usr/bin/python3
"""A contact sheet of a sweep's checkpoint images: one row per run, one column per step, like
Cohen et al. 1988 Figs 2-5 (each cell: the display image, and beside it the pseudo-colour error).

Usage: contact_sheet.py OUT_DIR [--kind display|cohen|perror|both] [--out FILE]

Reads OUT_DIR/images/<run>_step<NNNNNN>.png (and _cohen.png / _perror.png) as written by
`radlab run` with an [images] table, and writes OUT_DIR/plots/contact_sheet.png by default.
Rows follow the sweep's run order (sweep.json) and are labelled with the full run id, parameters
included. Only the runs sweep.json lists are shown (images of other runs in the folder are
ignored), and a sweep that is not complete is refused (sweep_runs.py).
"""
import argparse
import glob
import os
import re
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.image as mpimg  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
from sweep_runs import listed_runs  # noqa: E402

PATTERN = re.compile(r"^(?P<run>.+)_step(?P<step>\d{6})\.png$")


def file_stem(run_id):
    """The file name radlab gives a run's files (experiments/sweep/sweep.cpp: file_stem)."""
    return re.sub(r"[/: ,=]", "_", run_id)


def wrapped(run_id, width=28):
    """The run id over several lines, broken after '/' where it is long."""
    lines, line = [], ""
    for part in run_id.split("/"):
        piece = part if not line else "/" + part
        if line and len(line) + len(piece) > width:
            lines.append(line + "/")
            line = part
        else:
            line += piece
    return "\n".join(lines + [line])


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out_dir")
    parser.add_argument("--kind", default="both", choices=["display", "cohen", "perror", "both"])
    parser.add_argument("--out")
    args = parser.parse_args(argv)
    _, run_ids = listed_runs(args.out_dir, "contact_sheet")
    images = os.path.join(args.out_dir, "images")
    runs = {}
    for path in sorted(glob.glob(os.path.join(images, "*_step*.png"))):
        match = PATTERN.match(os.path.basename(path))
        if match:  # the display image; error maps share its stem
            runs.setdefault(match["run"], {})[int(match["step"])] = path[: -len(".png")]
    # Sweep order, labelled by run id; images of runs the sweep does not list are left out.
    ordered = []
    for run_id in run_ids:
        stem = file_stem(run_id)
        if stem in runs:
            ordered.append((run_id, runs.pop(stem)))
    if runs:
        print(f"contact_sheet: ignored images of {len(runs)} runs sweep.json does not list",
              file=sys.stderr)
    if not ordered:
        sys.exit(f"contact_sheet: no checkpoint images of the sweep's runs in {images}")
    steps = sorted({s for _, by_step in ordered for s in by_step})
    kinds = {"display": [""], "cohen": ["_cohen"], "perror": ["_perror"], "both": ["", "_cohen"]}[
        args.kind]
    columns = len(steps) * len(kinds)
    fig, axes = plt.subplots(len(ordered), columns,
                             figsize=(1.9 * columns + 1.2, 2.0 * len(ordered)), squeeze=False)
    for r, (run, by_step) in enumerate(ordered):
        for s, step in enumerate(steps):
            for k, suffix in enumerate(kinds):
                ax = axes[r][s * len(kinds) + k]
                ax.set_xticks([])
                ax.set_yticks([])
                stem = by_step.get(step)
                if stem and os.path.exists(stem + suffix + ".png"):
                    ax.imshow(mpimg.imread(stem + suffix + ".png"))
                if r == 0:
                    ax.set_title(f"step {step}" + (" (error)" if suffix else ""), fontsize=8)
                if s == 0 and k == 0:
                    ax.set_ylabel(wrapped(run), fontsize=7)
    fig.tight_layout()
    out = args.out or os.path.join(args.out_dir, "plots", "contact_sheet.png")
    os.makedirs(os.path.dirname(out), exist_ok=True)
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")


if __name__ == "__main__":
    main(sys.argv[1:])
