#!/usr/bin/python3
"""Variance over solver seeds, per ray, and its ratios between configurations (numpy only).

Usage: seed_variance.py OUT_DIR [--baseline SOLVER] [--resamples N]

Reads a sweep run with solver seeds (`repeats` or `solver_seeds`: docs/experiments.md):
summary.csv (each run's configuration, seed and rays) and runs/*.radiosity.csv (each run's
solution). For every configuration with at least two seeds it prints

  V = sum_i A_i sum_c s2_ic / sum_i A_i sum_c mean_ic^2

the area-weighted sample variance over seeds s2 of every element's radiosity (all channels),
relative to the mean solution's squared norm; V x rays, the variance per ray (the rays a run cast,
averaged over its seeds: with independent rays the variance falls as 1/rays, so V x rays compares
configurations at equal rays); and, per scene, the ratio of V x rays to the baseline solver's
configuration (default stochastic-jacobi) with a 90% interval: the 5% and 95% quantiles of the
ratio over bootstrap resamples of the seeds (each configuration's seeds resampled with
replacement, independently: the runs of different configurations are independent), from a fixed
generator seed, so the output is deterministic.
"""
import argparse
import csv
import os
import re
import sys

import numpy as np


def file_stem(run_id):
    """The file name radlab gives a run's files (experiments/sweep/sweep.cpp: file_stem)."""
    return re.sub(r"[/: ,=]", "_", run_id)


def rays_of(statistics):
    for item in statistics.split(";"):
        key, _, value = item.partition("=")
        if key == "rays":
            return float(value)
    return float("nan")


def read_runs(out_dir):
    """{configuration: {"scene", "solver", "params", "areas", "values": [K x m], "rays": [K]}}."""
    path = os.path.join(out_dir, "summary.csv")
    if not os.path.exists(path):
        sys.exit(f"seed_variance: {path}: no such file")
    groups = {}
    with open(path, newline="") as f:
        for row in csv.DictReader(f):
            if not row.get("solver_seed") or row.get("error"):
                continue
            radiosity = os.path.join(out_dir, "runs", file_stem(row["run_id"]) + ".radiosity.csv")
            data = np.loadtxt(radiosity, delimiter=",", skiprows=1, ndmin=2)
            group = groups.setdefault(row["configuration"], {
                "scene": row["scene"], "solver": row["solver"],
                "params": ",".join(p for p in row["params"].split(",")
                                   if not p.startswith("seed=")),
                "areas": data[:, 1], "values": [], "rays": []})
            group["values"].append(data[:, 2:].ravel())
            group["rays"].append(rays_of(row["solver_statistics"]))
    return {c: g for c, g in groups.items() if len(g["values"]) >= 2}


def relative_variance(values, weights):
    """V of the seeds' solutions (rows of `values`), elements weighted by area."""
    mean = values.mean(axis=0)
    variance = values.var(axis=0, ddof=1)
    return float((weights * variance).sum() / (weights * mean * mean).sum())


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out_dir")
    parser.add_argument("--baseline", default="stochastic-jacobi")
    parser.add_argument("--resamples", type=int, default=2000)
    args = parser.parse_args(argv)
    groups = read_runs(args.out_dir)
    if not groups:
        sys.exit(f"seed_variance: {args.out_dir}: no configuration with two or more solver seeds")
    rng = np.random.default_rng(20011121)  # fixed: the intervals are reproducible
    per_scene = {}
    for configuration, g in groups.items():
        values = np.array(g["values"])
        channels = values.shape[1] // len(g["areas"])
        g["weights"] = np.repeat(g["areas"], channels)
        g["array"] = values
        g["v"] = relative_variance(values, g["weights"])
        g["mean_rays"] = float(np.mean(g["rays"]))
        k = len(values)
        boot = np.empty(args.resamples)
        for b in range(args.resamples):
            boot[b] = relative_variance(values[rng.integers(0, k, k)], g["weights"])
        g["boot"] = boot * g["mean_rays"]
        per_scene.setdefault(g["scene"], []).append(configuration)
    print("| scene | configuration | seeds | rays (mean) | V | V x rays | ratio to baseline "
          "[90% bootstrap interval] |")
    print("|---|---|---|---|---|---|---|")
    for scene, configurations in per_scene.items():
        baseline = next((c for c in configurations if groups[c]["solver"] == args.baseline),
                        None)
        for c in configurations:
            g = groups[c]
            per_ray = g["v"] * g["mean_rays"]
            ratio = "—"
            if baseline is not None:
                b = groups[baseline]
                value = per_ray / (b["v"] * b["mean_rays"])
                low, high = np.quantile(g["boot"] / b["boot"], [0.05, 0.95])
                ratio = f"{value:.3g} [{low:.3g}, {high:.3g}]"
            name = g["solver"] + (f" {g['params']}" if g["params"] else "")
            print(f"| {os.path.basename(scene)} | {name} | {len(g['values'])} | "
                  f"{g['mean_rays']:.4g} | {g['v']:.3g} | {per_ray:.3g} | {ratio} |")


if __name__ == "__main__":
    main(sys.argv[1:])
