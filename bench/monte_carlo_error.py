"""rms_rel_reflected of a `radlab solve --out B.csv` against the certified reference in the cache.

For the Monte Carlo targets on scenes whose reference takes long to certify (issue 32: the
hospital): a matrix-free run with the certified reference re-certifies the cached reference
against rows computed on the fly (the whole raycast again, docs/solvers.md "Matrix-free runs"),
so the run is timed with `--reference none --out B.csv` and measured here afterwards. The metric
is the runner's headline `rms_rel_reflected` (metrics/error_metrics.cpp compare_reflected on the
mean of the channels): sqrt(sum A (B - B*)^2 / sum A (B* - E)^2), B, B* and E the per-element
means over the channels. The reference is loaded from the cache (radlab.reference: the one
`radlab reference` stored; it is computed, with its matrix, only if the cache lacks it).

Run (with build/python on PYTHONPATH):
  RADLAB_CACHE_DIR=DIR /usr/bin/python3 bench/monte_carlo_error.py SCENE B.csv [--subdiv K]
      [--mgf-include-root R]
"""
import argparse

import numpy as np

import radlab


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene")
    parser.add_argument("solution", help="radlab solve --out CSV")
    parser.add_argument("--subdiv", type=int, default=1)
    parser.add_argument("--mgf-include-root", default=None)
    args = parser.parse_args()
    scene = radlab.load(args.scene, subdiv=args.subdiv, mgf_include_root=args.mgf_include_root)
    B = radlab.read_solution(args.solution, scene.size).mean(axis=1)
    reference = np.asarray(radlab.reference(scene).B).reshape(scene.size, -1).mean(axis=1)
    E = np.asarray(scene.E).mean(axis=1)
    A = np.asarray(scene.areas)
    reflected = np.sum(A * (reference - E) ** 2)
    error = np.sum(A * (B - reference) ** 2)
    value = np.sqrt(error / reflected) if reflected > 0 else np.sqrt(error / np.sum(A))
    print(f"rms_rel_reflected {value:.6g}  ({scene.size} elements)")


if __name__ == "__main__":
    main()
