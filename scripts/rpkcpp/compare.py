#!/usr/bin/python3
"""Scores an rpkCpp (RenderPark) solution against radlab's certified reference, element by element.

Usage (with build/python on PYTHONPATH; docs/peers.md gives the whole procedure):

  scripts/rpkcpp/compare.py RPK_BINARY SCENE.mgf RPK_SCENE.mgf [--mgf-include-root R]
      [--rpk-args "-radiance-method Galerkin -iterations 11"] [--work DIR]
      [--radlab-solution B.csv ...] [--dump RPK_DUMP.csv]

rpkCpp is not part of radlab and is never downloaded by it: RPK_BINARY is a local build of
github.com/OscarChavarro/rpkCpp with a small instrumentation (docs/peers.md): when the
environment variable RPK_DUMP_PATCHES names a file, it writes one line per patch, in scene
order, with the patch's area, normal, reflectance Rd and emittance Ed (RGB), the constant
coefficient of its radiance (for RenderPark's orthonormal bases the area average over the
patch: L_r, L_g, L_b) and the radiance at the patch centre (Lc_*: the linear basis evaluated
there, for Galerkin).

RPK_SCENE.mgf is the scene as radlab loads SCENE.mgf (overlaps removed, non-convex faces split),
written by scripts/rpkcpp/export_mgf as one MGF face per radlab element in element order, so
that both programs solve the same geometry. rpkCpp splits faces of more than four vertices into several patches and drops
faces it calls degenerate, so patches are matched to elements by walking both lists in order:
an element takes the next patches while their normals agree (cosine > 0.999) and their summed
area reaches the element's within 0.5% (+ 1e-5 m^2: rpkCpp's areas are floats), their
area-weighted centre within the element's size (square root of its area) of its centroid; an element whose patches do not add up is unmatched and
left out of the metrics (their number and area are printed).

Units: RenderPark stores radiance in W/(sr m^2) after dividing MGF's luminous emittance by its
white efficacy (183.07 lm/W); radlab's MGF radiosities are luminous exitances in lm/m^2
(docs/scenes.md). The factor k = E / Ed is measured on the emitters, per channel, and must be
pi x 183.07 = 575.13 within 1e-3 on every emitter and channel (tinted emitters differ by a few
1e-4 through the two colour conversions), or the script stops; then k = pi x 183.07.

Metrics, as the runner's headline ones (metrics/error_metrics.cpp): on the mean of the
channels, rms_rel = sqrt(sum A (B - B*)^2 / sum A B*^2) and rms_rel_reflected =
sqrt(sum A (B - B*)^2 / sum A (B* - E)^2), over the matched elements, B* the certified reference
(radlab.reference: from the cache, computed only if the cache lacks it). The reflectances the
two programs give the same material are compared too (their colour conversions differ on
saturated colours): the largest difference and the area where the mean over the channels
differs by more than 1%.
"""
import argparse
import csv
import os
import re
import shlex
import subprocess
import sys

import numpy as np

import radlab

RENDERPARK_WHITE_EFFICACY = 183.07  # lm/W, RenderPark's conversion of MGF emittance to watts


