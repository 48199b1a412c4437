#!/usr/bin/env python3
"""Where a solution's error against a reference sits, element by element (docs/solvers.md,
"The classroom floor"): the overall rms_rel as radlab computes it (area-weighted, mean of the
channels), the signed area-weighted bias, and the share of the squared error by element area
(decades) and by the reference's brightness (quartiles), from two `--out` CSVs of the same mesh
(element,area,B_r,B_g,B_b; `radlab reference --out` and `radlab solve --out`).

    scripts/hierarchical_floor.py REFERENCE.csv ESTIMATE.csv
"""
import csv
import math
import sys


def load(path):
    rows = {}
    with open(path, newline="") as f:
        for r in csv.DictReader(f):
            rows[int(r["element"])] = (float(r["area"]),
                                       (float(r["B_r"]) + float(r["B_g"]) + float(r["B_b"])) / 3)
    return rows


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    ref, est = load(sys.argv[1]), load(sys.argv[2])
    if ref.keys() != est.keys():
        sys.exit("the two files do not have the same elements")
    elements = sorted(ref)
    sq = sum(ref[i][0] * (est[i][1] - ref[i][1]) ** 2 for i in elements)
    ref_sq = sum(ref[i][0] * ref[i][1] ** 2 for i in elements)
    area = sum(ref[i][0] for i in elements)
    bias = sum(ref[i][0] * (est[i][1] - ref[i][1]) for i in elements)
    mean_ref = sum(ref[i][0] * ref[i][1] for i in elements)
    print(f"elements {len(elements)}, area {area:.4g} m^2")
    print(f"rms_rel {math.sqrt(sq / ref_sq):.4g}; signed bias (area-weighted mean of B - B_ref "
          f"over that of B_ref) {bias / mean_ref:+.4g}")

    def table(title, key, labels):
        groups = {}
        for i in elements:
            groups.setdefault(key(i), []).append(i)
        print(f"\n{title:<24} {'elements':>9} {'area %':>8} {'sq.err %':>9} {'rms_rel':>9} "
              f"{'bias':>9}")
        for g in sorted(groups):
            ids = groups[g]
            a = sum(ref[i][0] for i in ids)
            s = sum(ref[i][0] * (est[i][1] - ref[i][1]) ** 2 for i in ids)
            r2 = sum(ref[i][0] * ref[i][1] ** 2 for i in ids)
            b = sum(ref[i][0] * (est[i][1] - ref[i][1]) for i in ids)
            m = sum(ref[i][0] * ref[i][1] for i in ids)
            print(f"{labels(g):<24} {len(ids):>9} {100 * a / area:>8.2f} {100 * s / sq:>9.2f} "
                  f"{math.sqrt(s / r2) if r2 else 0:>9.4f} {b / m if m else 0:>+9.4f}")

    table("element area (m^2)", lambda i: math.floor(math.log10(ref[i][0])),
          lambda g: f"[1e{g}, 1e{g + 1})")
    ranked = sorted(elements, key=lambda i: ref[i][1])
    quartile = {i: 4 * k // len(ranked) for k, i in enumerate(ranked)}
    table("B_ref quartile", lambda i: quartile[i], lambda g: f"Q{g + 1} (dark to bright)")


if __name__ == "__main__":
    main()
