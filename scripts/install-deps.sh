#!/usr/bin/env bash
# Installs radlab's dependencies from Debian 12 packages, in two groups:
#   scripts/install-deps.sh main   what the main job needs: the compiler, CMake, Ninja, the
#                                  libraries radlab links, and python3 with what the plots use
#   scripts/install-deps.sh test   main's packages and what the tests, benchmarks and style
#                                  check add (GoogleTest, Google Benchmark, clang-format,
#                                  Snakemake for the workflow test, pybind11 and pytest for
#                                  the Python module)
#   scripts/install-deps.sh        both (the same as test)
# Idempotent: installs only what is missing, and does nothing (not even apt-get update) when
# everything is present. Needs root for apt-get; as another user it uses sudo when available,
# else says what to run. A new dependency goes into the group that needs it.
set -euo pipefail

main_packages=(
  build-essential cmake ninja-build git pkg-config
  libglm-dev libembree-dev libopenexr-dev libceres-dev libeigen3-dev libtbb-dev
  libcli11-dev libtomlplusplus-dev libpng-dev nlohmann-json3-dev
  libboost-dev  # Boost.Geometry R-tree (scene/overlap.cpp), Boost.Random Sobol (solvers/monte_carlo)
  libcgal-dev  # scene/triangulate.cpp (header-only)
  libssl-dev  # SHA-256 of scene files, sweep manifests and plugins (core/sha256.cpp)
  python3 python3-matplotlib python3-numpy python3-pandas
)
test_packages=(
  libgtest-dev libbenchmark-dev clang-format
  snakemake  # workflow/Snakefile and its test (76 packages, 682 MB with python3-azure)
  # The Python module (python/, docs/python.md): pybind11 to build it, scipy for its matrices,
  # pytest and nbconvert/ipykernel for its tests and notebooks, tomli-w for experiments given as
  # dicts.
  pybind11-dev python3-pybind11 python3-dev python3-scipy python3-pytest python3-nbconvert
  python3-ipykernel python3-tomli-w
)

case "${1:-test}" in
  main) packages=("${main_packages[@]}") ;;
  test) packages=("${main_packages[@]}" "${test_packages[@]}") ;;
  *)
    echo "usage: scripts/install-deps.sh [main|test]" >&2
    exit 2
    ;;
esac

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

echo "install-deps: installing ${missing[*]}"
if [ "$(id -u)" -eq 0 ]; then
  as_root=()
elif command -v sudo >/dev/null 2>&1; then
  as_root=(sudo)
else
  echo "install-deps: not root and no sudo. As root, run:" >&2
  echo "  apt-get update && apt-get install -y ${missing[*]}" >&2
  exit 1
fi
export DEBIAN_FRONTEND=noninteractive
"${as_root[@]}" apt-get update -qq
"${as_root[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
