#!/usr/bin/env bash
# Two service replicas from the service image behind HAProxy (the machine's, in its own
# namespace), one simulated robot from its image, and a client host, named like compose
# services (docker/compose.yaml describes the same topology):
#  1. requests per second through the balancer with two replicas and with one (wrk, small
#     GET /v1/info and whole POST /v1/grasps requests);
#  2. a load run through the balancer while service-1 is killed (SIGKILL) and started again,
#     with robot commands sent through the balancer all along: clients see no error for these
#     idempotent requests (HAProxy retries what a dead replica dropped), and every accepted
#     command reaches a final state with the robot's result and runs on the robot exactly once;
#  3. the same command id sent to both replicas directly moves the robot once, and both answer
#     the robot's result.
# Figures go to stderr as "replicas_test: ..." lines (docs/containers.md quotes them).
#
# usage: replicas_test.sh   (needs root, wrk, haproxy and the images of scripts/images.sh)
set -euo pipefail
CT_TEST=replicas_test
# shellcheck source=lib.sh
source "$(dirname "$0")/lib.sh"
tag="${SOFTGRASP_IMAGE_TAG:-latest}"
for tool in haproxy wrk; do
  command -v "$tool" >/dev/null || ct_fail "$tool is missing: run scripts/setup.sh"
done
load_s="${SOFTGRASP_REPLICAS_LOAD_S:-12}"

ct_init
ct_host robot "localhost/softgrasp-robot:$tag"
ct_host service-1 "localhost/softgrasp-service:$tag"
ct_host service-2 "localhost/softgrasp-service:$tag"
ct_host balancer
ct_host client
ct_hosts_done

domain=132
token="replicas-$$-$RANDOM$RANDOM"
robot_id="sim-replicas"
dds_config() {
  local peers="" p
  for p in "$@"; do peers+="<Peer address=\"$p\"/>"; done
  echo "<CycloneDDS><Domain id=\"any\"><General><Interfaces><NetworkInterface name=\"eth0\"/></Interfaces><AllowMulticast>false</AllowMulticast></General><Discovery><ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>30</MaxAutoParticipantIndex><Peers>$peers</Peers><LeaseDuration>2 s</LeaseDuration></Discovery></Domain></CycloneDDS>"
}

ct_start robot -- --scene-seed 5 --objects 8 --support table --noise on --robot-id "$robot_id" \
  --domain "$domain" --dds-config "$(dds_config service-1 service-2)"
start_service() {
  local name="$1"
  mkdir -p "$CT_WORK/journal-$name"
  chown 10001:10001 "$CT_WORK/journal-$name"
  ct_start "$name" -e "SOFTGRASP_ROBOT_TOKENS=$token" -e "SOFTGRASP_ROBOT_DOMAIN_ID=$domain" \
    -e "SOFTGRASP_ROBOT_DDS_CONFIG=$(dds_config robot)" -e SOFTGRASP_ROBOT_COMMAND_TIMEOUT_S=60 \
    -v "$CT_WORK/journal-$name:/var/lib/softgrasp/robot-journal"
}
start_service service-1
start_service service-2

# The balancer: docker/haproxy.cfg, as compose uses it.
cp "$CT_DIR/../../docker/haproxy.cfg" "$CT_WORK/haproxy.cfg"
ct_wait_http client http://service-1:8080/healthz 60
ct_wait_http client http://service-2:8080/healthz 60
ct_daemon balancer haproxy -db -f "$CT_WORK/haproxy.cfg"
ct_wait_http client http://balancer:8080/healthz 30
ct_wait_http client http://robot:8081/scene.json 60
get() { ct_in client curl -sS -m 30 "$@"; }
auth=(-H "Authorization: Bearer $token")

