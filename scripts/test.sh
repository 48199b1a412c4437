#!/usr/bin/env bash
# The whole test suite: installs what is missing, builds (warnings are errors), runs every test.
# This is what CI runs (.ci/run).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/scripts/install-deps.sh"
build="$root/build-test"
"$root/scripts/build.sh" "$build" -DRADLAB_WERROR=ON
cd "$build"
ctest --output-on-failure -j"$(nproc)" --timeout 600
