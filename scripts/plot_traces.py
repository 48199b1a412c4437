#!/usr/bin/python3
"""Convergence plots from a radlab trace (Debian's python3-matplotlib, numpy, pandas).

Usage: plot_traces.py OUT_DIR [--formats png,pdf] [--out FOLDER]

--out FOLDER writes the figures there instead of OUT_DIR/plots (e.g. docs/figures/NAME).

Reads OUT_DIR/trace.csv, sweep.json (the experiment's name, and the runs to plot: only those it
lists; a sweep that is not complete is refused, see sweep_runs.py) and runs/*.run.json (each
run's scene, mesh and form factors) and writes into OUT_DIR/plots/, per scene and mesh:
  <scene>_rms_rel_vs_rows, <scene>_rms_rel_vs_seconds, <scene>_p_mean_vs_rows,
  <scene>_p_mean_vs_seconds   one line per run, log y; solid = solution(), dashed = display()
                              when it differs (e.g. Cohen's ambient term);
  <scene>_p_channels          per-channel p-error panels (Wu & Wang 2002, Figs 1 and 3), RGB scenes.
A configuration run over several solver seeds (aggregate.csv lists it: `solver_seeds` or `repeats`
in the experiment) is drawn as one line, the mean over its seeds at each checkpoint, inside a
shaded 90% band, mean +- t90 sd/sqrt(K) with aggregate.csv's Student-t factor t90 (the band of
the summary's final values, experiments/run/seed_aggregate.h).
Each figure is titled with the experiment, the scene, the mesh (elements, subdivision or element
size) and the form-factor settings (method, parameters, precision, cached or on the fly). When a
scene appears with several meshes or form-factor settings, <scene> gets a suffix per setting.
"""
import argparse
import json
import os
import re
import sys
import textwrap

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from sweep_runs import listed_runs  # noqa: E402


def file_stem(run_id):
    """The file name radlab gives a run's files (experiments/sweep/sweep.cpp: file_stem)."""
    return re.sub(r"[/: ,=]", "_", run_id)


def problem_of(out_dir, run_id, scene, sweep):
    """(key, description) of the run's scene, mesh and form factors, from its run.json (or
    sweep.json's problems when the run.json is missing or has no problem, e.g. a failed run)."""
    info = None
    path = os.path.join(out_dir, "runs", file_stem(run_id) + ".run.json")
    if os.path.exists(path):
        with open(path) as f:
            run = json.load(f)
        if "mesh" in run and "form_factors" in run:
            ff = run["form_factors"]
            info = {"scene": run["scene"]["spec"], "elements": run["mesh"]["elements"],
                    "subdivisions": run["mesh"]["subdivisions"],
                    "element_size": run["mesh"]["element_size"], "method": ff["method"],
                    "parameters": ff["parameters"], "precision": ff["precision"],
                    "rows": ff["rows"]}
    if info is None:
        for problem in sweep.get("problems", []):
            if f"/{problem.get('label')}" in run_id:
                ff = problem["form_factors"]
                info = {"scene": problem["scene"], "elements": problem.get("elements"),
                        "subdivisions": problem["subdivisions"],
                        "element_size": problem["element_size"], "method": ff["method"],
                        "parameters": ff["parameters"], "precision": ff["precision"],
                        "rows": ff["rows"]}
                break
    if info is None:
        return (scene,), scene
    mesh = (f"element size {info['element_size']:g}" if info["element_size"] else
            f"subdiv {info['subdivisions']}")
    elements = f"{info['elements']:,} elements, " if info.get("elements") else ""
    description = (f"{info['scene']}: {elements}{mesh}\n"
                   f"form factors {info['method']} ({info['parameters']}), {info['precision']}, "
                   f"{info['rows']}")
    key = (info["scene"], info["subdivisions"], info["element_size"], info["method"],
           info["parameters"], info["precision"], info["rows"])
    wrapped = "\n".join(textwrap.fill(line, 95, subsequent_indent="    ")
                         for line in description.split("\n"))
    return key, wrapped


def label_of(run_id, scene_label):
    """The run id without the scene part: solver and its parameters."""
    parts = [p for p in run_id.split("/") if not p.startswith("scene:")]
    return "/".join(parts) if parts else run_id


