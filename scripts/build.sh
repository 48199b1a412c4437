#!/usr/bin/env bash
# Configures and builds radlab (Release, Ninja when installed, ccache when installed).
#   scripts/build.sh [--target NAME]... [BUILD_DIR] [extra cmake args...]
# Default BUILD_DIR is build/; default targets are all of them (the library, `radlab`, the tests
# and the benchmarks). scripts/run-main.sh builds only `radlab`, scripts/test.sh everything.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
targets=()
while [ "${1:-}" = "--target" ]; do
  targets+=(--target "$2")
  shift 2
done
build="${1:-$root/build}"
shift || true

# Tests and benchmarks on unless the arguments turn them off (scripts/run-main.sh does).
configure=(-DCMAKE_BUILD_TYPE=Release -DRADLAB_BUILD_TESTS=ON -DRADLAB_BUILD_BENCHMARKS=ON)
# The generator is chosen once, when the folder is made; a folder made by an earlier Makefile
# build keeps its generator (CMake refuses to switch).
if [ ! -f "$build/CMakeCache.txt" ] && command -v ninja >/dev/null 2>&1; then
  configure+=(-G Ninja)
fi
# ccache makes a rebuild of unchanged sources a copy (CCACHE_DISABLE=1 turns it off for a run).
# The precompiled headers (CLI11, GoogleTest, nlohmann-json) are cacheable only with this
# sloppiness (ccache's manual, "Precompiled headers").
if command -v ccache >/dev/null 2>&1; then
  configure+=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
  export CCACHE_SLOPPINESS="${CCACHE_SLOPPINESS:-pch_defines,time_macros,include_file_mtime,include_file_ctime}"
else
  configure+=(-DCMAKE_CXX_COMPILER_LAUNCHER=)
fi
cmake -S "$root" -B "$build" "${configure[@]}" "$@" >/dev/null
cmake --build "$build" -j"$(nproc)" "${targets[@]}"
