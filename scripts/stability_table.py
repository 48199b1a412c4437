#!/usr/bin/python3
"""The stability table: runs experiments/stability.toml and writes docs/stability.md.

Usage: stability_table.py [--radlab build/cli/radlab] [--work build/stability]
                          [--out docs/stability.md]

One command makes the whole table (about a minute here). For every solver x case it records the
final error, rows, stop reason, certified bound and seconds that `radlab run` wrote to
summary.csv, and then checks each verdict independently, so that a false one is named in the
table rather than passed on:

- converged ("tolerance reached"): the final radiosities (runs/*.radiosity.csv) against the float
  system's certified reference (`radlab reference --out`): the measured
  ||B - B*||_inf / max B* must not exceed the printed bound plus the reference's own bound;
- a stop for stagnation or divergence: the same solver is run again without a tolerance, for the
  experiment's whole row budget (`radlab solve --rows`); if its error (rms_rel) then falls below
  a tenth of what it was at the stop, the solver was still converging and the verdict was false;
- a stop on the row budget while a tolerance was asked for must say that the tolerance was not
  reached (a hidden cap reported as success is flagged);
- no non-finite value may appear in the final radiosities or the error columns (silent NaN);
- a tolerance reached while the reflected part B - E is still far from converged (rms_rel of
  B - E above 1000 x the tolerance: the bound is relative to max B*, i.e. to the emitter) is
  marked with a caveat;
- a run that succeeds on a matrix whose rows sum above 1 + 1e-3 (light created: overlapping or
  near-touching input) is marked with a caveat: its certificate is true of an unphysical system;
- with a form-factor method other than raycast, each answer's mean |p| against the raycast
  solution of the same mesh (an independent method) must stay below 0.5: a room left black by
  form factors that miss a small lamp is a false "converged";
- positivity: min B >= 0 is required of the methods that add only non-negative amounts (Jacobi,
  Gauss-Seidel, shooting, sorted shooting, interleaving); the others' min B is shown.

It also solves each case's reference on the double-precision matrix (`--precision double`) and
shows the distance of each final answer to it: the effect of storing F in float.

The table is written to a temporary name and renamed when complete.
"""
import argparse
import csv
import json
import math
import os
import subprocess
import sys
import tomllib

MONOTONE = {"jacobi", "gauss-seidel", "shooting", "sorted-shooting", "interleaved"}
EXPERIMENTS = ["experiments/stability.toml", "experiments/stability_float.toml",
               "experiments/stability_hemicube.toml"]


def run(cmd, timeout):
    """Runs cmd; returns (exit code, combined output). A timeout is reported as exit code None."""
    try:
        p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                           timeout=timeout)
        return p.returncode, p.stdout
    except subprocess.TimeoutExpired as e:
        return None, (e.stdout or b"").decode() if isinstance(e.stdout, bytes) else (e.stdout or "")


def read_b(path):
    """Final radiosities: list of (area, [channels])."""
    rows = []
    with open(path) as f:
        for r in csv.DictReader(f):
            rows.append((float(r["area"]), [float(r["B_r"]), float(r["B_g"]), float(r["B_b"])]))
    return rows


def rel_inf(b, ref):
    """||B - B*||_inf / max B*, over elements and channels."""
    worst = 0.0
    top = max(max(abs(x) for x in c) for _, c in ref)
    for (_, x), (_, y) in zip(b, ref):
        for u, v in zip(x, y):
            worst = max(worst, abs(u - v))
    return worst / top if top > 0 else (0.0 if worst == 0 else math.inf)


def mean_p(b, ref):
    """Area-weighted mean |B - B*| / B* over elements and channels (B* > 0 only)."""
    total, weight = 0.0, 0.0
    for (area, x), (_, y) in zip(b, ref):
        for u, v in zip(x, y):
            if v > 0:
                total += area * abs(u - v) / v
                weight += area
    return total / weight if weight > 0 else 0.0


def num(s):
    try:
        return float(s)
    except (TypeError, ValueError):
        return None


