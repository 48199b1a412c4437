#!/usr/bin/python3
"""Compares two sweep folders' trace.csv and summary.csv apart from the columns that measure time.

Usage: compare_sweeps.py BEFORE_DIR AFTER_DIR

For refactoring checks: run the same experiment file with two builds (`radlab run FILE --out
DIR`) and compare; prints the first differing cell of each table and exits 1 if any differs.
The time columns are those of docs/experiments.md: `seconds` and every `seconds_*` /
`fit_seconds_*` column, and `stop_reason` (a time budget makes it machine-dependent).
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
    header, body = rows[0], rows[1:]
    keep = [k for k, c in enumerate(header) if not is_time(c)]
    return [header[k] for k in keep], [[r[k] for k in keep] for r in body]


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    same = True
    for name in ("trace.csv", "summary.csv"):
        ha, ra = table(os.path.join(sys.argv[1], name))
        hb, rb = table(os.path.join(sys.argv[2], name))
        if ha != hb:
            print(f"{name}: different columns")
            same = False
            continue
        if len(ra) != len(rb):
            print(f"{name}: {len(ra)} rows against {len(rb)}")
            same = False
            continue
        diff = [(i, c) for i, (a, b) in enumerate(zip(ra, rb)) for c in range(len(ha))
                if a[c] != b[c]]
        if diff:
            i, c = diff[0]
            print(f"{name}: {len(diff)} cells differ; first: row {i + 1}, {ha[c]}: "
                  f"{ra[i][c]} against {rb[i][c]}")
            same = False
        else:
            print(f"{name}: {len(ra)} rows x {len(ha)} columns identical (time columns left out)")
    sys.exit(0 if same else 1)


if __name__ == "__main__":
    main()