# Both replicas hear the robot.
for name in service-1 service-2; do
  for _ in $(seq 150); do
    [ "$(get "http://$name:8080/v1/robot" | jq --arg id "$robot_id" '[.robots[] | select(.robot_id == $id and .alive)] | length')" = 1 ] && break
    sleep 0.2
  done
  [ "$(get "http://$name:8080/v1/robot" | jq --arg id "$robot_id" '[.robots[] | select(.robot_id == $id and .alive)] | length')" = 1 ] ||
    ct_fail "$name does not see the robot over DDS"
done

get http://robot:8081/depth.png -o "$CT_WORK/depth.png"
get -X POST -H 'Content-Type: image/png' --data-binary "@$CT_WORK/depth.png" \
  "http://balancer:8080/v1/grasps?top_k=5" -o "$CT_WORK/grasps.json"
count="$(jq '.grasps | length' "$CT_WORK/grasps.json")"
[ "$count" -ge 1 ] || ct_fail "POST /v1/grasps through the balancer found no grasp: $(head -c 300 "$CT_WORK/grasps.json")"

# wrk: every other request a whole grasp request (the robot's depth PNG), else GET /v1/info.
cat >"$CT_WORK/load.lua" <<'LUA'
local f = assert(io.open(os.getenv("SG_DEPTH_PNG"), "rb"))
local depth = f:read("*a")
f:close()
local n = 0
request = function()
  n = n + 1
  if n % 2 == 0 then return wrk.format("GET", "/v1/info") end
  return wrk.format("POST", "/v1/grasps?top_k=3", {["Content-Type"] = "image/png"}, depth)
end
LUA
# Runs wrk for SECONDS on the balancer; prints "requests rps non2xx socket_errors".
load() {
  local seconds="$1" out
  out="$(ct_in client env SG_DEPTH_PNG="$CT_WORK/depth.png" wrk -t 1 -c 4 -d "${seconds}s" --timeout 10s \
    -s "$CT_WORK/load.lua" http://balancer:8080/)"
  echo "$out" >>"$CT_WORK/wrk.log"
  local requests rps non2xx errors
  requests="$(awk '/requests in/ {print $1}' <<<"$out")"
  rps="$(awk '/Requests\/sec/ {print $2}' <<<"$out")"
  non2xx="$(awk -F': ' '/Non-2xx/ {print $2}' <<<"$out")"
  errors="$(awk '/Socket errors/ {gsub(",", ""); print $4 + $6 + $8 + $10}' <<<"$out")"
  echo "${requests:-0} ${rps:-0} ${non2xx:-0} ${errors:-0}"
}

# ---- 1. throughput with two replicas, then one ------------------------------------------------
read -r _ rps_two non2xx errors <<<"$(load 5)"
[ "$non2xx" = 0 ] && [ "$errors" = 0 ] || ct_fail "load with two replicas: $non2xx non-2xx, $errors socket errors"
ct_stop service-2 TERM
sleep 1.5  # HAProxy marks it down after 2 failed checks 300 ms apart
read -r _ rps_one non2xx errors <<<"$(load 5)"
[ "$non2xx" = 0 ] && [ "$errors" = 0 ] || ct_fail "load with one replica: $non2xx non-2xx, $errors socket errors"
ct_log_line "through the balancer (1:1 GET /v1/info and POST /v1/grasps, 4 connections): two replicas $rps_two req/s, one replica $rps_one req/s"
start_service service-2
ct_wait_http client http://service-2:8080/healthz 60

# ---- 2. kill a replica under load -------------------------------------------------------------
# Robot commands through the balancer, one every 0.25 s; a client retries the same id on any
# error (as clients of an idempotent API do) and counts each error it saw.
commands_log="$CT_WORK/commands.log"
: >"$commands_log"
send_commands() {
  local i id body status attempt
  for i in $(seq 0 $((load_s * 4 - 1))); do
    id="replicas-$$-$i"
    body="$(jq -c --arg id "$id" ".grasps[$((i % count))] + {id: \$id}" "$CT_WORK/grasps.json")"
    for attempt in 1 2 3 4 5; do
      status="$(ct_in client curl -sS -m 10 -o /dev/null -w '%{http_code}' -X POST "${auth[@]}" \
        -H 'Content-Type: application/json' -d "$body" http://balancer:8080/v1/robot/grasps 2>/dev/null || true)"
      echo "$id $attempt $status" >>"$commands_log"
      case "$status" in 200 | 202) break ;; esac
      sleep 0.2
    done
    sleep 0.25
  done
}
send_commands &
sender=$!
(
  sleep "$((load_s / 4))"
  ct_stop service-1 KILL
  ct_in client curl -s -m 2 -o /dev/null http://service-1:8080/healthz || echo "killed" >"$CT_WORK/killed"
  sleep "$((load_s / 3))"
  start_service service-1
  # This subshell's CT_PID is its own copy: hand the new container's process to the script, or
  # the cleanup would kill only the old one and leave this one running.
  echo "${CT_PID[service-1]}" >"$CT_WORK/service-1.pid"
) &
killer=$!
read -r requests _ non2xx errors <<<"$(load "$load_s")"
wait "$killer"
CT_PID[service-1]="$(cat "$CT_WORK/service-1.pid")"
wait "$sender"
[ -f "$CT_WORK/killed" ] || ct_fail "service-1 still answered after it was killed"
ct_wait_http client http://service-1:8080/healthz 60
stats="$(get "http://balancer:8404/stats;csv")"
# Summed over both backends; columns by the CSV header's names (wretr, wredis).
backend_sum() {
  awk -F, -v col="$1" 'NR == 1 {sub("^# ", ""); for (i = 1; i <= NF; i++) if ($i == col) c = i; next}
    $2 == "BACKEND" && ($1 == "services" || $1 == "commands") {s += $c} END {print s + 0}' <<<"$stats"
}
retries="$(backend_sum wretr)"
redispatches="$(backend_sum wredis)"
command_errors="$(awk '$3 != 200 && $3 != 202' "$commands_log" | wc -l)"
ct_log_line "kill run: $requests requests in ${load_s} s through the balancer, $non2xx non-2xx, $errors socket errors; HAProxy retried $retries and redispatched $redispatches; robot commands: $(wc -l <"$commands_log") POSTs, $command_errors client-visible errors"
[ "$non2xx" = 0 ] || ct_fail "clients saw $non2xx non-2xx answers while a replica was killed"
[ "$errors" = 0 ] || ct_fail "clients saw $errors socket errors while a replica was killed"
[ "$command_errors" = 0 ] || ct_fail "robot command POSTs saw errors: $(awk '$3 != 200 && $3 != 202' "$commands_log" | head -5)"

# Every accepted command reaches a final state: ask by sending it again (idempotent; the replica
# that has it answers its record, the other one learns the robot's kept result).
runs() { grep -c "\] command $1: " "$(ct_log robot)" || true; }
final_state() {
  local id="$1" body="$2" state _
  for _ in $(seq 150); do
    state="$(get -X POST "${auth[@]}" -H 'Content-Type: application/json' -d "$body" \
      http://balancer:8080/v1/robot/grasps | jq -r '.state // empty')"
    case "$state" in succeeded | failed | rejected | timed_out) echo "$state"; return 0 ;; esac
    sleep 0.2
  done
  echo "$state"
}
sent="$(awk '{print $1}' "$commands_log" | sort -u)"
n_sent=0
for id in $sent; do
  i="${id##*-}"
  body="$(jq -c --arg id "$id" ".grasps[$((i % count))] + {id: \$id}" "$CT_WORK/grasps.json")"
  state="$(final_state "$id" "$body")"
  case "$state" in succeeded | failed) ;; *) ct_fail "command $id ended '$state', not with a robot result" ;; esac
  [ "$(runs "$id")" = 1 ] || ct_fail "the robot ran $id $(runs "$id") times, not once"
  n_sent=$((n_sent + 1))
