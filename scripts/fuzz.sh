#!/usr/bin/env bash
# Builds the libFuzzer harnesses (clang, AddressSanitizer + UBSan, in build-fuzz/) and runs each
# for SECONDS (default 60). Not part of the test suite. Usage:
#   scripts/fuzz.sh [SECONDS] [HARNESS...]     HARNESS: obj mgf toml merge (default: all)
# Each harness starts from the committed seeds and findings in fuzz/corpus/HARNESS, keeps its
# growing corpus in build-fuzz/corpus/HARNESS, and writes crashes, timeouts (hangs) and
# allocations above the limit to build-fuzz/findings/HARNESS/. Crashes do not stop a run
# (libFuzzer's fork mode). A finding, once fixed, is copied into fuzz/corpus/HARNESS/ and so
# replayed by the default test suite (tests/fuzz/fuzz_corpus_test.cpp). docs/reliability.md.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
seconds="${1:-60}"
shift || true
harnesses=("$@")
[ ${#harnesses[@]} -eq 0 ] && harnesses=(obj mgf toml merge)
build="$root/build-fuzz"
compiler="$(command -v clang++-14 || command -v clang++ || true)"
if [ -z "$compiler" ]; then
  echo "fuzz: needs clang (apt-get install clang-14 libclang-rt-14-dev)" >&2
  exit 1
fi
# FUZZ_NO_BUILD=1 runs what is built (e.g. two harnesses at once from two shells).
if [ -z "${FUZZ_NO_BUILD:-}" ]; then
  cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DRADLAB_FUZZ=ON \
    -DCMAKE_CXX_COMPILER="$compiler" >/dev/null
  targets=()
  for h in "${harnesses[@]}"; do targets+=("${h}_fuzz"); done
  cmake --build "$build" -j"$(nproc)" --target "${targets[@]}"
fi
# Leaks in a harness that throws are not findings worth a stop; memory use is bounded by the
# malloc and RSS limits instead.
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=0}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
# Fork mode (default) records a crash and goes on; FUZZ_FORK=0 runs in-process, which is several
# times faster on a loaded machine (no per-job restart) but stops at the first crash.
fork=(-fork=1 -ignore_crashes=1 -ignore_timeouts=1 -ignore_ooms=1)
[ "${FUZZ_FORK:-1}" = 0 ] && fork=()
for h in "${harnesses[@]}"; do
  # Scenes get inputs above 1 MB, large enough for the quadratic cases (a tessellated slab of
  # coplanar polygons, issue 36.3); experiment files and shards stay at 64 kB.
  max_len=65536
  case "$h" in obj | mgf) max_len="${FUZZ_MAX_LEN:-1100000}" ;; esac
  corpus="$build/corpus/$h"
  findings="$build/findings/$h"
  mkdir -p "$corpus" "$findings"
  log="$build/fuzz-$h.log"
  echo "fuzz: $h for ${seconds}s (log $log)"
  # -timeout: an input running 10 s is a hang; -malloc_limit_mb: one allocation above 1 GB is
  # unbounded memory (radlab's own limits refuse far smaller work first).
  "$build/fuzz/${h}_fuzz" "$corpus" "$root/fuzz/corpus/$h" -dict="$root/fuzz/radlab.dict" \
    -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2560 -malloc_limit_mb=1024 \
    -max_len="$max_len" "${fork[@]}" \
    -artifact_prefix="$findings/" >"$log" 2>&1 || true
  grep -E '^#[0-9]+' "$log" | tail -1 || true
  echo "fuzz: $h findings: $(find "$findings" -type f | wc -l) in $findings"
done
