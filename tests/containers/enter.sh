#!/usr/bin/env bash
# Runs one program of an image's root filesystem as a container would: called by lib.sh inside a
# fresh mount and PID namespace (unshare) in the host's network namespace. Mounts /proc, /dev, a
# private /tmp and the volumes into the root filesystem (all private to this mount namespace, so
# nothing leaks to the machine), then chroots as the image's user and execs the program with only
# the given environment, in the image's working folder.
#
# usage: enter.sh ROOTFS UID:GID WORKDIR NVOL [HOST CONTAINER]... NENV [K=V]... -- ARGV...
set -euo pipefail
rootfs="$1" user="$2" workdir="$3"
shift 3
nvol="$1"
shift
mount -t proc proc "$rootfs/proc"
mount --rbind /dev "$rootfs/dev"
mount -t tmpfs -o mode=1777 tmpfs "$rootfs/tmp"
for _ in $(seq "$nvol"); do
  mkdir -p "$rootfs$2"
  mount --bind "$1" "$rootfs$2"
  shift 2
done
nenv="$1"
shift
envs=()
for _ in $(seq "$nenv"); do
  envs+=("$1")
  shift
done
[ "$1" = "--" ] && shift
exec chroot --userspec="$user" "$rootfs" /usr/bin/env -i "${envs[@]}" \
  /bin/sh -c 'cd "$0" && exec "$@"' "$workdir" "$@"
