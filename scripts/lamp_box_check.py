#!/usr/bin/env python3
"""Which form factors are right inside a classroom.mgf luminaire (issue 33, item 4;
docs/solvers.md, "The classroom floor").

The flat references of classroom.mgf differ most on the lamp boxes' inner reflector faces, 3 cm
from the tube. This script cuts one luminaire (every top-level object whose points all lie in
--box) out of the scene into LAMP.mgf, has radlab compute its form factors with raycast, hemicube
and `exact visibility=clip` (work caps raised so that no pair stops short), and checks the
decisive entries by two computations that share no code with radlab:

  * a plain Monte Carlo double-area integral F_ij = A_j E[cos_i cos_j V / (pi r^2)] (x, y uniform
    on the two polygons; V tested against the tube, the only possible occluder between the two
    reflectors), with its standard deviation;
  * Lambert's contour formula for the point factor at each face's centre (what one hemicube there
    converges to), clipped to the eye's front half-space.

    scripts/lamp_box_check.py CLASSROOM.mgf --radlab build/cli/radlab [--samples N] [--out DIR]
"""
import argparse
import csv
import math
import os
import random
import subprocess


def sub(a, b):
    return [a[k] - b[k] for k in range(3)]


def dot(a, b):
    return sum(a[k] * b[k] for k in range(3))


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def area_vector(P):
    n = [0.0, 0.0, 0.0]
    for a in range(len(P)):
        c = cross(P[a], P[(a + 1) % len(P)])
        n = [n[k] + c[k] for k in range(3)]
    return n


def area(P):
    return 0.5 * math.sqrt(dot(area_vector(P), area_vector(P)))


def unit_normal(P):
    n = area_vector(P)
    length = math.sqrt(dot(n, n))
    return [x / length for x in n]


def centre(P):
    return [sum(p[k] for p in P) / len(P) for k in range(3)]


def extract(scene, out, lo, hi):
    """Top-level `o` blocks of `scene` whose points all lie in [lo, hi]; their text into `out`."""
    blocks, current, depth = [], None, 0
    for line in open(scene):
        s = line.strip()
        if current is None:
            if s.startswith("o "):
                current, depth = [line], 1
            continue
        current.append(line)
        if s.startswith("o "):
            depth += 1
        elif s == "o":
            depth -= 1
            if depth == 0:
                blocks.append(current)
                current = None
    kept = []
    for block in blocks:
        points = [[float(x) for x in l.split()[1:4]] for l in block if l.strip().startswith("p ")]
        if points and all(lo[k] <= p[k] <= hi[k] for p in points for k in range(3)):
            kept.append(block)
    if not kept:
        raise SystemExit(f"{scene}: no object lies wholly in the box {lo} .. {hi}")
    with open(out, "w") as f:
        f.writelines(line for block in kept for line in block)


def read_polygons(path):
    """Polygons in file order (radlab's element order at one element per polygon), each with
    whether its material emits (an `ed` above zero in the material's definition)."""
    points, polygons, name, material, emits = {}, [], None, None, {}
    for line in open(path):
        s = line.split()
        if not s:
            continue
        if s[0] == "m":
            material = s[1]
            if len(s) > 2:
                emits[material] = False
        elif s[0] == "ed":
            emits[material] = float(s[1]) > 0
        elif s[0] == "v":
            name = s[1]
        elif s[0] == "p":
            points[name] = [float(x) for x in s[1:4]]
        elif s[0] == "f":
            polygons.append((emits.get(material, False), [points[n] for n in s[1:]]))
    return polygons


def radlab_matrix(radlab, scene, method, params, out):
    command = [radlab, "formfactors", scene, "--ff", method, "--precision", "double", "--out", out]
    for p in params:
        command += ["--ff-set", p]
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    with open(out, newline="") as f:
        return {(int(r["i"]), int(r["j"])): float(r["F"]) for r in csv.DictReader(f)}


def sample_polygon(rng, P):
    """A uniform point on the convex polygon P (a fan of triangles, chosen by area)."""
    triangles = [(P[0], P[k], P[k + 1]) for k in range(1, len(P) - 1)]
    weights = [area(list(t)) for t in triangles]
    u = rng.random() * sum(weights)
    for t, w in zip(triangles, weights):
        if u <= w:
            break
        u -= w
    s, r = math.sqrt(rng.random()), rng.random()
    return [t[0][k] * (1 - s) + t[1][k] * s * (1 - r) + t[2][k] * s * r for k in range(3)]


def crosses(x, y, Q):
    """Does the segment x-y cross the convex polygon Q?"""
    n = unit_normal(Q)
    dx, dy = dot(sub(x, Q[0]), n), dot(sub(y, Q[0]), n)
    if dx * dy >= 0:
        return False
    p = [x[k] + dx / (dx - dy) * (y[k] - x[k]) for k in range(3)]
    return all(dot(cross(sub(Q[(a + 1) % len(Q)], Q[a]), sub(p, Q[a])), n) >= 0
               for a in range(len(Q)))


