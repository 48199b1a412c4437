#!/usr/bin/env python3
"""The scaling family's experiment (issue 33, item 2): hierarchical radiosity on
builtin:floors:k=K with and without clustering, links, memory and time against polygons.

    scripts/floors_scaling.py run OUT [--ks 1,2,4,8,16,32,64,108] [--clusterings isotropic,none]
    scripts/floors_scaling.py plot OUT [--fit build/bench/fit_power_law]

`run` solves each (clustering, K) once, the whole solve (refinement, then gathers to the fixed
point), `--reference none`, under `/usr/bin/time -v`, one process per run so that peak RSS is the
run's own, and appends a row to OUT/floors_scaling.csv as soon as the run ends (a long ladder
keeps what it measured). It records the load average before and after each run: the machine may
be shared, and the user CPU time is then the steadier figure. Unclustered hierarchical tests
every pair of root polygons, so its time grows with the square of the count: a size whose time,
extrapolated quadratically from the last one measured, passes --max-seconds (300) is not run
(at the default patch 0.5, whose polygon count 1,856 K + 96 is known before the run; at another
patch every size is run).
Rows already in the CSV are kept and not run again (delete the file to start afresh).

`plot` fits y ~ C s^p to links, refinement tests, user CPU seconds and peak RSS against the
polygon count s, per clustering, with radlab's Ceres fit (metrics/power_law_fit.h, through
build/bench/fit_power_law; +- 1 sigma), writes OUT/floors_exponents.csv and OUT/floors_scaling.png
(log-log, both clusterings, the fitted lines) and prints a Markdown table for docs/solvers.md.
"""
import argparse
import csv
import os
import re
import subprocess
import sys
import time

FIELDS = ["clustering", "k", "patch", "polygons", "links", "links_with_a_cluster",
          "refinement_tests", "rays", "steps", "wall_s", "user_s", "system_s", "cpu_percent",
          "peak_rss_mb", "load_before", "load_after", "exit_code"]

STATISTICS = {"input_polygons": "polygons", "links": "links",
              "links_with_a_cluster": "links_with_a_cluster",
              "refinement_tests": "refinement_tests", "rays": "rays"}


def load_average():
    with open("/proc/loadavg") as f:
        return float(f.read().split()[0])


def parse_time_v(text):
    """Wall, user, system seconds, CPU percent and peak RSS (MB) from GNU time -v."""
    def field(label):
        m = re.search(r"^\s*" + re.escape(label) + r": (.*)$", text, re.M)
        if not m:
            raise ValueError(f"/usr/bin/time -v printed no '{label}'")
        return m.group(1).strip()

    wall = 0.0
    for part in field("Elapsed (wall clock) time (h:mm:ss or m:ss)").split(":"):
        wall = wall * 60 + float(part)
    return {"wall_s": wall, "user_s": float(field("User time (seconds)")),
            "system_s": float(field("System time (seconds)")),
            "cpu_percent": float(field("Percent of CPU this job got").rstrip("%")),
            "peak_rss_mb": float(field("Maximum resident set size (kbytes)")) / 1024.0}


def solve(radlab, clustering, k, patch, feps, workdir):
    spec = f"builtin:floors:k={k},patch={patch}"
    stderr_path = os.path.join(workdir, f"{clustering}_k{k}.time.txt")
    command = ["/usr/bin/time", "-v", "-o", stderr_path, radlab, "solve", spec,
               "--solver", "hierarchical", "--set", f"feps={feps}",
               "--set", f"clustering={clustering}", "--reference", "none", "--steps", "1000000"]
    row = {"clustering": clustering, "k": k, "patch": patch, "load_before": load_average()}
    print("running:", " ".join(command), flush=True)
    done = subprocess.run(command, capture_output=True, text=True)
    row["load_after"] = load_average()
    row["exit_code"] = done.returncode
    with open(os.path.join(workdir, f"{clustering}_k{k}.out.txt"), "w") as f:
        f.write(done.stdout + done.stderr)
    if done.returncode != 0:
        print(f"  exit {done.returncode}: {done.stderr.strip()[-500:]}", flush=True)
    stats = {}
    for line in done.stdout.splitlines():
        parts = line.split()
        if len(parts) == 3 and parts[0] == "statistic":
            stats[parts[1]] = parts[2]
        if parts[:1] == ["stopped"]:
            m = re.search(r"after (\d+) steps", line)
            row["steps"] = int(m.group(1)) if m else ""
    for key, column in STATISTICS.items():
        row[column] = float(stats[key]) if key in stats else ""
    with open(stderr_path) as f:
        row.update(parse_time_v(f.read()))
    return row