def fmt(x, digits=2):
    if x is None:
        return "—"
    if x != x or x in (math.inf, -math.inf):
        return str(x)
    if x == 0:
        return "0"
    return f"{x:.{digits}e}"


def scene_arg(spec):
    return spec if spec.startswith("builtin:") else spec


def evaluate(args, path):
    """Runs one experiment file and checks its cells; returns (experiment, cells, references)."""
    with open(path, "rb") as f:
        exp = tomllib.load(f)
    exp["path"] = path
    subdiv = exp["subdiv"]
    budget_rows = int(exp["budget"]["rows"])
    tol = exp["budget"].get("tol")
    ff = exp["form_factors"]
    common = ["--subdiv", str(subdiv), "--ff", ff["method"]]
    work = os.path.join(args.work, exp["name"])
    os.makedirs(work, exist_ok=True)
    sweep_dir = os.path.join(work, "sweep")
    cmd = [args.radlab, "run", path, "--out", sweep_dir, "--overwrite"]
    code, output = run(cmd, args.timeout)
    if code is None:
        sys.exit(f"radlab run did not finish in {args.timeout} s: a hang")
    if code < 0 or code > 5:  # 0 ok, 2-5 documented failures (DESIGN §7); else a crash
        sys.exit(f"radlab run exited {code}:\n{output}")

    with open(os.path.join(sweep_dir, "summary.csv")) as f:
        summary = list(csv.DictReader(f))
    run_files = {}
    for name in os.listdir(os.path.join(sweep_dir, "runs")):
        if name.endswith(".run.json"):
            with open(os.path.join(sweep_dir, "runs", name)) as f:
                d = json.load(f)
            run_files[d["run_id"]] = os.path.join(sweep_dir, "runs", name[: -len(".run.json")])

    # References of every case, float (the system the runs solve) and double storage of F.
    refs = {}
    for spec in exp["scenes"]:
        for precision in ("float", "double"):
            ref_path = os.path.join(work, f"ref_{precision}_{len(refs)}.csv")
            c, out = run([args.radlab, "reference", spec, *common, "--precision", precision,
                          "--out", ref_path], args.timeout)
            refs[(spec, precision)] = read_b(ref_path) if c == 0 else None
            if c != 0:
                refs[(spec, precision, "error")] = out.strip().splitlines()[-1] if out else ""
        if ff["method"] != "raycast":
            # An independent method on the same mesh: the raycast solution.
            ref_path = os.path.join(work, f"ref_raycast_{len(refs)}.csv")
            c, out = run([args.radlab, "reference", spec, "--subdiv", str(subdiv), "--ff",
                          "raycast", "--precision", "double", "--out", ref_path], args.timeout)
            refs[(spec, "raycast")] = read_b(ref_path) if c == 0 else None

    cells = []
    for row in summary:
        spec, solver = row["scene"], row["solver"]
        cell = {"row": row, "spec": spec, "solver": solver, "checks": [], "false": [], "caveats": []}
        stop = row["stop_reason"]
        error = row["error"]
        base = run_files.get(row["run_id"])
        b = None
        if base and os.path.exists(base + ".run.json"):
            with open(base + ".run.json") as f:
                d = json.load(f)
            if "form_factors" in d and "reference" in d:
                cell["info"] = (d["form_factors"], d.get("mesh", {}), d["reference"])
                top = d["form_factors"].get("row_sum_max", 0.0)
                if top > 1.001 and not error:
                    cell["caveats"].append(
                        f"rows of F sum to {top:.4g} > 1 (light created: unphysical input, e.g. "
                        "overlapping polygons), and nothing refused or warned")
        if base and os.path.exists(base + ".radiosity.csv"):
            b = read_b(base + ".radiosity.csv")
        # Silent NaN: non-finite numbers anywhere a result is reported.
        for key in ("rms_rel", "bound_relative", "p_mean"):
            v = num(row[key])
            if v is not None and not math.isfinite(v) and not error:
                cell["false"].append(f"non-finite {key} reported without an error")
        if b is not None:
            cell["min_b"] = min(min(c) for _, c in b)
            if any(not math.isfinite(x) for _, c in b for x in c):
                cell["false"].append("non-finite radiosities written")
            elif solver in MONOTONE and cell["min_b"] < 0:
                cell["false"].append(f"negative radiosity {cell['min_b']:.3g} from a monotone method")
            ref_f = refs.get((spec, "float"))
            ref_d = refs.get((spec, "double"))
            if ref_f:
                cell["err_float"] = rel_inf(b, ref_f)
            if ref_d:
                cell["err_double"] = rel_inf(b, ref_d)
            ref_r = refs.get((spec, "raycast"))
            if ref_r and not error:
                # Wu & Wang's mean |p| against the raycast solution of the same mesh, an
                # independent form-factor method: two methods agree to a few per cent; an answer
                # off by half or more missed the light, whatever its certificate says. (p is
                # relative per element, so the bright emitters, right from step 0, weigh little.)
                cell["cross"] = mean_p(b, ref_r)
                if cell["cross"] > 0.5:
                    cell["false"].append(
                        f"mean |p| {cell['cross']:.2f} against the raycast solution: the form "
                        "factors missed the light, yet the run was certified")
                else:
                    cell["checks"].append(f"mean |p| {cell['cross']:.3f} against raycast")
        bound = num(row["bound_relative"])
        reached = stop == "tolerance reached" or row.get("tolerance_reached") == "true"
        cell["reached"] = reached
        if reached and tol and bound is not None and bound > tol:
            cell["false"].append(f"reported the tolerance reached with a bound of {bound:.2e}")
        if reached and "err_float" in cell and bound is not None:
            ref_bound = 1e-12  # the references here certify below 1e-12 relative (run.json)
            if cell["err_float"] > bound + ref_bound + 1e-15:
                cell["false"].append(
                    f"certified {bound:.2e} but measured {cell['err_float']:.2e} against the "
                    "reference")
            else:
                cell["checks"].append("bound holds")
            reflected = num(row.get("rms_rel_reflected"))
            if reflected is not None and tol and reflected > 1e3 * tol:
                cell["caveats"].append(
                    f"the tolerance is relative to max B* (the emitter): the reflected light "
                    f"(B − E) still has rms_rel {reflected:.2e}")
        said = "not reached" in stop or row.get("tolerance_reached", "") in ("false", "0", "no")
        if tol and not error and not reached and not said:
            cell["false"].append(f"tolerance {tol:g} not reached but the run reported '{stop}' "
                                 "and succeeded")
        low = error.lower()
        if ("stagnat" in low or "diverg" in low) and spec in [s for s in exp["scenes"]]:
            # Rerun without a tolerance for the experiment's row budget.
            with open(base + ".run.json") as f:
                d = json.load(f)
            trace = [t for t in csv.DictReader(open(os.path.join(sweep_dir, "trace.csv")))
                     if t["run_id"] == row["run_id"] and t["channel"] == "mean"]
            if trace:
                rows_at_stop = max(int(t["ff_rows"]) for t in trace)
                err_at_stop = num(trace[-1]["rms_rel"])
                opts = []
                for k, v in d["solver"]["options"].items():
                    opts += ["--set", f"{k}={v}"]
                tpath = os.path.join(work, "rerun_trace.csv")
                if os.path.exists(tpath):
                    os.remove(tpath)
                c, out = run([args.radlab, "solve", spec, *common, "--precision",
                              ff.get("precision", "float"), "--solver", solver, *opts,
                              "--rows", str(budget_rows), "--trace", tpath],
                             args.timeout)
                if c is None:
                    cell["false"].append("rerun without tolerance hung")
                elif os.path.exists(tpath):
                    tr = [t for t in csv.DictReader(open(tpath)) if t["channel"] == "mean"]
                    after = num(tr[-1]["rms_rel"]) if tr else None
                    rows_after = int(tr[-1]["ff_rows"]) if tr else 0
                    if after is not None and err_at_stop and after < 0.1 * err_at_stop:
                        cell["false"].append(
                            f"stopped at {rows_at_stop} rows, rms_rel {err_at_stop:.2e}; run on "
                            f"without a tolerance it reached {after:.2e} after {rows_after} rows")
                    else:
                        cell["checks"].append(
                            f"run on to {rows_after} rows without a tolerance: rms_rel "
                            f"{fmt(err_at_stop)} → {fmt(after)}")
        cells.append(cell)

    return exp, cells, refs


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--radlab", default="build/cli/radlab")
    ap.add_argument("--work", default="build/stability")
    ap.add_argument("--out", default="docs/stability.md")
    ap.add_argument("--timeout", type=float, default=1800.0,
                    help="seconds before a sweep counts as hung")
    args = ap.parse_args()
    write(args, [evaluate(args, path) for path in EXPERIMENTS])


