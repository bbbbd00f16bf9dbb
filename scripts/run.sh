#!/usr/bin/env bash
# Quick start: installs what is missing, builds, and serves on http://127.0.0.1:8080 with a
# SIMULATED robot attached (docs/sim-robot.md), so a grasp can be forwarded at once.
# Arguments go to softgrasp-server (e.g. --port 9000, --config FILE).
#
# The simulated robot: `softgrasp-sim robot` in the background, its scene views on
# http://127.0.0.1:8081, DDS on loopback only (domain SOFTGRASP_ROBOT_DOMAIN_ID, default 42).
# Robot token: SOFTGRASP_ROBOT_TOKENS if set, else one is generated and printed once.
# SOFTGRASP_SIM_ROBOT=0: no simulated robot (robot endpoints still on if tokens are given).
# SOFTGRASP_SIM_ROBOT_ARGS: extra arguments for the robot, e.g. "--scene-seed 7 --objects 3-5".
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
bash "$root/scripts/setup.sh"
bash "$root/scripts/build.sh"
build="${SOFTGRASP_BUILD_DIR:-$root/build}"
server=("$build/service/softgrasp-server" --host 127.0.0.1 --port 8080 "$@")

if [ "${SOFTGRASP_SIM_ROBOT:-1}" = "0" ]; then
  exec "${server[@]}"
fi

# One loopback-only Cyclone config for both processes (bridge::LoopbackConfigXml without a tag):
# the 127.0.0.1 interface, no multicast, unicast discovery to this host.
export SOFTGRASP_ROBOT_DOMAIN_ID="${SOFTGRASP_ROBOT_DOMAIN_ID:-42}"
export SOFTGRASP_ROBOT_DDS_CONFIG="${SOFTGRASP_ROBOT_DDS_CONFIG:-<CycloneDDS><Domain id=\"any\"><General><Interfaces><NetworkInterface address=\"127.0.0.1\"/></Interfaces><AllowMulticast>false</AllowMulticast></General><Discovery><ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>30</MaxAutoParticipantIndex><Peers><Peer address=\"127.0.0.1\"/></Peers><LeaseDuration>2 s</LeaseDuration></Discovery></Domain></CycloneDDS>}"
if [ -z "${SOFTGRASP_ROBOT_TOKENS:-}" ]; then
  SOFTGRASP_ROBOT_TOKENS="$(head -c 24 /dev/urandom | base64 | tr -d '/+=')"
  export SOFTGRASP_ROBOT_TOKENS
  echo "run: robot token for this run (Authorization: Bearer ...): $SOFTGRASP_ROBOT_TOKENS"
fi

robot_out="$(mktemp /tmp/softgrasp-sim-robot.XXXXXX)"
robot_pid=""
stop_robot() {
  if [ -n "$robot_pid" ] && kill -0 "$robot_pid" 2>/dev/null; then
    kill -TERM "$robot_pid" 2>/dev/null || true
    wait "$robot_pid" 2>/dev/null || true
  fi
  rm -f "$robot_out"
}
trap stop_robot EXIT

echo "run: starting a SIMULATED robot (softgrasp-sim robot) on http://127.0.0.1:8081, DDS domain $SOFTGRASP_ROBOT_DOMAIN_ID (loopback only)"
# shellcheck disable=SC2086  # SOFTGRASP_SIM_ROBOT_ARGS is a list of words on purpose
"$build/sim/softgrasp-sim" robot --support table --robot-id sim-robot \
  --domain "$SOFTGRASP_ROBOT_DOMAIN_ID" --dds-config "$SOFTGRASP_ROBOT_DDS_CONFIG" \
  --http-host 127.0.0.1 --http-port 8081 ${SOFTGRASP_SIM_ROBOT_ARGS:-} > >(tee "$robot_out") &
robot_pid=$!
for _ in $(seq 600); do
  grep -q "listening on" "$robot_out" 2>/dev/null && break
  if ! kill -0 "$robot_pid" 2>/dev/null; then
    echo "run: WARNING: the simulated robot did not start (see above); serving without it" >&2
    robot_pid=""
    break
  fi
  sleep 0.1
done

# Not exec: the trap stops the robot when the server exits (Ctrl-C reaches both).
"${server[@]}"