def read_rows(path):
    if not os.path.exists(path):
        return []
    with open(path) as f:
        return list(csv.DictReader(f))


def command_run(args):
    os.makedirs(args.out, exist_ok=True)
    workdir = os.path.join(args.out, "runs")
    os.makedirs(workdir, exist_ok=True)
    path = os.path.join(args.out, "floors_scaling.csv")
    done = {(r["clustering"], int(r["k"])) for r in read_rows(path)}
    if not os.path.exists(path):
        with open(path, "w", newline="") as f:
            csv.DictWriter(f, FIELDS).writeheader()
    ks = [int(k) for k in args.ks.split(",")]
    for clustering in args.clusterings.split(","):
        last = None  # (polygons, user seconds) of the last run of this clustering
        for r in read_rows(path):
            if r["clustering"] == clustering and r["exit_code"] == "0":
                last = (float(r["polygons"]), float(r["user_s"]))
        for k in ks:
            if (clustering, k) in done:
                continue
            # The polygon count without making the scene: docs/scenes.md's exact formula holds
            # at patch 0.5 only, so ask radlab for any other patch.
            polygons = 1856 * k + 96 if args.patch == 0.5 else None
            if clustering == "none" and last and polygons:
                predicted = last[1] * (polygons / last[0]) ** 2
                if predicted > args.max_seconds:
                    print(f"skipping clustering=none k={k} ({polygons} polygons): quadratic "
                          f"extrapolation {predicted:.0f} s > {args.max_seconds:.0f} s", flush=True)
                    break
            row = solve(args.radlab, clustering, k, args.patch, args.feps, workdir)
            with open(path, "a", newline="") as f:
                csv.DictWriter(f, FIELDS).writerow(row)
            print(f"  {clustering} k={k}: {row['polygons']:.0f} polygons, {row['links']:.0f} "
                  f"links, wall {row['wall_s']:.1f} s, user {row['user_s']:.1f} s, "
                  f"{row['peak_rss_mb']:.0f} MB, load {row['load_before']:.1f}/"
                  f"{row['load_after']:.1f}", flush=True)
            if row["exit_code"] != 0:
                break
            last = (float(row["polygons"]), row["user_s"])
            if args.pause:
                time.sleep(args.pause)


QUANTITIES = [("links", "links"), ("refinement_tests", "refinement tests"),
              ("user_s", "user CPU seconds"), ("wall_s", "wall seconds"),
              ("peak_rss_mb", "peak RSS (MB)")]


def fit(tool, polygons, values):
    """Exponent p and its 1-sigma of y ~ C s^p by radlab's Ceres fit (fit_power_law)."""
    text = "\n".join(f"{s!r},{y!r}" for s, y in zip(polygons, values)) + "\n"
    done = subprocess.run([tool], input=text, capture_output=True, text=True)
    if done.returncode != 0:
        return None
    exponent, sigma, constant = (float(v) for v in done.stdout.split())
    return exponent, sigma, constant


