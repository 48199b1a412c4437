#!/usr/bin/env python3
"""Row sums of the default form factors on every RenderPark scene: one table for docs/scenes.md.

Runs `radlab formfactors SCENE` (default raycast, sparse, symmetrised) on each scene, reads what it
prints (elements, repairs on loading, row sums of the computed matrix, build time) and writes the
markdown table between the markers `<!-- renderpark-rowsums begin -->` and `... end -->` in
docs/scenes.md (or prints it with --print). Usage, from the repository root:

    nice scripts/renderpark_table.py [--radlab build/cli/radlab] [--scenes DIR] [--print]

The scenes but soda.mgf take ~35 minutes on 2 cores (office1/graz.mgf and hospital/hosp.mgf 8-15
minutes each); soda.mgf (53,207 elements) needs `--limits memory_gb=16,pairs=3e9` and hours (its
whole build has not been run: docs/scenes.md). Each row is printed to stderr as it is done. The matrix
cache (RADLAB_CACHE_DIR) makes a second run fast, and the table then reports the time of the
original build.
"""
import argparse
import os
import re
import subprocess
import sys

SCENES = ["cube.mgf", "office2/office2.mgf", "corridor.mgf", "salon/classroom.mgf",
          "office3/office.mgf", "hospital/hosp.mgf", "examp1.mgf", "floor_gloss.mgf",
          "office1/graz.mgf", "soda.mgf"]


def run(radlab, path, root, limits):
    # hospital includes ../Materials: the scenes' folder is the include root
    command = [radlab, "--mgf-include-root", root]
    if limits:
        command += ["--limits", limits]
    result = subprocess.run(command + ["formfactors", path], capture_output=True, text=True)
    if result.returncode != 0:
        return {"error": f"exit {result.returncode}: {result.stderr.strip().splitlines()[-1]}"}
    out = result.stdout
    row = {}
    row["elements"] = int(re.search(r"^elements\s+(\d+)", out, re.M).group(1))
    row["seconds"] = float(re.search(r"^time\s+([\d.]+) s", out, re.M).group(1))
    m = re.search(r"^row sums\s+row sums of F \[([^,]+), ([^\]]+)\]; (\d+) rows? above 1 \+ (\S+)",
                  out, re.M)
    row["min"], row["max"], row["above"], row["stated"] = m.group(1), m.group(2), int(m.group(3)), m.group(4)
    # raycast checks each row against tolerance + storage + 5 sigma of its own visibility sampling
    sigma = re.search(r"largest so far (\S+);", out)
    if sigma:
        row["stated"] += f" + 5 σ_i, σ_i ≤ {sigma.group(1)}"
    # and what integrals stopped by a depth limit or work cap left beyond the tolerance, per row
    short = re.search(r"work cap \(largest (\S+), (\d+) pairs\)", out)
    if short:
        row["stated"] += f" + q_i ≤ {short.group(1)} ({short.group(2)} pairs stopped short)"
    r = re.search(r"^repairs\s+(.*)$", out, re.M).group(1)
    n = [int(x) for x in re.findall(r"(\d+)", r)]
    parts = []
    if n[1]: parts.append(f"{n[1]} split")
    if n[2]: parts.append(f"{n[2]} coincident overlaps removed ({n[3]} dropped, {n[4]} cut)")
    if n[5]: parts.append(f"{n[5]} back-to-back kept")
    if n[6]: parts.append(f"{n[6]} face-to-face contacts removed from both")
    if n[0]: parts.append(f"{n[0]} degenerate dropped")
    row["repairs"] = "; ".join(parts) or "none"
    return row


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--radlab", default="build/cli/radlab")
    parser.add_argument("--scenes", default="../shared/scenes/renderpark")
    parser.add_argument("--doc", default="docs/scenes.md")
    parser.add_argument("--print", action="store_true", help="print the table, do not edit the doc")
    parser.add_argument("--only", nargs="*", help="a subset of the scenes (for a quick look)")
    # soda.mgf's build is refused under the default limits (radlab --help, --limits): it needs
    # e.g. memory_gb=16,pairs=3e9 and ~6 GB for its pair memo
    parser.add_argument("--limits", help="passed to radlab --limits (soda.mgf needs it raised)")
    args = parser.parse_args()
    lines = ["| scene | elements | min row sum | max row sum | rows above 1 + stated error | "
             "repairs on loading | build (s) |", "|---|---|---|---|---|---|---|"]
    for scene in args.only or SCENES:
        print(f"{scene} ...", file=sys.stderr, flush=True)
        row = run(args.radlab, os.path.join(args.scenes, scene), args.scenes, args.limits)
        if "error" in row:
            lines.append(f"| {scene} | — | — | — | — | {row['error']} | — |")
            continue
        lines.append(f"| {scene} | {row['elements']:,} | {row['min']} | {row['max']} | "
                     f"{row['above']} (stated error {row['stated']}) | {row['repairs']} | "
                     f"{row['seconds']:.1f} |")
        print(lines[-1], file=sys.stderr, flush=True)
    table = "\n".join(lines) + "\n"
    if args.print:
        sys.stdout.write(table)
        return
    text = open(args.doc).read()
    begin, end = "<!-- renderpark-rowsums begin -->\n", "<!-- renderpark-rowsums end -->"
    if begin not in text or end not in text:
        sys.exit(f"{args.doc}: markers {begin.strip()} / {end} not found")
    head, rest = text.split(begin, 1)
    tail = rest.split(end, 1)[1]
    tmp = args.doc + ".tmp"
    with open(tmp, "w") as f:
        f.write(head + begin + table + end + tail)
    os.replace(tmp, args.doc)
    print(f"wrote the table into {args.doc}", file=sys.stderr)


if __name__ == "__main__":
    main()
