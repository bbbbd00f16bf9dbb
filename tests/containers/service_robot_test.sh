#!/usr/bin/env bash
# The service and the simulated robot from their images, as two hosts (plus a client host) on one
# bridge, named like compose services: detect -> forward over DDS across hosts -> result. The
# service's robot journal is a host folder mounted into its container; the service container is
# killed (SIGKILL) right after it accepted a command and started again on the same folder: the
# command must still reach a final state with the robot's result, executed exactly once (the
# robot's log names each command it runs), and a retry of the same id must not move the robot
# again. The image's health check must pass. docs/containers.md.
#
# usage: service_robot_test.sh   (needs root and the images of scripts/images.sh)
set -euo pipefail
CT_TEST=service_robot_test
# shellcheck source=lib.sh
source "$(dirname "$0")/lib.sh"
tag="${SOFTGRASP_IMAGE_TAG:-latest}"

ct_init
ct_host robot "localhost/softgrasp-robot:$tag"
ct_host service "localhost/softgrasp-service:$tag"
ct_host client
ct_hosts_done

domain=131
token="containers-$$-$RANDOM$RANDOM"
robot_id="sim-containers"
# Cyclone: eth0 only, unicast discovery of the other host by its name.
dds_config() {
  echo "<CycloneDDS><Domain id=\"any\"><General><Interfaces><NetworkInterface name=\"eth0\"/></Interfaces><AllowMulticast>false</AllowMulticast></General><Discovery><ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>30</MaxAutoParticipantIndex><Peers><Peer address=\"$1\"/></Peers><LeaseDuration>2 s</LeaseDuration></Discovery></Domain></CycloneDDS>"
}
journal="$CT_WORK/journal"
mkdir -p "$journal"
chown 10001:10001 "$journal"  # the images' softgrasp user

ct_start robot -- --scene-seed 3 --objects 8 --support table --noise on --robot-id "$robot_id" \
  --domain "$domain" --dds-config "$(dds_config service)"
start_service() {
  ct_start service -e "SOFTGRASP_ROBOT_TOKENS=$token" -e "SOFTGRASP_ROBOT_DOMAIN_ID=$domain" \
    -e "SOFTGRASP_ROBOT_DDS_CONFIG=$(dds_config robot)" -e SOFTGRASP_ROBOT_COMMAND_TIMEOUT_S=30 \
    -v "$journal:/var/lib/softgrasp/robot-journal"
}
start_service
ct_wait_http client http://robot:8081/scene.json 60
ct_wait_http client http://service:8080/healthz 60
get() { ct_in client curl -sS -m 20 "$@"; }
auth=(-H "Authorization: Bearer $token")

# The image's own health check, run in the service container's file system and network.
health="$(buildah inspect --type image "localhost/softgrasp-service:$tag" | jq '.Docker.config.Healthcheck')"
[ "$(jq -r '.Test[0]' <<<"$health")" = CMD-SHELL ] || ct_fail "the service image has no shell health check: $health"
ct_in service chroot --userspec=10001:10001 "${CT_ROOT[service]}" /bin/sh -c "$(jq -r '.Test[1]' <<<"$health")" ||
  ct_fail "the service image's health check failed: $(jq -r '.Test[1]' <<<"$health")"

wait_robot() {
  local robots _
  for _ in $(seq 150); do
    robots="$(get http://service:8080/v1/robot)"
    [ "$(jq -r --arg id "$robot_id" '[.robots[] | select(.robot_id == $id and .alive)] | length' <<<"$robots")" = 1 ] && return 0
    sleep 0.2
  done
  ct_fail "the service does not see the robot over DDS: $robots"
}
wait_robot
ct_log_line "the service (service:8080) sees robot '$robot_id' on robot over DDS"

get http://robot:8081/depth.npy -o "$CT_WORK/depth.npy"
get http://robot:8081/camera.intr -o "$CT_WORK/camera.intr"
get -F "depth=@$CT_WORK/depth.npy" -F "intrinsics=@$CT_WORK/camera.intr" -F top_k=5 \
  http://service:8080/v1/grasps -o "$CT_WORK/grasps.json"
count="$(jq '.grasps | length' "$CT_WORK/grasps.json")"
[ "$count" -ge 1 ] || ct_fail "POST /v1/grasps found no grasp: $(head -c 400 "$CT_WORK/grasps.json")"

# Runs of command ID on the robot (its log has one "command ID: outcome" line per execution).
runs() { grep -c "\] command $1: " "$(ct_log robot)" || true; }
post() {
  get -o "$CT_WORK/post.json" -w '%{http_code}' -X POST "${auth[@]}" -H 'Content-Type: application/json' \
    -d "$2" "http://service:8080/v1/robot/grasps"
}
wait_final() {
  local id="$1" state="" _
  for _ in $(seq 300); do
    get "${auth[@]}" "http://service:8080/v1/robot/grasps/$id" -o "$CT_WORK/command.json" 2>/dev/null || true
    state="$(jq -r '.state // empty' "$CT_WORK/command.json" 2>/dev/null || true)"
    case "$state" in succeeded | failed | rejected | timed_out) echo "$state"; return 0 ;; esac
    sleep 0.1
  done
  ct_fail "command $id did not reach a final state: $(cat "$CT_WORK/command.json" 2>/dev/null)"
}

# Accepted, then the service container is killed at once and started again on the same journal.
id="containers-$$-killed"
body="$(jq -c --arg id "$id" '.grasps[0] + {id: $id}' "$CT_WORK/grasps.json")"
status="$(post "$id" "$body")"
[ "$status" = 202 ] || ct_fail "POST /v1/robot/grasps answered $status: $(cat "$CT_WORK/post.json")"
ct_stop service KILL
! ct_in client curl -s -m 2 -o /dev/null http://service:8080/healthz || ct_fail "the killed service still answers"
ct_log_line "service killed (SIGKILL) right after it accepted $id; robot runs of it so far: $(runs "$id")"
start_service
ct_wait_http client http://service:8080/healthz 60
state="$(wait_final "$id")"
[ "$state" = succeeded ] || [ "$state" = failed ] ||
  ct_fail "after the restart, $id ended '$state', not with the robot's result: $(cat "$CT_WORK/command.json")"
jq -e '.result.robot_id == "'"$robot_id"'" and (.result.reason | length > 0)' "$CT_WORK/command.json" >/dev/null ||
  ct_fail "$id has no robot result: $(cat "$CT_WORK/command.json")"
ct_log_line "after the restart: $id $state ($(jq -c '{outcome: .result.outcome, reason: .result.reason}' "$CT_WORK/command.json"))"

# The same id again: the recorded command, not a new one; then a new id proves the robot is
# past any repeat (one writer's commands arrive in order), and the first ran exactly once.
status="$(post "$id" "$body")"
case "$status" in 200 | 202) ;; *) ct_fail "a retry of $id answered $status: $(cat "$CT_WORK/post.json")" ;; esac
next="containers-$$-next"
body_next="$(jq -c --arg id "$next" '.grasps[1 % length] + {id: $id}' "$CT_WORK/grasps.json")"
status="$(post "$next" "$body_next")"
[ "$status" = 202 ] || ct_fail "POST of $next answered $status: $(cat "$CT_WORK/post.json")"
wait_final "$next" >/dev/null
[ "$(runs "$id")" = 1 ] || ct_fail "the robot ran $id $(runs "$id") times, not once"
[ "$(runs "$next")" = 1 ] || ct_fail "the robot ran $next $(runs "$next") times, not once"
ct_log_line "PASS: detect -> forward -> result across hosts; $id ran once through a SIGKILL of the service"