def verdict(cell):
    row = cell["row"]
    if row["error"]:
        return row["stop_reason"].replace("failed: ", "") + ": " + row["error"].split(": ", 1)[-1]
    if row.get("tolerance_reached") == "true" and row["stop_reason"] != "tolerance reached":
        return row["stop_reason"] + " (tolerance reached)"
    if row.get("tolerance_reached") == "false":
        return row["stop_reason"] + " (tolerance not reached)"
    return row["stop_reason"]


def short(cell):
    if cell["false"]:
        return "**FALSE**"
    row = cell["row"]
    stop = row["stop_reason"]
    if cell.get("reached"):
        return "converged ⚠" if cell["caveats"] else "converged"
    if row.get("tolerance_reached") == "false" and not row["error"]:
        return f"not reached ({stop})"
    low = (stop + " " + row["error"]).lower()
    for word in ("stagnat", "diverg", "not reached", "invalid input", "usage", "positiv", "budget"):
        if word in low:
            return {"stagnat": "stagnated", "diverg": "diverging", "not reached": "not reached",
                    "invalid input": "refused", "usage": "refused", "positiv": "positivity",
                    "budget": "budget"}[word]
    return stop


def write(args, results):
    lines = []
    w = lines.append
    w("# Stability on stiff and extreme cases")
    w("")
    w("Generated by `scripts/stability_table.py` (do not edit by hand), which runs the experiment "
      "files below and checks every verdict independently (the script's doc block says how). "
      "The cases are described in [scenes.md](scenes.md#stability-scenes). The first table "
      "stores F in double, so every solver can reach the tolerance; the second stores it in "
      "float, as radlab's default does, and the certified reference is of the double-precision "
      "F: the float rounding is a floor the solvers must stop at and say so; the third computes "
      "hemicube form factors on the fly for the tiny light, and checks each answer against the "
      "raycast solution of the same mesh. Each case also "
      "shows the distance of each final answer from the reference solved on the "
      "double-precision matrix (`radlab reference --precision double`).")
    w("")
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], stdout=subprocess.PIPE,
                                stderr=subprocess.DEVNULL, text=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"],
                               stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                               text=True).stdout.strip()
        # The table itself may be the one changed file: that is not a change to what made it.
        dirty = "\n".join(x for x in dirty.splitlines() if not x.endswith(args.out))
    except OSError:
        commit, dirty = "", ""
    if commit:
        w(f"Made at commit `{commit}`{' (with local changes)' if dirty else ''}.")
        w("")
    total = sum(len(cells) for _, cells, _ in results)
    nfalse = sum(1 for _, cells, _ in results for c in cells if c["false"])
    w(f"**{total} cells; {nfalse} with a false verdict** (marked **FALSE**).")
    w("")
    for exp, cells, refs in results:
        section(w, exp, cells, refs)
    tmp = args.out + ".tmp"
    with open(tmp, "w") as f:
        f.write("\n".join(lines) + "\n")
    os.replace(tmp, args.out)
    print(f"wrote {args.out}: {total} cells, {nfalse} false verdicts")


