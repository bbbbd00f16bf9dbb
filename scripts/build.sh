#!/usr/bin/env bash
# Configures and builds softgrasp into build/ (ccache-friendly; no -march=native).
# Extra arguments go to the CMake configure step; SOFTGRASP_TARGETS="a b" builds only those.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${SOFTGRASP_BUILD_DIR:-$root/build}"
# ccache hits across checkouts in different folders (CI clones afresh each time).
export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$root}"
export CCACHE_NOHASHDIR="${CCACHE_NOHASHDIR:-1}"
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSOFTGRASP_WERROR=ON "$@" >/dev/null
targets=()
for t in ${SOFTGRASP_TARGETS:-}; do targets+=(--target "$t"); done
cmake --build "$build" -j "$(nproc)" "${targets[@]}"
