#!/usr/bin/env bash
# Builds the softgrasp images (service, robot, worker; docker/Dockerfile) with buildah, without a
# Docker engine or a registry: a Debian 12 base is made locally with debootstrap once and tagged
# debian:12, so the Dockerfile's FROM resolves to it. Layers are cached (--layers) and the host's
# ccache is mounted into the build stage, so a rebuild with unchanged sources takes about a
# minute and one after a source change recompiles only what changed. Run as root.
# docs/containers.md.
#
# usage: images.sh [TARGET...]     targets: service robot worker (default: all three)
# env:   SOFTGRASP_IMAGE_TAG       tag of the images (default: latest)
#        SOFTGRASP_BASE_REBUILD=1  make the Debian base again (e.g. for security updates)
#        SOFTGRASP_DEBIAN_MIRROR   default http://deb.debian.org/debian
# Prints one line per image: name, size, seconds it took to build.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(service robot worker)
tag="${SOFTGRASP_IMAGE_TAG:-latest}"
mirror="${SOFTGRASP_DEBIAN_MIRROR:-http://deb.debian.org/debian}"
base=localhost/softgrasp-base:bookworm

for tool in buildah debootstrap; do
  command -v "$tool" >/dev/null || { echo "images: $tool is missing: run scripts/setup.sh" >&2; exit 1; }
done
[ "$(id -u)" -eq 0 ] || { echo "images: run as root (buildah and debootstrap need it here)" >&2; exit 1; }
for t in "${targets[@]}"; do
  case "$t" in service | robot | worker) ;; *) echo "images: unknown target '$t'" >&2; exit 2 ;; esac
done

log() { echo "images: $*" >&2; }

# ---- the base: Debian 12 minbase from the archive, with updates and security sources ----------
if [ "${SOFTGRASP_BASE_REBUILD:-0}" = 1 ] || ! buildah inspect --type image "$base" >/dev/null 2>&1; then
  work="$(mktemp -d /tmp/softgrasp-base.XXXXXX)"
  trap 'rm -rf "$work"' EXIT
  log "making the Debian 12 base with debootstrap ($mirror)"
  started=$SECONDS
  debootstrap --variant=minbase bookworm "$work/rootfs" "$mirror" >"$work/debootstrap.log" 2>&1 || {
    tail -n 20 "$work/debootstrap.log" >&2
    echo "images: debootstrap failed" >&2
    exit 1
  }
  cat >"$work/rootfs/etc/apt/sources.list" <<SOURCES
deb $mirror bookworm main
deb $mirror bookworm-updates main
deb http://deb.debian.org/debian-security bookworm-security main
SOURCES
  rm -rf "$work/rootfs/var/cache/apt/archives/"*.deb "$work/rootfs/var/lib/apt/lists/"*
  container="$(buildah from scratch)"
  buildah copy --quiet "$container" "$work/rootfs" / >/dev/null
  buildah config --env PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin \
    --cmd /bin/bash \
    --label org.opencontainers.image.description="Debian 12 minbase made by scripts/images.sh" \
    "$container"
  buildah commit --quiet --rm "$container" "$base" >/dev/null
  rm -rf "$work"
  trap - EXIT
  log "base made in $((SECONDS - started)) s"
fi
# FROM debian:12 in the Dockerfile resolves to the local base; nothing is pulled.
buildah tag "$base" docker.io/library/debian:12

ccache_dir="$(ccache -k cache_dir 2>/dev/null || true)"
[ -n "$ccache_dir" ] || ccache_dir="${HOME:-/root}/.cache/ccache"
mkdir -p "$ccache_dir"

# ccache's keys include these variables: the build stage sets the same ones (docker/Dockerfile).
host_locale=""
for v in LANG LC_ALL LC_CTYPE LC_MESSAGES; do
  [ -n "${!v+set}" ] && host_locale+="$v=${!v} "
done

# The host's CA bundle, for npm in the build stage behind a TLS-inspecting proxy.
certs=()
[ -s /etc/ssl/certs/ca-certificates.crt ] && certs=(--volume /etc/ssl/certs:/host-certs:ro)

for t in "${targets[@]}"; do
  started=$SECONDS
  log "building localhost/softgrasp-$t:$tag"
  buildah bud --quiet --isolation chroot --pull=false --layers --format docker \
    --volume "$ccache_dir:/ccache" "${certs[@]}" --build-arg HOST_LOCALE="$host_locale" \
    -f "$root/docker/Dockerfile" --target "$t" -t "localhost/softgrasp-$t:$tag" "$root" >/dev/null
  size="$(buildah images --noheading --format '{{.Size}}' "localhost/softgrasp-$t:$tag" | head -n 1)"
  echo "localhost/softgrasp-$t:$tag size=\"$size\" build_s=$((SECONDS - started))"
done
