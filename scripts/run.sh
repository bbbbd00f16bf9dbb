#!/usr/bin/env bash
# Quick start: installs what is missing, builds, and serves on http://127.0.0.1:8080.
# Arguments go to softgrasp-server (e.g. --port 9000, --config FILE).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
bash "$root/scripts/setup.sh"
bash "$root/scripts/build.sh"
exec "${SOFTGRASP_BUILD_DIR:-$root/build}/service/softgrasp-server" --host 127.0.0.1 --port 8080 "$@"
