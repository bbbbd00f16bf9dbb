#!/usr/bin/env bash
# Installs what is missing, builds, and runs the whole test suite (unit, integration, contract,
# fuzz-corpus replay), then a sanitizer build of the HTTP and codec tests.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
bash "$root/scripts/setup.sh"
bash "$root/scripts/build.sh"
ctest --test-dir "${SOFTGRASP_BUILD_DIR:-$root/build}" -j "$(nproc)" --output-on-failure

# The code that reads bytes from outside, once more under AddressSanitizer + UBSan.
SOFTGRASP_BUILD_DIR="$root/build-asan" bash "$root/scripts/build.sh" \
  -DSOFTGRASP_SANITIZER=address,undefined -DSOFTGRASP_BUILD_BENCHMARKS=OFF
ctest --test-dir "$root/build-asan" -j "$(nproc)" --output-on-failure -L 'http|io|fuzz'
