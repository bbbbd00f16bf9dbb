# Container hosts for the container-based integration tests (sourced by the *_test.sh files next
# to it). Each image's root filesystem runs as a separate host: a buildah working container gives
# a copy-on-write root filesystem, a network namespace with one veth on a bridge gives it an
# address, and the program runs chrooted into it as the image's user, with the image's entry
# point and environment, in its own mount and PID namespaces (enter.sh). Host names resolve like
# compose service names (an /etc/hosts in every host). Namespaces without an image (the client,
# the balancer) run the machine's own programs and get /etc/netns/<ns>/hosts (ip-netns(8)).
# Everything is removed on exit. Needs root. docs/containers.md.
#
#   ct_init                          bridge and state; call first (sets an EXIT trap)
#   ct_host NAME [IMAGE]             a host NAME (with IMAGE: its root filesystem)
#   ct_hosts_done                    writes every host's hosts file (after the last ct_host)
#   ct_start NAME [-e K=V]... [-v HOST:PATH]... [-- ARGS...]
#                                    runs the image's entry point with ARGS (else its CMD)
#   ct_daemon NAME CMD...            runs a machine program in NAME's namespace in the background
#   ct_stop NAME [SIGNAL]            SIGTERM (default) or SIGKILL to the program, then waits
#                                    (SIGKILL: the whole container, as docker kill)
#   ct_in NAME CMD...                runs a machine command in NAME's network namespace
#   ct_ip NAME                       NAME's address
#   ct_log NAME                      path of NAME's combined output
# shellcheck shell=bash

CT_DIR="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
declare -A CT_NS=() CT_IP=() CT_IMAGE=() CT_ROOT=() CT_CONTAINER=() CT_PID=()
CT_NAMES=()
CT_WORK=""
CT_BRIDGE=""
CT_SUBNET=""

ct_fail() {
  echo "${CT_TEST:-container test}: FAIL: $*" >&2
  exit 1
}
ct_log_line() { echo "${CT_TEST:-container test}: $*" >&2; }

ct_cleanup() {
  local code=$? name pid
  set +e  # tear everything down whatever fails (a killed program's wait status is not an error)
  for name in "${CT_NAMES[@]}"; do
    pid="${CT_PID[$name]:-}"
    [ -n "$pid" ] || continue
    [ -n "${CT_ROOT[$name]:-}" ] && kill -KILL "$(ct_main_pid "$name")" 2>/dev/null
    kill -KILL "$pid" 2>/dev/null
  done
  for name in "${CT_NAMES[@]}"; do
    pid="${CT_PID[$name]:-}"
    [ -n "$pid" ] && wait "$pid" 2>/dev/null
  done
  if [ "$code" -ne 0 ]; then
    for name in "${CT_NAMES[@]}"; do
      [ -s "$CT_WORK/$name.log" ] && { echo "---- $name (last 30 lines)" >&2; tail -n 30 "$CT_WORK/$name.log" >&2; }
    done
  fi
  for name in "${CT_NAMES[@]}"; do
    ip netns del "${CT_NS[$name]}" 2>/dev/null
    rm -rf "/etc/netns/${CT_NS[$name]}"
    [ -n "${CT_CONTAINER[$name]:-}" ] && buildah rm "${CT_CONTAINER[$name]}" >/dev/null 2>&1
  done
  [ -n "$CT_BRIDGE" ] && ip link del "$CT_BRIDGE" 2>/dev/null
  [ -n "$CT_WORK" ] && rm -rf "$CT_WORK"
  exit "$code"
}

