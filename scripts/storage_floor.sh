#!/bin/bash
# The float-storage floor (docs/reference.md): Jacobi and Gauss-Seidel on the closed cube at
# rho = 0.99 (builtin:cube, exact form factors), F stored in double and in float, measured
# against the certified reference of the double-precision F. Writes
# docs/figures/storage_floor.png. Usage: scripts/storage_floor.sh [radlab binary]
set -euo pipefail
cd "$(dirname "$0")/.."
radlab=${1:-build/cli/radlab}
. scripts/python.sh
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for precision in double float; do
  for solver in jacobi gauss-seidel; do
    "$radlab" -q solve builtin:cube:rho=0.99 --ff exact --precision "$precision" \
      --solver "$solver" --rows 24000 --trace "$work/${solver}_${precision}.csv" >/dev/null
  done
done
mkdir -p docs/figures
"$python" - "$work" docs/figures/storage_floor.png <<'PY'
import sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import pandas as pd

work, out = sys.argv[1], sys.argv[2]
fig, ax = plt.subplots(figsize=(6.4, 4.0))
for solver, colour in (("jacobi", "tab:blue"), ("gauss-seidel", "tab:orange")):
    for precision, style in (("double", "-"), ("float", "--")):
        t = pd.read_csv(f"{work}/{solver}_{precision}.csv")
        t = t[t.channel == "mean"]
        ax.semilogy(t.ff_rows / 6, t.rms_rel.clip(lower=1e-17), style, color=colour,
                    label=f"{solver}, F stored in {precision}")
ax.set_xlabel("sweeps (6 rows each)")
ax.set_ylabel("rms_rel against the certified reference of F in double")
ax.set_title("Closed cube, rho = 0.99, exact form factors: the float-storage floor")
ax.legend()
ax.grid(True, which="both", alpha=0.3)
fig.tight_layout()
fig.savefig(out, dpi=120)
print("wrote", out)
PY
