#!/usr/bin/python3
"""A contact sheet of a sweep's checkpoint images: one row per run, one column per step, like
Cohen et al. 1988 Figs 2-5 (each cell: the display image, and beside it the pseudo-colour error).

Usage: contact_sheet.py OUT_DIR [--kind display|cohen|perror|both] [--out FILE]

Reads OUT_DIR/images/<run>_step<NNNNNN>.png (and _cohen.png / _perror.png) as written by
`radlab run` with an [images] table, and writes OUT_DIR/plots/contact_sheet.png by default.
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

PATTERN = re.compile(r"^(?P<run>.+)_step(?P<step>\d{6})\.png$")


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out_dir")
    parser.add_argument("--kind", default="both", choices=["display", "cohen", "perror", "both"])
    parser.add_argument("--out")
    args = parser.parse_args(argv)
    images = os.path.join(args.out_dir, "images")
    runs = {}
    for path in sorted(glob.glob(os.path.join(images, "*_step*.png"))):
        match = PATTERN.match(os.path.basename(path))
        if match:  # the display image; error maps share its stem
            runs.setdefault(match["run"], {})[int(match["step"])] = path[: -len(".png")]
    if not runs:
        sys.exit(f"contact_sheet: no checkpoint images in {images}")
    steps = sorted({s for by_step in runs.values() for s in by_step})
    kinds = {"display": [""], "cohen": ["_cohen"], "perror": ["_perror"], "both": ["", "_cohen"]}[
        args.kind]
    columns = len(steps) * len(kinds)
    fig, axes = plt.subplots(len(runs), columns, figsize=(1.9 * columns, 2.0 * len(runs)),
                             squeeze=False)
    for r, (run, by_step) in enumerate(runs.items()):
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
                    ax.set_ylabel(run.split("_scene_")[0], fontsize=8)
    fig.tight_layout()
    out = args.out or os.path.join(args.out_dir, "plots", "contact_sheet.png")
    os.makedirs(os.path.dirname(out), exist_ok=True)
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")


if __name__ == "__main__":
    main(sys.argv[1:])
