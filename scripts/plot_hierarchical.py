#!/usr/bin/env python3
"""Figures 4 and 5 of Hanrahan, Salzman & Aupperle 1991 from a radlab sweep's runs/.

    scripts/plot_hierarchical.py OUT   # OUT from experiments/hierarchical_fig4.toml or _fig5.toml

Fig. 4 (OUT named *fig4*): links against potential element pairs, (n/2)^2 for the n leaves the
run made (two polygons), with the n^2 (all pairs) and n (linear) lines. Fig. 5 (scenes with a
closed form): |F_links - F| against feps, F_links being the receiver's radiosity (element 1; the
emitter has E = 1 and reflects nothing, the receiver reflects everything). Writes OUT/fig4.png
and/or OUT/fig5.png and prints the numbers.
"""
import csv
import glob
import json
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

CLOSED_FORM = {  # Howell's catalogue: C-11 (parallel), C-14 (perpendicular), unit squares
    "hierarchical_parallel_1": 0.19982489569838746,
    "hierarchical_parallel_close": 0.8269945223972565,
    "hierarchical_perpendicular": 0.20004377607540316,
}


def runs(out):
    for path in sorted(glob.glob(os.path.join(out, "runs", "*.run.json"))):
        with open(path) as f:
            run = json.load(f)
        if run.get("solver", {}).get("name") != "hierarchical":
            continue
        scene = os.path.splitext(os.path.basename(run["scene"]["spec"]))[0]
        stats = run.get("solver_statistics", {})
        feps = float(run["solver"]["options"]["feps"])
        with open(path.replace(".run.json", ".radiosity.csv")) as f:
            rows = list(csv.DictReader(f))
        yield scene, feps, stats, rows


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    out = sys.argv[1]
    fig4, fig5 = {}, {}
    for scene, feps, stats, rows in runs(out):
        if "links" in stats:
            potential = (stats["leaves"] / 2.0) ** 2
            fig4.setdefault(scene, []).append((feps, potential, stats["links"], stats["leaves"]))
        if scene in CLOSED_FORM and len(rows) == 2:
            f_links = float(rows[1]["B_r"])
            fig5.setdefault(scene, []).append((feps, abs(f_links - CLOSED_FORM[scene]), f_links))
    name = os.path.basename(os.path.normpath(out))
    if "fig5" in name and fig5:
        plt.figure(figsize=(5.5, 4))
        for scene, points in sorted(fig5.items()):
            points.sort()
            print(scene, "F =", CLOSED_FORM[scene])
            for feps, err, f in points:
                print(f"  feps {feps:<8g} F_links {f:.6f}  error {err:.3g}")
            plt.loglog([p[0] for p in points], [p[1] for p in points], "o-",
                       label=scene.replace("hierarchical_", ""))
        xs = sorted({p[0] for pts in fig5.values() for p in pts})
        plt.loglog(xs, [0.01 * x for x in xs], "k:", label="0.01 feps")
        plt.xlabel("feps")
        plt.ylabel("|F(summed links) - F(closed form)|")
        plt.title("HSA 1991 Fig. 5: form-factor error against feps")
        plt.legend(fontsize=8)
        plt.tight_layout()
        plt.savefig(os.path.join(out, "fig5.png"), dpi=120)
        print("wrote", os.path.join(out, "fig5.png"))
    if "fig4" in name and fig4:
        which = "aeps falls, feps = 0.02" if "aeps" in name else "feps falls"
        plt.figure(figsize=(5.5, 4))
        lo, hi = math.inf, 0.0
        for scene, points in sorted(fig4.items()):
            points.sort(key=lambda p: p[1])
            print(scene)
            for feps, potential, links, leaves in points:
                print(f"  feps {feps:<8g} potential pairs {potential:<12.4g} links {links:<9.0f}"
                      f" leaves {leaves:.0f}")
                lo, hi = min(lo, potential), max(hi, potential)
            plt.loglog([p[1] for p in points], [p[2] for p in points], "o-",
                       label=scene.replace("hierarchical_", ""))
        xs = [lo, hi]
        plt.loglog(xs, xs, "k--", label="all pairs (n^2)")
        plt.loglog(xs, [20 * math.sqrt(x) for x in xs], "k:", label="40 n (linear)")
        plt.xlabel("potential element pairs (leaves/2)^2")
        plt.ylabel("links")
        plt.title(f"HSA 1991 Fig. 4: links against potential pairs ({which})", fontsize=9)
        plt.legend(fontsize=8)
        plt.tight_layout()
        plt.savefig(os.path.join(out, "fig4.png"), dpi=120)
        print("wrote", os.path.join(out, "fig4.png"))


if __name__ == "__main__":
    main()