def section(w, exp, cells, refs):
    path = exp["path"]
    scenes = exp["scenes"]
    solvers = []
    for c in cells:
        if c["solver"] not in solvers:
            solvers.append(c["solver"])
    by = {(c["spec"], c["solver"]): c for c in cells}
    w(f"## {exp['description']}")
    w("")
    w(f"[`{path}`](../{path}): every solver on every case, `--subdiv {exp['subdiv']}`, "
      f"{exp['form_factors']['method']} form factors stored in "
      f"{exp['form_factors'].get('precision', 'float')}, budget "
      + ", ".join(f"{k} {v:g}" if isinstance(v, float) else f"{k} {v}"
                  for k, v in exp["budget"].items()) + ".")
    w("")
    nfalse = sum(1 for c in cells if c["false"])
    w(f"{len(cells)} cells; {nfalse} with a false verdict.")
    w("")
    for c in cells:
        if c["false"]:
            w(f"- **FALSE** `{c['spec'].replace('builtin:', '')}` × {c['solver']}: "
              + "; ".join(c["false"]).replace("|", "/"))
    if nfalse:
        w("")
    w("### Overview")
    w("")
    w("| solver | " + " | ".join(f"`{s.replace('builtin:', '')}`" for s in scenes) + " |")
    w("|---|" + "---|" * len(scenes))
    for solver in solvers:
        w(f"| {solver} | " + " | ".join(short(by[(s, solver)]) if (s, solver) in by else "—"
                                         for s in scenes) + " |")
    w("")
    w("converged: the certified bound reached the tolerance, and the measured error against the "
      "reference is within it; not reached / budget: the row or time budget ran out first and "
      "the run says so; stagnated / diverging / refused: the run failed with that message "
      "(exit 4 or 3); **FALSE**: the independent check contradicts the verdict; ⚠: true, but "
      "misleading (see the check column).")
    w("")
    w("### Per case")
    for s in scenes:
        w("")
        w(f"#### `{s}`")
        w("")
        err = refs.get((s, "float", "error"))
        if err:
            w(f"Reference: {err}")
            w("")
        info = next((c.get("info") for c in cells if c["spec"] == s and c.get("info")), None)
        if info:
            ffd, mesh, ref = info
            w(f"{mesh['elements']} elements; F: rows sum to [{ffd.get('row_sum_min', 0):.6g}, "
              f"{ffd.get('row_sum_max', 0):.6g}], relative reciprocity defect of the computed "
              f"rows {fmt(ffd.get('computed_reciprocity_defect_relative'))}; reference: "
              f"{ref.get('method')}, certified {fmt(ref.get('bound_relative'))} of max B*, "
              f"q = {ref.get('q', 0):.6g}.")
            w("")
        w("| solver | rms_rel | rms_rel of B−E | ‖B−B*‖∞/max B* measured against `radlab reference` "
          "| the same against the reference of double-precision F "
          "| rows | seconds | certified bound | min B | verdict | check |")
        w("|---|---|---|---|---|---|---|---|---|---|---|")
        for solver in solvers:
            c = by.get((s, solver))
            if not c:
                continue
            row = c["row"]
            check = "; ".join(c["false"] + ["⚠ " + x for x in c["caveats"]] + c["checks"]) or "—"
            if c["false"]:
                check = "**FALSE**: " + check
            secs = num(row["seconds"])
            w(f"| {solver} | {fmt(num(row['rms_rel']))} | {fmt(num(row.get('rms_rel_reflected')))} | "
              f"{fmt(c.get('err_float'))} | "
              f"{fmt(c.get('err_double'))} | {row['ff_rows'] or '—'} | "
              f"{'—' if secs is None else f'{secs:.3f}'} | {fmt(num(row['bound_relative']))} | "
              f"{fmt(c.get('min_b'), 3)} | {verdict(c).replace('|', '/')} | "
              f"{check.replace('|', '/')} |")
    w("")


if __name__ == "__main__":
    main()
