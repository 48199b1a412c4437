#!/usr/bin/env bash
# The whole test suite: installs what is missing, builds (warnings are errors), runs every test.
# This is what CI runs (.ci/run).
#   scripts/test.sh              Release build in build-test/ (tests and benchmarks)
#   scripts/test.sh --sanitize   the same suite built with AddressSanitizer + UBSan in
#                                build-sanitize/ (any report fails the test that caused it)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/scripts/install-deps.sh" test
if [ "${1:-}" = "--sanitize" ]; then
  build="$root/build-sanitize"
  # RelWithDebInfo: optimised enough to run the suite in minutes, with line numbers in reports.
  "$root/scripts/build.sh" "$build" -DRADLAB_WERROR=ON -DRADLAB_SANITIZE=ON \
    -DRADLAB_BUILD_TESTS=ON -DRADLAB_BUILD_BENCHMARKS=OFF -DCMAKE_BUILD_TYPE=RelWithDebInfo
  # Leak checking stays on; UBSan stops at the first report so that it fails the test.
  export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1}"
  export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
else
  build="$root/build-test"
  "$root/scripts/build.sh" "$build" -DRADLAB_WERROR=ON -DRADLAB_BUILD_TESTS=ON \
    -DRADLAB_BUILD_BENCHMARKS=ON
fi
cd "$build"
ctest --output-on-failure -j"$(nproc)" --timeout 600
