#!/usr/bin/env bash
# Issue 36's cases that a radlab binary shows on its command line, run through the binary given
# ($1) in a fresh folder ($2): the polygon limit on an OBJ (36.7), a merge of shards computed on
# two versions of a scene's MTL (36.2), a merge of a shard whose runs/ lost its files (36.5), and a
# cached raycast matrix whose .sigma side file was zeroed (36.8). Prints each case's exit code and
# the line that matters. Used to show the regression cases fail on 83085a8's code
# (docs/reliability.md): build that commit's `radlab` in a worktree and run this with both.
#   scripts/reliability_cases.sh build/cli/radlab /tmp/cases-new
[ $# -eq 2 ] || { echo "usage: $0 RADLAB_BINARY WORK_FOLDER" >&2; exit 2; }
RL=$(realpath "$1"); W=$2; rm -rf "$W"; mkdir -p "$W"; cd "$W"; export RADLAB_CACHE_DIR=$W/cache
# 36.7: an OBJ of 900 triangles under --limits polygons=100.
python3 - <<'PY'
with open("tri900.obj", "w") as f:
    k = 0
    for i in range(30):
        for j in range(15):
            f.write(f"v {i} {j} 0\nv {i+1} {j} 0\nv {i} {j+1} 0\nv {i+1} {j+1} 0\n")
            f.write(f"f {k+1} {k+2} {k+4}\nf {k+1} {k+4} {k+3}\n"); k += 4
    # a lamp above, facing down, so that the scene is valid but for its size
    f.write(f"mtllib lamp.mtl\nusemtl lamp\nv 10 5 3\nv 10 6 3\nv 11 6 3\nv 11 5 3\nf {k+1} {k+2} {k+3} {k+4}\n")
with open("lamp.mtl", "w") as f:
    f.write("newmtl lamp\nKd 0.5 0.5 0.5\nKe 1 1 1\n")
PY
$RL --limits polygons=100 -q solve tri900.obj --reference none --steps 1 --solver jacobi > l.txt 2>&1
echo "36.7 polygons limit: exit $? | $(grep -i -m1 -E 'error|polygons' l.txt)"
# 36.2: a sweep over an OBJ scene; the MTL edited; the sweep run again into the same folder.
cat > box.obj <<'OBJ'
mtllib box.mtl
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0 0 1
v 1 0 1
v 1 1 1
v 0 1 1
usemtl wall
f 1 4 3 2
f 5 6 7 8
f 1 2 6 5
f 2 3 7 6
f 3 4 8 7
usemtl lamp
f 4 1 5 8
OBJ
printf 'newmtl wall\nKd 0.5 0.5 0.5\nnewmtl lamp\nKd 0.5 0.5 0.5\nKe 1 1 1\n' > box.mtl
printf 'name = "mix"\nscenes = ["box.obj"]\nsubdiv = 2\nsolvers = ["jacobi", "gauss-seidel"]\n[budget]\nsteps = 5\n' > mix.toml
$RL -q run mix.toml --shard 0/2 --out v0 > /dev/null 2>&1; echo "36.2 shard 0/2 on the first MTL: exit $?"
printf 'newmtl wall\nKd 0.9 0.9 0.9\nnewmtl lamp\nKd 0.5 0.5 0.5\nKe 1 1 1\n' > box.mtl
$RL -q run mix.toml --shard 1/2 --out v1 > /dev/null 2>&1; echo "36.2 shard 1/2 on the edited MTL: exit $?"
$RL -q merge v0 v1 --out vmerged > r2.txt 2>&1
echo "36.2 merge of the two versions: exit $? | $(grep -i -m1 -E 'error' r2.txt)"
printf 'newmtl wall\nKd 0.5 0.5 0.5\nnewmtl lamp\nKd 0.5 0.5 0.5\nKe 1 1 1\n' > box.mtl
# 36.5: two shards, one shard's runs/ emptied, merged.
$RL -q run mix.toml --shard 0/2 --out s0 > /dev/null 2>&1; $RL -q run mix.toml --shard 1/2 --out s1 > /dev/null 2>&1
rm -rf s1/runs/*
$RL -q merge s0 s1 --out merged > m.txt 2>&1
echo "36.5 merge with an emptied runs/: exit $? | $(grep -i -m1 -E 'error|missing|manifest' m.txt)"
# 36.8: the .sigma side file of a cached raycast matrix zeroed, then the matrix used again.
$RL -q solve builtin:cornell --subdiv 2 --steps 3 --solver jacobi > s1.txt 2>&1; echo "36.8 first solve: exit $?"
for f in cache/*.sigma; do [ -f "$f" ] && python3 -c "import sys; p=sys.argv[1]; n=len(open(p,'rb').read()); open(p,'wb').write(bytes(n))" "$f"; done
$RL -q solve builtin:cornell --subdiv 2 --steps 3 --solver jacobi > s2.txt 2>&1
echo "36.8 solve after zeroing .sigma: exit $? | $(grep -i -m1 -E 'error|unphysical|sigma|side file' s2.txt)"