def read_dump(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        sys.exit(f"{path}: no patches (was the scene empty?)")

    def columns(*names):
        return np.array([[float(row[n]) for n in names] for row in rows])

    return {
        "area": columns("area")[:, 0],
        "normal": columns("nx", "ny", "nz"),
        "centre": columns("cx", "cy", "cz"),
        "Rd": columns("Rd_r", "Rd_g", "Rd_b"),
        "Ed": columns("Ed_r", "Ed_g", "Ed_b"),
        "L": columns("L_r", "L_g", "L_b"),
        "Lc": columns("Lc_r", "Lc_g", "Lc_b"),
    }


def match_patches(areas, normals, centroids, patch):
    """For every element, the list of patch indices that make it (empty: unmatched)."""
    parts = []
    j, m = 0, len(patch["area"])
    for i in range(len(areas)):
        # rpkCpp computes areas in float: slivers of 1e-6 m^2 come out 10% off, hence the
        # absolute part of the tolerance (float rounding of coordinates of a few metres).
        tolerance = 5e-3 * areas[i] + 1e-5
        taken, total, k = [], 0.0, j
        while k < m and (not taken or total < areas[i] - tolerance):
            if np.dot(patch["normal"][k], normals[i]) < 0.999:
                break
            total += patch["area"][k]
            taken.append(k)
            k += 1
        # The patches' area-weighted centre must lie on the element: a dropped element must
        # not take its successor's patches.
        near = False
        if taken:
            w = patch["area"][taken]
            centre = (w[:, None] * patch["centre"][taken]).sum(axis=0) / w.sum()
            near = np.linalg.norm(centre - centroids[i]) <= np.sqrt(areas[i])
        if near and abs(total - areas[i]) <= tolerance:
            parts.append(taken)
            j = k
        else:
            parts.append([])
    return parts


def area_average(values, parts, patch_area):
    out = np.zeros((len(parts), values.shape[1]))
    for i, taken in enumerate(parts):
        if taken:
            w = patch_area[taken]
            out[i] = (w[:, None] * values[taken]).sum(axis=0) / w.sum()
    return out


def metrics(B, reference, E, A):
    b, r, e = B.mean(axis=1), reference.mean(axis=1), E.mean(axis=1)
    squared = np.sum(A * (b - r) ** 2)
    return (np.sqrt(squared / np.sum(A * r**2)), np.sqrt(squared / np.sum(A * (r - e) ** 2)))


def run_rpk(binary, scene, rpk_args, work):
    work = os.path.abspath(work)
    dump = os.path.join(work, "rpk_patches.csv")
    log = os.path.join(work, "rpk.log")
    if os.path.exists(dump):
        os.remove(dump)
    command = [binary, os.path.abspath(scene), "-raytracing-method", "none", "-timings"]
    command += shlex.split(rpk_args)
    with open(log, "w") as out:
        subprocess.run(command, cwd=work, stdout=out, stderr=subprocess.STDOUT, check=False,
                       env=dict(os.environ, RPK_DUMP_PATCHES=dump))
    if not os.path.exists(dump):
        sys.exit(f"{binary} wrote no {dump}: it lacks the RPK_DUMP_PATCHES instrumentation "
                 f"(docs/peers.md), or it failed (see {log})")
    text = open(log, errors="replace").read()
    seconds = re.findall(r"Radiance total time ([0-9.e+-]+) secs", text)
    rays = re.findall(r"Radiance rays: (\d+)", text)
    print(f"rpkCpp: {' '.join(command[1:])}")
    if seconds:
        print(f"rpkCpp radiance CPU seconds (its own clock, loading excluded): {seconds[-1]}")
    if rays:
        print(f"rpkCpp radiance rays: {rays[-1]}")
    return read_dump(dump)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("rpk", help="the instrumented rpkCpp binary")
    parser.add_argument("scene", help="the scene radlab loads (its certified reference)")
    parser.add_argument("rpk_scene", help="the same scene written per radlab element")
    parser.add_argument("--mgf-include-root", default=None)
    parser.add_argument("--rpk-args", default="-radiance-method Galerkin -iterations 11")
    parser.add_argument("--work", default=".", help="folder for rpkCpp's log and dump")
    parser.add_argument("--dump", default=None,
                        help="score this RPK_DUMP_PATCHES file instead of running rpkCpp")
    parser.add_argument("--radlab-solution", nargs="*", default=[],
                        help="radlab solve --out CSVs to score beside it")
    args = parser.parse_args()
    os.makedirs(args.work, exist_ok=True)

    scene = radlab.load(args.scene, mgf_include_root=args.mgf_include_root)
    A = np.asarray(scene.areas)
    E = np.asarray(scene.E).reshape(scene.size, -1)
    rho = np.asarray(scene.rho).reshape(scene.size, -1)
    if E.shape[1] == 1:
        E, rho = np.repeat(E, 3, axis=1), np.repeat(rho, 3, axis=1)
    if args.dump:
        patch = read_dump(args.dump)
    else:
        patch = run_rpk(args.rpk, args.rpk_scene, args.rpk_args, args.work)
    parts = match_patches(A, np.asarray(scene.normals), np.asarray(scene.centroids), patch)
    matched = np.array([bool(p) for p in parts])
    print(f"elements {scene.size}, rpkCpp patches {len(patch['area'])}, matched {matched.sum()} "
          f"({A[matched].sum() / A.sum():.6f} of the area); unmatched {(~matched).sum()}")

    Ed = area_average(patch["Ed"], parts, patch["area"])
    emitters = matched & (E.sum(axis=1) > 0)
    if not emitters.any():
        sys.exit("no matched emitter: cannot tie rpkCpp's units to radlab's")
    k = E[emitters] / Ed[emitters]
    spread = (k.max() - k.min()) / k.mean()
    expected = np.pi * RENDERPARK_WHITE_EFFICACY
    print(f"units: radlab E / rpkCpp Ed on {emitters.sum()} emitters: {k.min():.6g} .. "
          f"{k.max():.6g} (pi x {RENDERPARK_WHITE_EFFICACY} = {expected:.6g})")
    # Tinted emitters (hospital's cxy 0.337 lamps) go through the two colour conversions, which
    # differ slightly off the neutral point: a spread of a few 1e-4, hence 1e-3.
    if spread > 1e-3 or abs(k.mean() / expected - 1) > 1e-3:
        sys.exit("the emitters do not give one factor pi x 183.07: the mapping is not exact")
    k = expected

    Rd = area_average(patch["Rd"], parts, patch["area"])
    diff = np.abs(Rd - rho)[matched]
    mean_diff = np.abs(Rd.mean(axis=1) - rho.mean(axis=1))[matched]
    print(f"reflectance: largest |rpkCpp - radlab| {diff.max():.4f} in a channel; mean of the "
          f"channels differs by > 1% on {A[matched][mean_diff > 0.01].sum() / A.sum():.4f} of "
          f"the area (largest {mean_diff.max():.4f})")

    reference = np.asarray(radlab.reference(scene).B).reshape(scene.size, -1)
    if reference.shape[1] == 1:
        reference = np.repeat(reference, 3, axis=1)
    sel = matched
    for name, values in (("area average", patch["L"]), ("centre value", patch["Lc"])):
        B = k * area_average(values, parts, patch["area"])
        rms_rel, rms_rel_reflected = metrics(B[sel], reference[sel], E[sel], A[sel])
        print(f"rpkCpp {name:13s}: rms_rel {rms_rel:.6g}  rms_rel_reflected "
              f"{rms_rel_reflected:.6g}  (matched elements)")
    for path in args.radlab_solution:
        B = radlab.read_solution(path, scene.size)
        rms_rel, rms_rel_reflected = metrics(B[sel], reference[sel], E[sel], A[sel])
        whole = metrics(B, reference, E, A)
        print(f"radlab {path}: rms_rel {rms_rel:.6g}  rms_rel_reflected {rms_rel_reflected:.6g}"
              f"  (matched elements; all elements: {whole[0]:.6g}, {whole[1]:.6g})")


if __name__ == "__main__":
    main()
