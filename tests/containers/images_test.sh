#!/usr/bin/env bash
# What the three images of scripts/images.sh hold: each runtime image has every shared library
# its programs load and nothing of the build (no compiler, no -dev package, no browser), runs as
# the non-root user softgrasp (uid 10001), and its program starts (--help); the service image has
# the page, the three shipped models and a health check. Prints each image's size on disk.
# docs/containers.md.
#
# usage: images_test.sh   (needs root and the images)
set -euo pipefail
CT_TEST=images_test
# shellcheck source=lib.sh
source "$(dirname "$0")/lib.sh"
tag="${SOFTGRASP_IMAGE_TAG:-latest}"
ct_init

declare -A programs=(
  [service]="/usr/local/bin/softgrasp-server"
  [robot]="/usr/local/bin/softgrasp-sim"
  [worker]="/usr/local/bin/softgrasp-sim /usr/local/bin/softgrasp-train"
)
for name in service robot worker; do
  image="localhost/softgrasp-$name:$tag"
  ct_host "$name" "$image"
  root="${CT_ROOT[$name]}"
  config="$(buildah inspect --type image "$image" | jq '.OCIv1.config')"

  [ "$(jq -r '.User' <<<"$config")" = softgrasp ] || ct_fail "$image does not run as softgrasp: $config"
  [ "$(ct_user_ids "$root" softgrasp)" = 10001:10001 ] || ct_fail "$image: softgrasp is not uid 10001"

  for tool in gcc g++ cc c++ cpp clang ld as make cmake ninja chromium node npm; do
    for dir in usr/bin usr/local/bin; do
      [ ! -e "$root/$dir/$tool" ] || ct_fail "$image carries a build tool or browser: /$dir/$tool"
    done
  done
  dev="$(chroot "$root" dpkg-query -W -f '${Package}\n' | grep -E -- '-dev(:|$)' || true)"
  [ -z "$dev" ] || ct_fail "$image carries -dev packages: $(echo "$dev" | tr '\n' ' ')"
  for exe in ${programs[$name]}; do
    missing="$(chroot "$root" ldd "$exe" | grep 'not found' || true)"
    [ -z "$missing" ] || ct_fail "$image: $exe misses libraries: $missing"
    chroot --userspec=10001:10001 "$root" "$exe" --help >/dev/null 2>&1 ||
      ct_fail "$image: $exe --help failed"
  done
  size_mb="$(du -sm --apparent-size "$root" | cut -f1)"
  packages="$(chroot "$root" dpkg-query -W -f '${Package}\n' | wc -l)"
  ct_log_line "$image: $size_mb MB on disk, $packages Debian packages"
done

root="${CT_ROOT[service]}"
for f in web/index.html models/pix2stiffness.pt models/segmentation.pt models/gqcnn.pt; do
  [ -s "$root/usr/local/share/softgrasp/$f" ] || ct_fail "the service image lacks /usr/local/share/softgrasp/$f"
done
health="$(buildah inspect --type image "localhost/softgrasp-service:$tag" | jq '.Docker.config.Healthcheck')"
jq -e '.Test[0] == "CMD-SHELL" and (.Test[1] | test("/healthz"))' <<<"$health" >/dev/null ||
  ct_fail "the service image has no /healthz health check: $health"
ct_log_line "PASS"
