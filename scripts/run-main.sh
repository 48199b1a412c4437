#!/usr/bin/env bash
# The main job: installs what is missing, builds Release, and runs the default experiment on the
# built-in Cornell box, writing a trace CSV, the final radiosities, run.json and an image.
# Usage: scripts/run-main.sh [OUT_DIR]   (default out/main)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
out="${1:-$root/out/main}"
"$root/scripts/install-deps.sh"
"$root/scripts/build.sh" "$root/build"
mkdir -p "$out"
"$root/build/experiments/radlab" solve builtin:cornell --subdiv 6 --solver gauss-seidel \
  --steps 3000 --trace "$out/trace.csv" --out "$out/radiosity.csv" --image "$out/cornell.exr"
echo
echo "main job done; results in $out:"
ls -1 "$out"
