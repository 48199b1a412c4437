#!/usr/bin/env python3
"""Measures what `radlab prepare --plan` estimates against what preparing costs (docs/reliability.md,
"Estimates that bound"): for a small benchmark of scenes and form-factor settings, each problem is
prepared alone on an empty cache under /usr/bin/time, and its peak resident size and wall time are
set beside the plan's `memory_mb` and `prepare_seconds`. An estimate bounds the measurement when the
ratio measured / estimated is at most 1.

    python3 scripts/measure_estimates.py [--radlab build/cli/radlab] [--threads 2]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

# name, scene, subdiv, [form_factors] lines, precision
CASES = [
    ("cornell raycast float", "builtin:cornell", 12, 'method = "raycast"\nrays = 4', "float"),
    ("cornell raycast double", "builtin:cornell", 12, 'method = "raycast"\nrays = 4', "double"),
    ("cornell raycast float", "builtin:cornell", 4, 'method = "raycast"\nrays = 16', "float"),
    ("cube hemicube R 2048", "builtin:cube", 8, 'method = "hemicube"\nresolution = 2048', "float"),
    ("cornell hemicube R 512", "builtin:cornell", 4, 'method = "hemicube"\nresolution = 512', "float"),
    ("cornell hemicube R 150", "builtin:cornell", 8, 'method = "hemicube"', "float"),
]


def experiment(scene, subdiv, form_factors, precision):
    return (f'name = "estimate"\nscenes = ["{scene}"]\nsubdiv = {subdiv}\n'
            f'solvers = ["jacobi"]\n'
            f'[form_factors]\n{form_factors}\nprecision = "{precision}"\n[budget]\nrows = 10\n')


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--radlab", default="build/cli/radlab")
    parser.add_argument("--threads", type=int, default=2)
    args = parser.parse_args()
    radlab = os.path.abspath(args.radlab)
    print("| case | elements | memory estimated (MB) | peak RSS (MB) | ratio | time estimated (s) "
          "| wall (s) | ratio |")
    print("|---|---|---|---|---|---|---|---|")
    worst_memory = worst_time = 0.0
    for name, scene, subdiv, form_factors, precision in CASES:
        with tempfile.TemporaryDirectory() as folder:
            toml = os.path.join(folder, "e.toml")
            with open(toml, "w") as f:
                f.write(experiment(scene, subdiv, form_factors, precision))
            env = dict(os.environ, RADLAB_CACHE_DIR=os.path.join(folder, "cache"))
            plan = subprocess.run([radlab, "-q", "--threads", str(args.threads), "prepare", toml,
                                   "--plan"], env=env, capture_output=True, text=True, check=True)
            problem = json.loads(plan.stdout)["problems"][0]
            timed = subprocess.run(["/usr/bin/time", "-f", "%M %e", radlab, "-q", "--threads",
                                    str(args.threads), "prepare", toml], env=env,
                                   capture_output=True, text=True)
            if timed.returncode != 0:
                sys.exit(f"{name}: radlab prepare failed:\n{timed.stderr}")
            rss_kb, wall = timed.stderr.strip().splitlines()[-1].split()
            rss_mb = float(rss_kb) * 1024 / 1e6
            memory_ratio = rss_mb / problem["memory_mb"]
            time_ratio = float(wall) / max(problem["prepare_seconds"], 1e-9)
            worst_memory = max(worst_memory, memory_ratio)
            worst_time = max(worst_time, time_ratio)
            print(f"| {name}, subdiv {subdiv} | {problem['elements']} | {problem['memory_mb']:.0f} "
                  f"| {rss_mb:.0f} | {memory_ratio:.2f} | {problem['prepare_seconds']:.3g} "
                  f"| {float(wall):.3g} | {time_ratio:.2f} |", flush=True)
    print(f"\nlargest ratios: memory {worst_memory:.2f}, time {worst_time:.2f} "
          f"(at most 1: the estimate bounds the measurement)")


if __name__ == "__main__":
    main()