done
ct_log_line "all $n_sent accepted commands ended with the robot's result, each run once"

# ---- 3. one id through both replicas ----------------------------------------------------------
id="replicas-$$-both"
body="$(jq -c --arg id "$id" '.grasps[0] + {id: $id}' "$CT_WORK/grasps.json")"
answers=""
for name in service-1 service-2; do
  status="$(get -o "$CT_WORK/post.json" -w '%{http_code}' -X POST "${auth[@]}" -H 'Content-Type: application/json' \
    -d "$body" "http://$name:8080/v1/robot/grasps")"
  [ "$status" = 202 ] || ct_fail "$name answered $status to $id: $(cat "$CT_WORK/post.json")"
  state=""
  for _ in $(seq 150); do
    get "${auth[@]}" "http://$name:8080/v1/robot/grasps/$id" -o "$CT_WORK/command.json"
    state="$(jq -r '.state' "$CT_WORK/command.json")"
    case "$state" in succeeded | failed) break ;; esac
    sleep 0.2
  done
  case "$state" in succeeded | failed) ;; *) ct_fail "$name: $id ended '$state': $(cat "$CT_WORK/command.json")" ;; esac
  answers+="$(jq -c '[.state, .result.outcome, .result.finished_unix_ns]' "$CT_WORK/command.json") "
done
[ "$(runs "$id")" = 1 ] || ct_fail "the robot ran $id $(runs "$id") times through two replicas"
read -r a b <<<"$answers"
[ "$a" = "$b" ] || ct_fail "the replicas disagree on $id: $a vs $b"
ct_log_line "one id through both replicas: robot ran it once, both answer $a"
ct_log_line "PASS"
