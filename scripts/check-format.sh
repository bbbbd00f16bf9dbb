#!/usr/bin/env bash
# Fails when a C++ source or header tracked by git is not formatted as .clang-format says (the
# idlc-generated DDS types under api/generated are left as generated). Fix: clang-format -i FILE.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
cd "$root"
mapfile -t files < <(git ls-files '*.cpp' '*.h' | grep -v '^api/generated/')
unformatted=()
for f in "${files[@]}"; do
  clang-format --dry-run --Werror "$f" >/dev/null 2>&1 || unformatted+=("$f")
done
if [ ${#unformatted[@]} -gt 0 ]; then
  echo "check-format: ${#unformatted[@]} of ${#files[@]} files are not clang-format clean:" >&2
  printf '  %s\n' "${unformatted[@]}" >&2
  echo "check-format: run clang-format -i on them" >&2
  exit 1
fi
echo "check-format: ${#files[@]} files clean"