def command_plot(args):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [r for r in read_rows(os.path.join(args.out, "floors_scaling.csv"))
            if r["exit_code"] == "0"]
    if not rows:
        sys.exit(f"floors_scaling: {args.out}/floors_scaling.csv: no successful runs")
    by = {}
    for r in rows:
        by.setdefault(r["clustering"], []).append(r)
    fits = []
    figure, axes = plt.subplots(1, 3, figsize=(15, 4.6))
    panels = [("links", "links"), ("peak_rss_mb", "peak RSS (MB)"), ("user_s", "user CPU (s)")]
    styles = {"isotropic": ("tab:blue", "o"), "none": ("tab:red", "s")}
    for clustering, list_ in sorted(by.items()):
        list_.sort(key=lambda r: float(r["polygons"]))
        s = [float(r["polygons"]) for r in list_]
        for key, label in QUANTITIES:
            y = [float(r[key]) for r in list_]
            result = fit(args.fit, s, y) if len(s) >= 3 else None
            fits.append({"clustering": clustering, "quantity": key,
                         "exponent": result[0] if result else "",
                         "sigma": result[1] if result else "",
                         "constant": result[2] if result else "",
                         "points": len(s), "polygons_min": min(s), "polygons_max": max(s)})
        color, marker = styles.get(clustering, ("black", "x"))
        for axis, (key, label) in zip(axes, panels):
            y = [float(r[key]) for r in list_]
            f = next(x for x in fits if x["clustering"] == clustering and x["quantity"] == key)
            name = f"clustering={clustering}"
            if f["exponent"] != "":
                name += f": s^{f['exponent']:.2f} ± {f['sigma']:.2f}"
                axis.plot(s, [f["constant"] * v ** f["exponent"] for v in s], "--", color=color,
                          linewidth=1)
            axis.plot(s, y, marker=marker, linestyle="", color=color, label=name)
            axis.set_xscale("log")
            axis.set_yscale("log")
            axis.set_xlabel("polygons s")
            axis.set_ylabel(label)
            axis.grid(True, which="both", alpha=0.3)
            axis.legend(fontsize=8)
    figure.suptitle("hierarchical radiosity on builtin:floors:k=K (feps 0.04, whole solve)")
    figure.tight_layout()
    png = os.path.join(args.out, "floors_scaling.png")
    figure.savefig(png, dpi=110)
    with open(os.path.join(args.out, "floors_exponents.csv"), "w", newline="") as f:
        writer = csv.DictWriter(f, list(fits[0].keys()))
        writer.writeheader()
        writer.writerows(fits)
    print(f"wrote {png}")
    print("| clustering | K | polygons | links (with a cluster end) | refinement tests | wall s "
          "(user CPU s) | peak RSS MB | load before/after |")
    print("|---|---|---|---|---|---|---|---|")
    for clustering, list_ in sorted(by.items()):
        for r in list_:
            cluster = (f" ({float(r['links_with_a_cluster']):,.0f})"
                       if r["links_with_a_cluster"] else "")
            print(f"| {clustering} | {r['k']} | {float(r['polygons']):,.0f} | "
                  f"{float(r['links']):,.0f}{cluster} | "
                  f"{float(r['refinement_tests']):,.0f} | {float(r['wall_s']):.1f} "
                  f"({float(r['user_s']):.1f}) | {float(r['peak_rss_mb']):,.0f} | "
                  f"{float(r['load_before']):.1f}/{float(r['load_after']):.1f} |")
    for f in fits:
        if f["exponent"] != "":
            print(f"clustering={f['clustering']}: {f['quantity']} ~ s^{f['exponent']:.3f} ± "
                  f"{f['sigma']:.3f} ({f['points']} points, s = {f['polygons_min']:.0f} … "
                  f"{f['polygons_max']:.0f})")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="run the ladder, appending to OUT/floors_scaling.csv")
    run.add_argument("out")
    run.add_argument("--radlab", default="build/cli/radlab")
    run.add_argument("--ks", default="1,2,4,8,16,32,64,108")
    run.add_argument("--clusterings", default="isotropic,none")
    run.add_argument("--patch", type=float, default=0.5)
    run.add_argument("--feps", type=float, default=0.04)
    run.add_argument("--max-seconds", type=float, default=300.0,
                     help="skip unclustered sizes predicted (quadratically) to take longer")
    run.add_argument("--pause", type=float, default=0.0, help="seconds to wait between runs")
    plot = sub.add_parser("plot", help="fit the exponents, plot, print the table")
    plot.add_argument("out")
    plot.add_argument("--fit", default="build/bench/fit_power_law")
    args = parser.parse_args()
    if args.command == "run":
        command_run(args)
    else:
        command_plot(args)


if __name__ == "__main__":
    main()