def positive(series):
    values = series.to_numpy(dtype=float)
    values[~(values > 0)] = np.nan  # log axes: hide zeros (exact) and missing values
    return values


def seed_configurations(out_dir, run_ids):
    """{run_id: (configuration, t90)} for the runs of configurations aggregate.csv lists with at
    least two seeds (empty without aggregate.csv)."""
    aggregate_path = os.path.join(out_dir, "aggregate.csv")
    if not os.path.exists(aggregate_path):
        return {}
    aggregate = pd.read_csv(aggregate_path, keep_default_na=False, dtype=str)
    t90 = {row["configuration"]: float(row["t90"]) for _, row in aggregate.iterrows()
           if row["t90"] != "" and int(row["seeds"]) >= 2}
    summary = pd.read_csv(os.path.join(out_dir, "summary.csv"), keep_default_na=False, dtype=str)
    summary = summary[summary["run_id"].isin(run_ids) & (summary["error"] == "")]
    return {row["run_id"]: (row["configuration"], t90[row["configuration"]])
            for _, row in summary.iterrows() if row["configuration"] in t90}


def with_seed_bands(runs, configurations, metrics, axes):
    """The runs as plotted: a run of a repeated configuration is replaced by one entry per
    configuration holding, per step, the mean over its seeds of each metric and x axis and the
    band columns METRIC_low / METRIC_high (mean -+ t90 sd / sqrt(K))."""
    plotted, grouped = [], {}
    for run_id, data in runs:
        if run_id in configurations:
            grouped.setdefault(configurations[run_id], []).append(data)
        else:
            plotted.append((run_id, data))
    for (configuration, t90), frames in grouped.items():
        rows = pd.concat(frames)
        steps = rows.groupby("step", sort=True)
        data = steps[axes + metrics].mean().reset_index()
        count = steps.size().to_numpy()
        for metric in metrics:
            half = t90 * steps[metric].std(ddof=1).to_numpy() / np.sqrt(count)
            data[f"{metric}_low"] = data[metric] - half
            data[f"{metric}_high"] = data[metric] + half
        k = len(frames)
        plotted.append((f"{label_of(configuration, '')} (mean of {k} seeds, 90% band)", data))
    return plotted


