#!/usr/bin/env bash
# Offline checks of the container files: docker/Dockerfile passes dockerfilelint (npm, pinned in
# docker/lint; installed on first use) with docker/.dockerfilelintrc, and a planted bad line is
# caught (so the linter really runs); docker/haproxy.cfg passes `haproxy -c`; the compose file
# names the services the container tests run. No root, no images needed. docs/containers.md.
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
fail() {
  echo "lint_test: FAIL: $*" >&2
  exit 1
}
lint="$root/docker/lint"
stamp="$lint/node_modules/.softgrasp-lock.sha256"
lock_hash="$(sha256sum "$lint/package-lock.json" | cut -d' ' -f1)"
if [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$lock_hash" ]; then
  (cd "$lint" && npm ci --no-audit --no-fund --loglevel=error) || fail "npm ci in docker/lint"
  echo "$lock_hash" >"$stamp"
fi
dockerfilelint="$lint/node_modules/.bin/dockerfilelint"

# Its exit code is the number of issues.
"$dockerfilelint" -c "$root/docker" "$root/docker/Dockerfile" >&2 || fail "docker/Dockerfile has lint issues (above)"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
{ cat "$root/docker/Dockerfile"; echo "RUN apt-get update && apt-get install -y curl"; } >"$work/Dockerfile"
if "$dockerfilelint" -c "$root/docker" "$work/Dockerfile" >/dev/null; then
  fail "dockerfilelint did not catch an install without --no-install-recommends"
fi

command -v haproxy >/dev/null || fail "haproxy is missing: run scripts/setup.sh"
haproxy -c -q -f "$root/docker/haproxy.cfg" || fail "docker/haproxy.cfg does not pass haproxy -c"

services="$(awk '/^services:/ {s = 1; next} s && /^[a-z]/ {s = 0} s && /^  [a-z0-9-]+:$/ {sub(":", ""); print $1}' \
  "$root/docker/compose.yaml" | sort | tr '\n' ' ')"
[ "$services" = "balancer robot service-1 service-2 worker " ] ||
  fail "docker/compose.yaml services are '$services'"
for name in service-1 service-2; do
  grep -q "server $name $name:8080" "$root/docker/haproxy.cfg" || fail "haproxy.cfg does not balance $name"
done
echo "lint_test: PASS" >&2
