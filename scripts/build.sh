#!/usr/bin/env bash
# Configures and builds softgrasp into build/ (ccache-friendly; no -march=native), then bundles the
# web page into <build>/web (npm ci from web/package-lock.json when it changed, then esbuild).
# Extra arguments go to the CMake configure step; SOFTGRASP_TARGETS="a b" builds only those;
# SOFTGRASP_WEB=0 skips the page (e.g. the sanitizer pass, which serves no page).
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

if [ "${SOFTGRASP_WEB:-1}" != "0" ]; then
  web="$root/web"
  # npm ci only when the lock file changed since the last install (it wipes node_modules).
  stamp="$web/node_modules/.softgrasp-lock.sha256"
  lock_hash="$(sha256sum "$web/package-lock.json" | cut -d' ' -f1)"
  if [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$lock_hash" ]; then
    (cd "$web" && npm ci --no-audit --no-fund --loglevel=error)
    echo "$lock_hash" > "$stamp"
  fi
  node "$web/build.mjs" --outdir "$build/web"
fi
