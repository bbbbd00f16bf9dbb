#!/usr/bin/env bash
# Prints, one per line and sorted, the Debian packages that hold the shared libraries the given
# executables load (ldd, so indirect ones too). The image's build stage runs it on the binaries
# it built; each runtime stage installs exactly that list, so a runtime image has the libraries
# and none of the -dev packages, compilers or tools the build needed.
#
# usage: runtime-packages.sh EXECUTABLE...
# Fails (exit 1) if a library is missing or belongs to no package.
set -euo pipefail
[ $# -ge 1 ] || { echo "usage: runtime-packages.sh EXECUTABLE..." >&2; exit 2; }

status=0
declare -A libraries=()
for exe in "$@"; do
  [ -x "$exe" ] || { echo "runtime-packages: $exe is not an executable" >&2; exit 1; }
  while read -r line; do
    case "$line" in
      *"=> not found"*)
        echo "runtime-packages: $exe: ${line%% *} not found" >&2
        status=1
        ;;
      *"=> /"*)
        lib="${line#*=> }"
        libraries["${lib%% (*}"]=1
        ;;
    esac
  done < <(ldd "$exe")
done
[ "$status" = 0 ] || exit 1

# Debian 12 merged /usr, but dpkg still records many libraries under /lib: ask for each path as
# ldd gives it, resolved, and each with /usr added or taken away, all in one dpkg query.
candidates() {
  local file="$1" real c
  real="$(readlink -f "$file")"
  for c in "$file" "$real"; do
    echo "$c"
    case "$c" in
      /usr/lib/*) echo "${c#/usr}" ;;
      /lib/*) echo "/usr$c" ;;
    esac
  done
}
declare -A owner=()
mapfile -t all < <(for lib in "${!libraries[@]}"; do candidates "$lib"; done | sort -u)
# "pkg:arch: /path" per owned path; unowned paths only print errors (ignored here).
while IFS= read -r line; do
  owner["${line#*: }"]="$(echo "${line%%: *}" | cut -d: -f1)"
done < <(dpkg -S "${all[@]}" 2>/dev/null || true)

declare -A packages=()
for lib in "${!libraries[@]}"; do
  found=""
  while read -r c; do
    if [ -n "${owner[$c]:-}" ]; then found="${owner[$c]}"; break; fi
  done < <(candidates "$lib")
  if [ -n "$found" ]; then
    packages["$found"]=1
  else
    echo "runtime-packages: $lib belongs to no Debian package" >&2
    status=1
  fi
done
[ "$status" = 0 ] || exit 1
printf '%s\n' "${!packages[@]}" | sort
