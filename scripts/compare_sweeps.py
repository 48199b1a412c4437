#!/usr/bin/python3
"""Compares two sweep folders' trace.csv and summary.csv apart from the columns that measure time.

Usage: compare_sweeps.py BEFORE_DIR AFTER_DIR

For refactoring checks: run the same experiment file with two builds (`radlab run FILE --out
DIR`) and compare; prints the first differing cell of each table and exits 1 if any differs.
The time columns are those of docs/experiments.md: `seconds` and every `seconds_*` /
`fit_seconds_*` column, and `stop_reason` (a time budget makes it machine-dependent).
Columns are matched by name: a column only one build writes (one added since) is named and left
out, so a build that appends columns can still be checked against an older one.
"""
import csv
import os
import sys


def is_time(column):
    return column == "seconds" or column.startswith("seconds_") or \
        column.startswith("fit_seconds") or column == "stop_reason"


def table(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], rows[1:]


def compare(name, dir_a, dir_b):
    """Prints how the two folders' `name` tables differ; returns True when they do not."""
    ha, ra = table(os.path.join(dir_a, name))
    hb, rb = table(os.path.join(dir_b, name))
    only_a = [c for c in ha if c not in hb]
    only_b = [c for c in hb if c not in ha]
    if only_a or only_b:
        print(f"{name}: left out, only in {dir_a}: {only_a or 'none'}; only in {dir_b}: "
              f"{only_b or 'none'}")
    common = [c for c in ha if c in hb and not is_time(c)]
    if not common:
        print(f"{name}: no column in common")
        return False
    ka = [ha.index(c) for c in common]
    kb = [hb.index(c) for c in common]
    if len(ra) != len(rb):
        print(f"{name}: {len(ra)} rows against {len(rb)}")
        return False
    diff = [(i, n) for i, (a, b) in enumerate(zip(ra, rb)) for n in range(len(common))
            if a[ka[n]] != b[kb[n]]]
    if diff:
        i, n = diff[0]
        print(f"{name}: {len(diff)} cells differ; first: row {i + 1}, {common[n]}: "
              f"{ra[i][ka[n]]} against {rb[i][kb[n]]}")
        return False
    print(f"{name}: {len(ra)} rows x {len(common)} common columns identical (time columns left "
          f"out)")
    return True


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    same = [compare(name, sys.argv[1], sys.argv[2]) for name in ("trace.csv", "summary.csv")]
    sys.exit(0 if all(same) else 1)


if __name__ == "__main__":
    main()