ct_init() {
  if [ "${SOFTGRASP_CONTAINERS_SKIP:-0}" = 1 ]; then
    ct_log_line "SKIPPED on purpose (SOFTGRASP_CONTAINERS_SKIP=1)"
    exit 77
  fi
  [ "$(id -u)" -eq 0 ] || ct_fail "needs root (namespaces, chroot, buildah); SOFTGRASP_CONTAINERS_SKIP=1 skips it"
  local tool
  for tool in buildah ip unshare chroot curl jq; do
    command -v "$tool" >/dev/null || ct_fail "$tool is missing: run scripts/setup.sh"
  done
  CT_WORK="$(mktemp -d /tmp/softgrasp-containers.XXXXXX)"
  trap ct_cleanup EXIT
  trap 'exit 130' INT TERM
  # A /24 of 10.231.0.0/16 per run, so runs on one machine do not collide.
  CT_SUBNET="10.231.$(($$ % 250 + 1))"
  CT_BRIDGE="sgct$$"
  ip link add "$CT_BRIDGE" type bridge || ct_fail "ip link add bridge"
  ip link set "$CT_BRIDGE" up
}

ct_host() {
  local name="$1" image="${2:-}" index ns veth
  index=$((${#CT_NAMES[@]} + 2))
  ns="sgct$$-$name"
  veth="sgv$$x$index"
  CT_NAMES+=("$name")
  CT_NS[$name]="$ns"
  CT_IP[$name]="$CT_SUBNET.$index"
  ip netns add "$ns" || ct_fail "ip netns add $ns"
  ip link add "$veth" type veth peer name "eth0" netns "$ns" || ct_fail "veth for $name"
  ip link set "$veth" master "$CT_BRIDGE"
  ip link set "$veth" up
  ip -n "$ns" addr add "${CT_IP[$name]}/24" dev eth0
  ip -n "$ns" link set lo up
  ip -n "$ns" link set eth0 up
  # DDS discovery uses multicast when allowed: without a route, joining the group fails.
  ip -n "$ns" route add 224.0.0.0/4 dev eth0
  if [ -n "$image" ]; then
    buildah inspect --type image "$image" >/dev/null 2>&1 ||
      ct_fail "image $image not found: build it with scripts/images.sh"
    CT_IMAGE[$name]="$image"
    CT_CONTAINER[$name]="$(buildah from --pull=false --name "sgct$$-$name" "$image")" ||
      ct_fail "buildah from $image"
    CT_ROOT[$name]="$(buildah mount "${CT_CONTAINER[$name]}")" || ct_fail "buildah mount $image"
  fi
}

ct_hosts_done() {
  local hosts="$CT_WORK/hosts" name
  printf '127.0.0.1 localhost\n::1 localhost\n' >"$hosts"
  for name in "${CT_NAMES[@]}"; do echo "${CT_IP[$name]} $name" >>"$hosts"; done
  for name in "${CT_NAMES[@]}"; do
    if [ -n "${CT_ROOT[$name]:-}" ]; then
      cp "$hosts" "${CT_ROOT[$name]}/etc/hosts"
      echo "$name" >"${CT_ROOT[$name]}/etc/hostname"
    else
      mkdir -p "/etc/netns/${CT_NS[$name]}"
      cp "$hosts" "/etc/netns/${CT_NS[$name]}/hosts"
    fi
  done
}

ct_ip() { echo "${CT_IP[$1]}"; }
ct_log() { echo "$CT_WORK/$1.log"; }
ct_in() {
  local name="$1"
  shift
  ip netns exec "${CT_NS[$name]}" "$@"
}

# uid:gid of USER (a name or a number, optionally NAME:GROUP) in the root filesystem ROOT.
ct_user_ids() {
  local root="$1" user="${2:-root}" uid gid
  [ -n "$user" ] || user=root
  case "$user" in
    *:*) ct_fail "USER with a group ($user) is not supported by these tests" ;;
  esac
  if [[ "$user" =~ ^[0-9]+$ ]]; then
    uid="$user"
    gid="$(awk -F: -v u="$user" '$3 == u {print $4; exit}' "$root/etc/passwd")"
  else
    uid="$(awk -F: -v u="$user" '$1 == u {print $3; exit}' "$root/etc/passwd")"
    gid="$(awk -F: -v u="$user" '$1 == u {print $4; exit}' "$root/etc/passwd")"
  fi
  [ -n "$uid" ] || ct_fail "user $user is not in the image"
  echo "$uid:${gid:-$uid}"
}

ct_start() {
  local name="$1"
  shift
  local root="${CT_ROOT[$name]:-}" config envs=() vols=() args=() have_args=0 user workdir
  [ -n "$root" ] || ct_fail "ct_start $name: not an image host"
  while [ $# -gt 0 ]; do
    case "$1" in
      -e) envs+=("$2"); shift 2 ;;
      -v) vols+=("${2%%:*}" "${2#*:}"); shift 2 ;;
      --) shift; args=("$@"); have_args=1; break ;;
      *) ct_fail "ct_start: unknown option $1" ;;
    esac
  done
  config="$(buildah inspect --type image "${CT_IMAGE[$name]}" | jq '.OCIv1.config')"
  local image_env=() entry=() cmd=()
  mapfile -t image_env < <(jq -r '.Env // [] | .[]' <<<"$config")
  mapfile -t entry < <(jq -r '.Entrypoint // [] | .[]' <<<"$config")
  mapfile -t cmd < <(jq -r '.Cmd // [] | .[]' <<<"$config")
  [ "$have_args" = 1 ] || args=("${cmd[@]}")
  user="$(ct_user_ids "$root" "$(jq -r '.User // ""' <<<"$config")")"
  workdir="$(jq -r '.WorkingDir // "/"' <<<"$config")"
  [ -n "$workdir" ] || workdir=/
  local all_env=("${image_env[@]}" "HOSTNAME=$name" "${envs[@]}")
  ip netns exec "${CT_NS[$name]}" unshare --mount --pid --fork --kill-child --propagation private \
    bash "$CT_DIR/enter.sh" "$root" "$user" "$workdir" $((${#vols[@]} / 2)) "${vols[@]}" \
    "${#all_env[@]}" "${all_env[@]}" -- "${entry[@]}" "${args[@]}" >>"$CT_WORK/$name.log" 2>&1 &
  CT_PID[$name]=$!
}

ct_daemon() {
  local name="$1"
  shift
  ip netns exec "${CT_NS[$name]}" "$@" >>"$CT_WORK/$name.log" 2>&1 &
  CT_PID[$name]=$!
}

# The program's own pid (the child of unshare, PID 1 of the container's PID namespace).
ct_main_pid() { pgrep -P "${CT_PID[$1]}" | head -n 1; }

ct_stop() {
  local name="$1" signal="${2:-TERM}" pid="${CT_PID[$1]:-}" child
  [ -n "$pid" ] || return 0
  if [ -z "${CT_ROOT[$name]:-}" ]; then
    kill "-$signal" "$pid" 2>/dev/null || true  # a machine program (ct_daemon)
  else
    # The program is PID 1 of the container's PID namespace: when it dies, the kernel kills
    # everything else in it, as `docker kill` does. (Killing unshare would not do: the program
    # changed its user, which clears the parent-death signal --kill-child relies on.)
    child="$(ct_main_pid "$name")"
    [ -n "$child" ] && { kill "-$signal" "$child" 2>/dev/null || true; }
  fi
  local _
  for _ in $(seq 100); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
  kill -KILL "$pid" 2>/dev/null || true
  wait "$pid" 2>/dev/null || true
  CT_PID[$name]=""
  return 0
}

# Waits until URL answers 2xx from NAME's namespace, or fails after SECONDS (default 60).
ct_wait_http() {
  local name="$1" url="$2" seconds="${3:-60}" _
  for _ in $(seq $((seconds * 5))); do
    ct_in "$name" curl -fsS -m 2 -o /dev/null "$url" 2>/dev/null && return 0
    sleep 0.2
  done
  ct_fail "$url did not answer from $name within $seconds s"
}
