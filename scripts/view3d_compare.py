#!/usr/bin/env python3
"""Side-by-side form factors against NIST View3D (docs/formfactors.md, "Occluded pairs").

  view3d_compare.py scenes DIR
      writes DIR/room_box.{obj,mtl,vs3} (unit room with a box [0.25,0.75]^3 inside, 480
      elements at --element-size 0.125) and DIR/box6144.{obj,vs3} (unit box, 6,144 elements at
      --element-size 0.03125). Each .vs3 lists the same elements in radlab's mesh order (polygon
      by polygon, each a K x K grid, row by row from the first corner), so element k of radlab
      is View3D surface k+1.
  view3d_compare.py error REFERENCE CANDIDATE [--rows A:B --cols C:D]
      worst row error max_i sum_j |F_ij - F*_ij| over rows A..B-1 and columns C..D-1 (default
      the room's floor 0:64 and ceiling 64:128). Each file is radlab's CSV (i,j,F) or View3D's
      binary output (out=1; its text output has 6 decimals only).

View3D itself is not fetched by anything here: build it anywhere and run it on the .vs3 file.
"""
import struct
import sys


def face(axis, value, sign, lo, hi):
    """Axis-aligned square at coordinate `value` along `axis`, spanning [lo, hi] along the
    other two, front normal sign * e_axis; corners counter-clockwise seen from the front."""
    u, v = (axis + 1) % 3, (axis + 2) % 3
    if sign < 0:
        u, v = v, u

    def point(a, b):
        p = [0.0, 0.0, 0.0]
        p[axis] = value
        p[u] = a
        p[v] = b
        return tuple(p)

    return [point(lo, lo), point(hi, lo), point(hi, hi), point(lo, hi)]


def room_box():
    polygons = [face(2, 0.0, +1, 0, 1), face(2, 1.0, -1, 0, 1),  # floor, ceiling
                face(0, 0.0, +1, 0, 1), face(0, 1.0, -1, 0, 1),
                face(1, 0.0, +1, 0, 1), face(1, 1.0, -1, 0, 1)]
    lo, hi = 0.25, 0.75  # the box, faces outward
    polygons += [face(2, lo, -1, lo, hi), face(2, hi, +1, lo, hi),
                 face(0, lo, -1, lo, hi), face(0, hi, +1, lo, hi),
                 face(1, lo, -1, lo, hi), face(1, hi, +1, lo, hi)]
    return polygons, 0.125


def unit_box():
    polygons = [face(2, 0.0, +1, 0, 1), face(2, 1.0, -1, 0, 1),
                face(0, 0.0, +1, 0, 1), face(0, 1.0, -1, 0, 1),
                face(1, 0.0, +1, 0, 1), face(1, 1.0, -1, 0, 1)]
    return polygons, 1.0 / 32.0


def grid(q, k):
    """radlab's quad_grid (scene/mesh.cpp): bilinear K x K grid, rows b, columns a."""
    def at(a, b):
        s, t = a / k, b / k
        return tuple((1 - s) * (1 - t) * q[0][c] + s * (1 - t) * q[1][c] + s * t * q[2][c] +
                     (1 - s) * t * q[3][c] for c in range(3))
    for b in range(k):
        for a in range(k):
            yield [at(a, b), at(a + 1, b), at(a + 1, b + 1), at(a, b + 1)]


def write_scene(stem, polygons, h, title):
    with open(stem + ".mtl", "w") as f:
        f.write("newmtl grey\nKd 0.5 0.5 0.5\nKe 0 0 0\nnewmtl lamp\nKd 0.5 0.5 0.5\nKe 1 1 1\n")
    name = stem.split("/")[-1]
    with open(stem + ".obj", "w") as f:
        f.write("# %s: radlab --element-size %g; the same elements as %s.vs3\n" % (title, h, name))
        f.write("mtllib %s.mtl\n" % name)
        for p in polygons:
            for v in p:
                f.write("v %.17g %.17g %.17g\n" % v)
        for n, p in enumerate(polygons):
            f.write("usemtl %s\n" % ("lamp" if n == 1 else "grey"))
            f.write("f %d %d %d %d\n" % tuple(4 * n + k + 1 for k in range(4)))
    vertices, surfaces = [], []
    for p in polygons:
        edge = max(abs(p[1][c] - p[0][c]) for c in range(3))
        k = round(edge / h)
        for quad in grid(p, k):
            surfaces.append([len(vertices) + m + 1 for m in range(4)])
            vertices.extend(quad)
    with open(stem + ".vs3", "w") as f:
        f.write("T %s\n" % title)
        f.write("C encl=0 list=0 out=1 eps=1e-4\n")  # eps: edit for other tolerances
        f.write("F 3\n")
        for n, v in enumerate(vertices):
            f.write("V %d %.17g %.17g %.17g\n" % ((n + 1,) + v))
        for n, s in enumerate(surfaces):
            f.write("S %d %d %d %d %d 0 0 0.9 s%d\n" % ((n + 1,) + tuple(s) + (n + 1,)))
        f.write("End of data\n")
    return len(surfaces)


def read_matrix(path):
    """{(i, j): F} with 0-based indices, from radlab's CSV (i,j,F) or View3D's binary output
    (out=1: a 32-byte header, n areas, n rows of n F values, n emittances, all float32)."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:6] == b"View3D":
        words = (len(data) - 32) // 4
        n = int(round((words + 1) ** 0.5 - 1))  # words = n^2 + 2n
        if n * n + 2 * n != words:
            raise SystemExit("%s: not a View3D binary view-factor file" % path)
        values = struct.unpack("<%df" % words, data[32:32 + 4 * words])
        return {(i, j): values[n + i * n + j] for i in range(n) for j in range(n)
                if values[n + i * n + j] != 0.0}
    result = {}
    for line in data.decode().splitlines():
        parts = line.split(",")
        if len(parts) != 3 or not parts[0].strip().isdigit():
            continue
        result[(int(parts[0]), int(parts[1]))] = float(parts[2])
    return result


def main(argv):
    if len(argv) >= 2 and argv[0] == "scenes":
        d = argv[1].rstrip("/")
        n = write_scene(d + "/room_box", *room_box(), "unit room with a box [0.25,0.75]^3 inside")
        m = write_scene(d + "/box6144", *unit_box(), "unit box, 32 x 32 elements a face")
        print("room_box: %d elements, box6144: %d elements" % (n, m))
        return 0
    if len(argv) >= 3 and argv[0] == "error":
        rows, cols = (0, 64), (64, 128)
        for k in range(3, len(argv) - 1):
            if argv[k] == "--rows":
                rows = tuple(int(x) for x in argv[k + 1].split(":"))
            if argv[k] == "--cols":
                cols = tuple(int(x) for x in argv[k + 1].split(":"))
        ref, cand = read_matrix(argv[1]), read_matrix(argv[2])
        worst, worst_row, total = 0.0, -1, 0.0
        for i in range(*rows):
            e = sum(abs(cand.get((i, j), 0.0) - ref.get((i, j), 0.0)) for j in range(*cols))
            s = sum(ref.get((i, j), 0.0) for j in range(*cols))
            total += s
            if e > worst:
                worst, worst_row = e, i
        print("worst row error %.3e (row %d); reference block sum %.6f" % (worst, worst_row, total))
        return 0
    print(__doc__, file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