def plot_metric(runs, metric, x, title, path_stem, formats):
    fig, ax = plt.subplots(figsize=(7.5, 4.8))
    for i, (run_id, data) in enumerate(runs):
        colour = f"C{i % 10}"
        label = label_of(run_id, "")
        if f"{metric}_low" in data:
            ax.fill_between(data[x], positive(data[f"{metric}_low"]),
                            positive(data[f"{metric}_high"]), color=colour, alpha=0.25, lw=0)
        ax.plot(data[x], positive(data[metric]), color=colour, lw=1.4, label=label)
        display = f"{metric}_display"
        if display in data and not np.allclose(
            data[display].fillna(-1), data[metric].fillna(-1), rtol=1e-12, atol=0
        ):
            ax.plot(data[x], positive(data[display]), color=colour, lw=1.0, ls="--",
                    label=f"{label} (display)")
    ax.set_yscale("log")
    ax.set_xlabel({"ff_rows": "form-factor rows (hemicubes)", "seconds": "solver seconds",
                   "pair_evals": "element-pair form factors evaluated",
                   "seconds_with_setup": "seconds including set-up (matrix build)"}[x])
    ax.set_ylabel({"rms_rel": "relative RMS error (Cohen eq. 14)",
                   "rms_rel_reflected": "relative RMS error of B - E",
                   "p_mean": "mean |p-error| (Wu & Wang)"}[metric])
    ax.set_title(title, fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    for fmt in formats:
        fig.savefig(f"{path_stem}.{fmt}", dpi=130)
    plt.close(fig)


def plot_channels(runs, title, path_stem, formats):
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.2), sharey=True)
    for ax, channel, name in zip(axes, ["r", "g", "b"], ["red", "green", "blue"]):
        for i, (run_id, data) in enumerate(runs):
            ax.plot(data["ff_rows"], positive(data[channel]), color=f"C{i % 10}", lw=1.3,
                    label=label_of(run_id, ""))
        ax.set_yscale("log")
        ax.set_title(f"{name} channel", fontsize=10)
        ax.set_xlabel("form-factor rows")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("mean |p-error|")
    axes[0].legend(fontsize=7)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    for fmt in formats:
        fig.savefig(f"{path_stem}.{fmt}", dpi=130)
    plt.close(fig)


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out_dir")
    parser.add_argument("--formats", default="png,pdf")
    parser.add_argument("--out", help="folder for the figures (default OUT_DIR/plots)")
    args = parser.parse_args(argv)
    formats = [f for f in args.formats.split(",") if f]
    sweep, run_ids = listed_runs(args.out_dir, "plot_traces")
    trace_path = os.path.join(args.out_dir, "trace.csv")
    if not os.path.exists(trace_path):
        sys.exit(f"plot_traces: {trace_path}: no such file")
    trace = pd.read_csv(trace_path)
    trace = trace[trace["run_id"].isin(run_ids)]
    if trace.empty:
        sys.exit(f"plot_traces: {trace_path}: no rows of the runs sweep.json lists")
    name = sweep.get("name", os.path.basename(os.path.normpath(args.out_dir)))
    plots = args.out or os.path.join(args.out_dir, "plots")
    os.makedirs(plots, exist_ok=True)
    written = []
    configurations = seed_configurations(args.out_dir, run_ids)
    # Group the runs by scene, mesh and form factors (one set of figures each).
    problems = {}
    for run_id, scene in trace.groupby("run_id", sort=False)["scene"].first().items():
        key, description = problem_of(args.out_dir, run_id, scene, sweep)
        problems.setdefault(key, (description, []))[1].append(run_id)
    per_scene = {}
    for key in problems:
        per_scene.setdefault(key[0], []).append(key)
    for key, (description, run_ids) in problems.items():
        scene = key[0]
        short = (scene[len("builtin:"):] if scene.startswith("builtin:") else
                 os.path.splitext(os.path.basename(scene))[0])
        safe = re.sub(r"[^A-Za-z0-9._-]", "_", short)
        if len(per_scene[scene]) > 1:
            safe += "_" + str(per_scene[scene].index(key) + 1)
        scene_rows = trace[trace["run_id"].isin(run_ids)]
        mean = scene_rows[scene_rows["channel"] == "mean"]
        title = f"{name}: {description}"
        # Traces from before the pair_evals / rms_rel_reflected / seconds_with_setup columns still
        # plot.
        metrics = [m for m in ["rms_rel", "p_mean", "rms_rel_reflected"] if m in mean]
        axes = [x for x in ["ff_rows", "seconds", "pair_evals", "seconds_with_setup"] if x in mean]
        runs = with_seed_bands(list(mean.groupby("run_id", sort=False)), configurations,
                               metrics, axes)
        for metric in metrics:
            for x in axes:
                # A run that never moves along x (no form-factor rows: the matrix-free Monte
                # Carlo solvers and hierarchical) would sit at x = 0 as a vertical line: it is
                # left out of that plot, and a plot no run moves along is not written.
                moving = [(run_id, data) for run_id, data in runs if (data[x] > 0).any()]
                if not moving:
                    continue
                stem = os.path.join(plots, f"{safe}_{metric}_vs_{'rows' if x == 'ff_rows' else x}")
                plot_metric(moving, metric, x, title, stem, formats)
                written.append(stem)
        channels = scene_rows[scene_rows["channel"].isin(["r", "g", "b"])]
        if not channels.empty:
            wide = channels.pivot_table(index=["run_id", "step", "ff_rows"], columns="channel",
                                        values="p_mean", sort=False).reset_index()
            channel_runs = list(wide.groupby("run_id", sort=False))
            stem = os.path.join(plots, f"{safe}_p_channels")
            plot_channels(channel_runs, title + " (per channel, Wu & Wang Figs 1/3)", stem, formats)
            written.append(stem)
    for stem in written:
        print(f"wrote {stem}.{{{','.join(formats)}}}")


if __name__ == "__main__":
    main(sys.argv[1:])