def monte_carlo(Pi, Pj, occluders, samples, seed):
    rng = random.Random(seed)
    ni, nj = unit_normal(Pi), unit_normal(Pj)
    total = total2 = 0.0
    for _ in range(samples):
        x, y = sample_polygon(rng, Pi), sample_polygon(rng, Pj)
        d = sub(y, x)
        r2 = dot(d, d)
        ci, cj = dot(ni, d), -dot(nj, d)
        v = 0.0
        if ci > 0 and cj > 0 and not any(crosses(x, y, Q) for Q in occluders):
            v = ci * cj / (math.pi * r2 * r2)
        total += v
        total2 += v * v
    mean = total / samples
    sd = math.sqrt(max(total2 / samples - mean * mean, 0.0) / samples)
    return area(Pj) * mean, area(Pj) * sd


def clip_front(Q, eye, n):
    out, d = [], [dot(sub(q, eye), n) for q in Q]
    for a in range(len(Q)):
        b = (a + 1) % len(Q)
        if d[a] >= 0:
            out.append(Q[a])
        if (d[a] >= 0) != (d[b] >= 0):
            t = d[a] / (d[a] - d[b])
            out.append([Q[a][k] + t * (Q[b][k] - Q[a][k]) for k in range(3)])
    return out


def point_factor(Pi, Q):
    """Lambert's formula from the centre of Pi (its normal) to Q clipped to the front side."""
    eye, n = centre(Pi), unit_normal(Pi)
    Q = clip_front(Q, eye, n)
    s = 0.0
    for a in range(len(Q)):
        r0, r1 = sub(Q[a], eye), sub(Q[(a + 1) % len(Q)], eye)
        c = cross(r0, r1)
        length = math.sqrt(dot(c, c))
        if length > 0:
            s += math.atan2(length, dot(r0, r1)) * dot(n, c) / length
    return abs(s) / (2 * math.pi)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scene", help="classroom.mgf (RenderPark's salon/classroom.mgf)")
    parser.add_argument("--radlab", required=True, help="the radlab binary")
    parser.add_argument("--box", type=float, nargs=6, default=[1.0, 2.4, 3.3, 1.3, 4.0, 3.6],
                        help="x0 y0 z0 x1 y1 z1 of the luminaire to cut out (default: the first)")
    parser.add_argument("--samples", type=int, default=1000000, help="Monte Carlo samples a pair")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--out", default=".", help="folder for LAMP.mgf and the matrices")
    a = parser.parse_args()
    os.makedirs(a.out, exist_ok=True)
    lamp = os.path.join(a.out, "lamp.mgf")
    extract(a.scene, lamp, a.box[:3], a.box[3:])
    polygons = read_polygons(lamp)
    emitters = [i for i, (emitting, _) in enumerate(polygons) if emitting]
    if len(emitters) != 1:
        raise SystemExit(f"{lamp}: expected one tube, found polygons {emitters}")
    tube = emitters[0]
    by_area = sorted(range(len(polygons)), key=lambda i: -area(polygons[i][1]))
    # The two inner reflectors: the largest polygons facing down (towards the room and the tube).
    reflectors = [i for i in by_area if unit_normal(polygons[i][1])[2] < -0.5 and i != tube][:2]
    if len(reflectors) != 2:
        raise SystemExit(f"{lamp}: no two inner reflector faces")
    r0, r1 = reflectors
    F = {m: radlab_matrix(a.radlab, lamp, m, p, os.path.join(a.out, f"F_{m}.csv"))
         for m, p in [("raycast", []), ("hemicube", []),
                      ("exact", ["visibility=clip", "max_evaluations=100000000", "max_depth=24"])]}
    raw = radlab_matrix(a.radlab, lamp, "hemicube", ["symmetrise=false"],
                        os.path.join(a.out, "F_hemicube_raw.csv"))
    print(f"{lamp}: {len(polygons)} polygons; tube {tube}, inner reflectors {r0} and {r1} "
          f"({area(polygons[r0][1]):.4f} m^2 each); {a.samples} Monte Carlo samples a pair\n")
    print("| pair | exact (clip) | Monte Carlo ± 1 sd | raycast | hemicube | hemicube raw row "
          "| point factor at the centre |")
    print("|---|---|---|---|---|---|---|")
    tube_polygon = polygons[tube][1]
    for n, (i, j) in enumerate([(r0, tube), (tube, r0), (r0, r1)]):
        occluders = [tube_polygon] if tube not in (i, j) else []
        mc, sd = monte_carlo(polygons[i][1], polygons[j][1], occluders, a.samples, a.seed + n)
        e = F["exact"].get((i, j), 0.0)
        cells = [f"{e:.6f}", f"{mc:.6f} ± {sd:.6f}"]
        for m in ("raycast", "hemicube"):
            v = F[m].get((i, j), 0.0)
            cells.append(f"{v:.6f} ({v / e - 1:+.2%})")
        v = raw.get((i, j), 0.0)
        cells.append(f"{v:.6f} ({v / e - 1:+.2%})")
        cells.append(f"{point_factor(polygons[i][1], polygons[j][1]):.6f}"
                     if not occluders else "(occluded: not computed)")
        print(f"| F({i},{j}) | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
