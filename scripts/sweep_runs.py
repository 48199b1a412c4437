"""The runs of a radlab output folder, as its sweep.json lists them (shared by the plot scripts).

A folder may hold files of runs that are not part of its sweep (an interrupted sweep, files
copied in by hand); the plots show only the runs sweep.json lists, and refuse a sweep that is not
complete (status "running": interrupted or still running). A merge with --allow-incomplete says
"incomplete": plotted, with a warning. A sweep.json without a status (an older radlab) is plotted
with a warning.
"""
import json
import os
import sys


def listed_runs(out_dir, script):
    """(sweep, run ids in run order) of OUT_DIR; exits with a message when it cannot be used."""
    path = os.path.join(out_dir, "sweep.json")
    if not os.path.exists(path):
        sys.exit(f"{script}: {path}: no such file (not the output folder of `radlab run`)")
    try:
        with open(path) as f:
            sweep = json.load(f)
    except (OSError, ValueError) as e:
        sys.exit(f"{script}: {path}: cannot read ({e})")
    status = sweep.get("status")
    if status is None:
        print(f"{script}: warning: {path} has no status (written by an older radlab)",
              file=sys.stderr)
    elif status == "incomplete":
        print(f"{script}: warning: {path}: status incomplete, {sweep.get('missing_runs', '?')} "
              "runs of the sweep are missing", file=sys.stderr)
    elif status != "complete":
        sys.exit(f"{script}: {out_dir}: the sweep is not complete (status {status!r}: "
                 "interrupted or still running); run it again to finish it")
    return sweep, list(sweep.get("runs", []))
