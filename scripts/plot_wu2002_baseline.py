#!/usr/bin/python3
"""Wu & Wang 2002's pure-shooting baseline, per channel (their Figs 1 and 3), from a run of
experiments/wu2002_baseline_*.toml (Debian's python3-matplotlib, numpy, pandas).

Usage: plot_wu2002_baseline.py OUT_DIR --turning R,G,B --shots S [--out FOLDER]

Writes FOLDER/<scene>_baseline_p_channels.png: mean |p| against steps (= form-factor rows) per
channel for every run — solid double storage, dashed float storage; Cohen's ambient is drawn on
its display (the p_mean_display column), everything else on solution() — with the paper's
turning numbers as dotted verticals; and FOLDER/<scene>_interleaving_lead.png: interleaving's
mean |p| minus pure shooting's over the gathering session (below zero: interleaving leads).
"""
import argparse
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

CHANNELS = [("r", "red"), ("g", "green"), ("b", "blue")]


def label(run_id):
    parts = run_id.split("/")
    return parts[0] + " " + " ".join(p for p in parts[2:])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out_dir")
    ap.add_argument("--turning", required=True, help="the paper's turning numbers r,g,b")
    ap.add_argument("--shots", type=int, required=True, help="interleaving's shooting session")
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    turning = [int(x) for x in args.turning.split(",")]
    out = args.out or os.path.join(args.out_dir, "plots")
    os.makedirs(out, exist_ok=True)
    t = pd.read_csv(os.path.join(args.out_dir, "trace.csv"))
    scene = t["scene"].iloc[0].replace("builtin:", "")
    runs = list(dict.fromkeys(t["run_id"]))

    fig, axes = plt.subplots(1, 3, figsize=(16, 5.2), sharey=True)
    colours = {}
    for (ch, name), ax in zip(CHANNELS, axes):
        for rid in runs:
            h = t[(t.run_id == rid) & (t.channel == ch)].sort_values("step")
            col = "p_mean_display" if "ambient:true" in rid else "p_mean"
            key = rid.replace("storage:float", "storage:double")
            style = "--" if "storage:float" in rid else "-"
            line, = ax.plot(h["step"], h[col], style, lw=1.2, color=colours.get(key),
                            label=label(rid) + (" (display)" if col.endswith("display") else ""))
            colours.setdefault(key, line.get_color())
        ax.axvline(turning[CHANNELS.index((ch, name))], color="k", ls=":", lw=1)
        ax.set_yscale("log")
        ax.set_title(f"{name}: the paper's turning number {turning[CHANNELS.index((ch, name))]}")
        ax.set_xlabel("steps (form-factor rows)")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("mean |p-error|")
    axes[0].legend(fontsize=7, loc="lower left")
    fig.suptitle(f"Wu & Wang 2002 baseline on builtin:{scene}: no run turns upwards "
                 "(dashed: float storage of x and dB, on top of solid)")
    fig.tight_layout()
    path = os.path.join(out, f"{scene}_baseline_p_channels.png")
    fig.savefig(path, dpi=110)
    print("wrote", path)

    pure = [r for r in runs if r.startswith("interleaved/") and "gathers:0" in r]
    mixed = [r for r in runs if r.startswith("interleaved/") and "gathers:0" not in r]
    if pure and mixed:
        fig, ax = plt.subplots(figsize=(8, 4.5))
        for ch, name in CHANNELS:
            a = t[(t.run_id == pure[0]) & (t.channel == ch)].set_index("step")["p_mean"]
            b = t[(t.run_id == mixed[0]) & (t.channel == ch)].set_index("step")["p_mean"]
            steps = [s for s in b.index if s >= args.shots and s in a.index]
            ax.plot([s - args.shots for s in steps], [b[s] - a[s] for s in steps], color=name,
                    label=name)
        ax.axhline(0, color="k", lw=0.8)
        ax.set_xlabel("steps after the first shooting session of %d shots (then sessions of "
                      "gathers and shots alternate)" % args.shots)
        ax.set_ylabel("mean |p|: interleaving − pure shooting")
        ax.set_title(f"builtin:{scene}: below zero, interleaving leads")
        ax.grid(True, alpha=0.3)
        ax.legend()
        fig.tight_layout()
        path = os.path.join(out, f"{scene}_interleaving_lead.png")
        fig.savefig(path, dpi=110)
        print("wrote", path)


if __name__ == "__main__":
    main()
