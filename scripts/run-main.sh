#!/usr/bin/env bash
# The main job: installs what it needs and is missing (scripts/install-deps.sh main), builds the
# `radlab` command alone (Release, in build/; no tests or benchmarks), runs the default experiment
# (experiments/quick.toml: every solver on the built-in Cornell box, about a minute here), then
# draws its convergence plots and a contact sheet of its images, and writes the page that shows it
# all (out/main/index.html, `radlab report`).
# Usage: scripts/run-main.sh [OUT_DIR]   (default out/main)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
out="${1:-$root/out/main}"
"$root/scripts/install-deps.sh" main
# Tests and benchmarks off: their packages belong to the test command, and the main job runs
# neither. scripts/build.sh (no arguments) turns them back on in build/.
"$root/scripts/build.sh" --target radlab "$root/build" -DRADLAB_BUILD_TESTS=OFF \
  -DRADLAB_BUILD_BENCHMARKS=OFF
source "$root/scripts/python.sh"   # sets $python: a python3 with matplotlib, numpy and pandas

"$root/build/cli/radlab" run "$root/experiments/quick.toml" --out "$out"
"$python" "$root/scripts/plot_traces.py" "$out" --out "$out/plots"
"$python" "$root/scripts/contact_sheet.py" "$out" --kind both --out "$out/contact_sheet.png"
# `radlab run` wrote index.html before the plots existed; again, now with them.
"$root/build/cli/radlab" report "$out"

cat <<TEXT

main job done. Open $out/index.html (summary, plots, images, links to every file). In $out:
  trace.csv            errors of every solver at every checkpoint (columns: docs/outputs.md)
  summary.csv          one row per solver run: final errors, rows/seconds to 1e-1..1e-3, fitted rates
  runs/*.radiosity.csv the final radiosities of each run;  runs/*.run.json  how to reproduce it
  images/              EXR + PNG of the display solution and of its error (Cohen's colours, p-error)
  plots/               convergence plots (error against form-factor rows and seconds; PNG and PDF)
  contact_sheet.png    every run's images side by side
TEXT
