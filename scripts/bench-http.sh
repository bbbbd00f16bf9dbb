#!/usr/bin/env bash
# softgrasp-server's HTTP layer against nginx (one worker process), in the same run on the same
# machine, both on loopback: small-request throughput (wrk, keep-alive, GET /healthz) and the
# latency of a health check while 1,000 slow and 1,000 idle clients hold sockets open
# (tests/bench/http_slow_clients). Prints one JSON object; docs/performance.md has the figures.
#
#   bash scripts/bench-http.sh [--quick] [--build-dir DIR] [--rounds N] [--seconds S]
#
# --quick: one short round and 200 slow and 200 idle clients (the CTest smoke run, label "bench").
# Needs nginx-light and wrk (scripts/setup.sh installs them) and a build (scripts/build.sh).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${SOFTGRASP_BUILD_DIR:-$root/build}"
rounds=3
seconds=5
slow=1000
idle=1000
slow_seconds=5
connections=32
while [ $# -gt 0 ]; do
  case "$1" in
    --quick) rounds=1; seconds=1; slow=200; idle=200; slow_seconds=2; shift ;;
    --build-dir) build="$2"; shift 2 ;;
    --rounds) rounds="$2"; shift 2 ;;
    --seconds) seconds="$2"; shift 2 ;;
    *) echo "bench-http: unknown argument $1" >&2; exit 2 ;;
  esac
done
server_bin="$build/service/softgrasp-server"
slow_bin="$build/tests/bench/http_slow_clients"
for tool in nginx wrk jq; do
  command -v "$tool" >/dev/null || { echo "bench-http: $tool missing: run scripts/setup.sh" >&2; exit 2; }
done
for bin in "$server_bin" "$slow_bin"; do
  [ -x "$bin" ] || { echo "bench-http: $bin missing: run scripts/build.sh" >&2; exit 2; }
done

work="$(mktemp -d)"
pids=()
cleanup() {
  for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null || true; done
  wait 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT

# softgrasp-server on a free port, without models or robot: only the HTTP layer is measured.
SOFTGRASP_ROBOT_ENABLED=false "$server_bin" --port 0 --stiffness-model none \
  >"$work/softgrasp.out" 2>"$work/softgrasp.log" &
pids+=($!)
sg_port=""
for _ in $(seq 100); do
  sg_port="$(sed -n 's|^listening on http://127.0.0.1:\([0-9]*\)$|\1|p' "$work/softgrasp.out")"
  [ -n "$sg_port" ] && break
  sleep 0.1
done
[ -n "$sg_port" ] || { echo "bench-http: softgrasp-server did not start" >&2; cat "$work/softgrasp.log" >&2; exit 1; }

# nginx: one worker, the same answer on /healthz; on one port with its access log on (as
# softgrasp's is; nginx's default, one write per request), on the next port with it off.
nginx_port=""
for attempt in $(seq 20); do
  port=$(( 20000 + (RANDOM % 40000) ))
  cat >"$work/nginx.conf" <<EOF
daemon off;
worker_processes 1;
worker_rlimit_nofile 16384;
pid $work/nginx.pid;
error_log $work/nginx-error.log;
events { worker_connections 8192; }
http {
  access_log $work/nginx-access.log;
  client_body_temp_path $work;
  server {
    listen 127.0.0.1:$port;
    location = /healthz { default_type application/json; return 200 '{"status":"ok"}'; }
  }
  server {
    listen 127.0.0.1:$((port + 1));
    access_log off;
    location = /healthz { default_type application/json; return 200 '{"status":"ok"}'; }
  }
}
EOF
  nginx -p "$work" -c "$work/nginx.conf" 2>>"$work/nginx-error.log" &
  npid=$!
  for _ in $(seq 50); do
    if curl -fsS "http://127.0.0.1:$port/healthz" >/dev/null 2>&1 &&
       curl -fsS "http://127.0.0.1:$((port + 1))/healthz" >/dev/null 2>&1; then
      nginx_port=$port
      break
    fi
    kill -0 "$npid" 2>/dev/null || break
    sleep 0.1
  done
  if [ -n "$nginx_port" ]; then pids+=("$npid"); break; fi
  kill "$npid" 2>/dev/null || true
  wait "$npid" 2>/dev/null || true
done
[ -n "$nginx_port" ] || { echo "bench-http: nginx did not start" >&2; cat "$work/nginx-error.log" >&2; exit 1; }

# Requests per second of one wrk run (one thread, $connections keep-alive connections).
rps() {
  wrk -t1 -c"$connections" -d"${seconds}s" "http://127.0.0.1:$1/healthz" |
    awk '/^Requests\/sec:/ {print $2}'
}
median() { sort -g | awk '{a[NR]=$1} END {print (NR % 2) ? a[(NR+1)/2] : (a[NR/2] + a[NR/2+1]) / 2}'; }

# Alternating rounds, so that drifts of a noisy machine hit both alike.
: >"$work/rps-sg"
: >"$work/rps-nginx"
: >"$work/rps-nginx-nolog"
for _ in $(seq "$rounds"); do
  rps "$nginx_port" >>"$work/rps-nginx"
  rps "$sg_port" >>"$work/rps-sg"
  rps "$((nginx_port + 1))" >>"$work/rps-nginx-nolog"
done
sg_rps="$(median <"$work/rps-sg")"
nginx_rps="$(median <"$work/rps-nginx")"
nginx_nolog_rps="$(median <"$work/rps-nginx-nolog")"

slow_run() {
  # Exits 1 when a probe failed; the JSON says how many, and the check at the end decides.
  "$slow_bin" --port "$1" --slow "$slow" --idle "$idle" --seconds "$slow_seconds" \
    --probe-interval-ms 100 || true
}
slow_nginx="$(slow_run "$nginx_port")"
slow_sg="$(slow_run "$sg_port")"

jq -n --argjson sg_rps "$sg_rps" --argjson nginx_rps "$nginx_rps" \
  --argjson nginx_nolog_rps "$nginx_nolog_rps" \
  --slurpfile nginx_nolog_all <(jq -s . <"$work/rps-nginx-nolog") \
  --argjson slow_sg "$slow_sg" --argjson slow_nginx "$slow_nginx" \
  --arg rounds "$rounds" --arg seconds "$seconds" --arg connections "$connections" \
  --slurpfile sg_all <(jq -s . <"$work/rps-sg") --slurpfile nginx_all <(jq -s . <"$work/rps-nginx") '
  {
    throughput_healthz: {
      tool: "wrk -t1 -c\($connections) -d\($seconds)s, median of \($rounds) alternating rounds",
      softgrasp_rps: $sg_rps, nginx_1_worker_rps: $nginx_rps,
      nginx_1_worker_no_access_log_rps: $nginx_nolog_rps,
      ratio_softgrasp_to_nginx: (($sg_rps / $nginx_rps) * 1000 | round / 1000),
      ratio_softgrasp_to_nginx_no_access_log: (($sg_rps / $nginx_nolog_rps) * 1000 | round / 1000),
      softgrasp_rounds: $sg_all[0], nginx_rounds: $nginx_all[0],
      nginx_no_access_log_rounds: $nginx_nolog_all[0]
    },
    slow_clients: {softgrasp: $slow_sg, nginx: $slow_nginx}
  }'
# Both servers must have answered every probe with a 200 while the slow clients held on.
[ "$(jq '.probes_failed' <<<"$slow_sg")" = 0 ] && [ "$(jq '.slow_answered' <<<"$slow_sg")" = 0 ]
