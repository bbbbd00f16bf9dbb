#!/usr/bin/env bash
# Datasets on Slurm, on a one-node cluster this test starts (munged, slurmctld and slurmd from
# Debian's packages, private config, ports and folders; all stopped at the end):
#  - fractals, generate and gqcnn-dataset as array jobs (scripts/slurm-batch.sh) give the same
#    bytes, file for file, as one process with the same seed;
#  - a task that fails (its shard folder is blocked) is named, the others are kept, and
#    re-running it alone (--only) completes the batch, again the same bytes;
#  - the wall time of one process and of the array job on this machine's cores, for the docs.
# docs/slurm.md.
#
# usage: slurm_test.sh SOFTGRASP_SIM   (needs root; SOFTGRASP_SLURM_SKIP=1 skips it, exit 77)
set -euo pipefail
sim="$1"
root="$(cd "$(dirname "$0")/../.." && pwd)"
batch="$root/scripts/slurm-batch.sh"
fail() {
  echo "slurm_test: FAIL: $*" >&2
  exit 1
}
log() { echo "slurm_test: $*" >&2; }
if [ "${SOFTGRASP_SLURM_SKIP:-0}" = 1 ]; then
  log "SKIPPED on purpose (SOFTGRASP_SLURM_SKIP=1)"
  exit 77
fi
[ "$(id -u)" -eq 0 ] || fail "needs root (slurmd runs jobs as their user); SOFTGRASP_SLURM_SKIP=1 skips it"
for tool in munged slurmctld slurmd sbatch squeue sinfo; do
  command -v "$tool" >/dev/null || fail "$tool is missing: run scripts/setup.sh"
done
[ -r /etc/munge/munge.key ] || fail "/etc/munge/munge.key is missing (the munge package makes it)"

work="$(mktemp -d /tmp/softgrasp-slurm.XXXXXX)"
chmod 755 "$work"
cleanup() {
  local code=$? f
  set +e
  for f in "$work/slurmd.pid" "$work/slurmctld.pid" "$work/munge/munged.pid"; do
    [ -f "$f" ] && kill "$(cat "$f")" 2>/dev/null
  done
  sleep 0.5
  for f in "$work/slurmd.pid" "$work/slurmctld.pid" "$work/munge/munged.pid"; do
    [ -f "$f" ] && kill -KILL "$(cat "$f")" 2>/dev/null
  done
  if [ "$code" -ne 0 ]; then
    for f in "$work"/log/*.log "$work"/*.slurm/task-*.log; do
      [ -f "$f" ] && { echo "---- $f" >&2; tail -n 15 "$f" >&2; }
    done
  fi
  rm -rf "$work"
  exit "$code"
}
trap cleanup EXIT
trap 'exit 130' INT TERM

# ---- a one-node cluster --------------------------------------------------------------------
mkdir -p "$work/munge" "$work/state" "$work/spool" "$work/log"
chown munge:munge "$work/munge"
su munge -s /bin/sh -c "munged --socket=$work/munge/munge.sock --pid-file=$work/munge/munged.pid \
  --log-file=$work/munge/munged.log --seed-file=$work/munge/munged.seed" || fail "munged did not start"
host="$(hostname -s)"
cpus="$(nproc)"
# Ports from the run's pid, so a cluster of the machine (6817/6818) or another run is not hit.
port=$((20000 + ($$ % 20000) * 2))
cat >"$work/slurm.conf" <<CONF
ClusterName=sgtest
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$port
SlurmdPort=$((port + 1))
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$work/munge/munge.sock
CredType=cred/munge
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/log/slurmctld.log
SlurmdLogFile=$work/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MpiDefault=none
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=2000 State=UNKNOWN
PartitionName=sgtest Nodes=ALL Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF="$work/slurm.conf"
slurmctld || fail "slurmctld did not start"
slurmd || fail "slurmd did not start"
for _ in $(seq 100); do
  [ "$(sinfo -h -o '%t' 2>/dev/null)" = idle ] && break
  sleep 0.2
done
[ "$(sinfo -h -o '%t')" = idle ] || fail "the node is not idle: $(sinfo 2>&1)"
log "one-node cluster up: $host, $cpus CPUs"

same_bytes() {
  diff -r "$1" "$2" >"$work/diff.txt" 2>&1 || fail "$2 differs from one process's $1: $(head -n 5 "$work/diff.txt")"
}

# ---- fractals: 4 tasks ---------------------------------------------------------------------
"$sim" fractals --count 8 --seed 3 --out "$work/fractals-one" >/dev/null 2>&1 || fail "fractals in one process"
bash "$batch" --tasks 4 --sim "$sim" -- fractals --count 8 --seed 3 --out "$work/fractals" >/dev/null ||
  fail "slurm-batch.sh fractals"
same_bytes "$work/fractals-one" "$work/fractals"
log "fractals: 4 array tasks merged = one process, byte for byte"

# ---- generate: 3 tasks, one fails, re-run alone --------------------------------------------
gen=(generate --scenes 6 --seed 4 --shard-size 2 --objects 3-5 --noise on)
started=$SECONDS
"$sim" "${gen[@]}" --out "$work/scenes-one" >/dev/null 2>&1 || fail "generate in one process"
one_s=$((SECONDS - started))
mkdir -p "$work/scenes"
touch "$work/scenes/shard_0001"  # a file where task 1 (scenes 2 and 3) makes its shard folder
if bash "$batch" --tasks 3 --sim "$sim" -- "${gen[@]}" --out "$work/scenes" 2>"$work/batch.err" >/dev/null; then
  fail "slurm-batch.sh succeeded though task 1 could not write"
fi
grep -q "tasks 1 of 3 did not finish" "$work/batch.err" || fail "the failed task is not named: $(cat "$work/batch.err")"
[ ! -f "$work/scenes/index.json" ] || fail "an index was merged without task 1"
[ -f "$work/scenes.slurm/task-0.ok" ] && [ -f "$work/scenes.slurm/task-2.ok" ] || fail "tasks 0 and 2 are not kept"
log "a failed task is named: $(grep 'did not finish' "$work/batch.err" | sed 's/^slurm-batch: //')"
rm "$work/scenes/shard_0001"
started=$SECONDS
bash "$batch" --tasks 3 --only 1 --sim "$sim" -- "${gen[@]}" --out "$work/scenes" >/dev/null 2>"$work/batch.err" ||
  fail "re-running task 1 alone failed: $(cat "$work/batch.err")"
same_bytes "$work/scenes-one" "$work/scenes"
log "generate: task 1 re-run alone ($((SECONDS - started)) s), merged = one process, byte for byte"

# ---- gqcnn-dataset: 2 tasks; the merge renumbers the second task's images ------------------
gq=(gqcnn-dataset --objects 4 --shard-objects 1 --images-per-object 2 --grasps 20 --robust-samples 3 --seed 6)
"$sim" "${gq[@]}" --out "$work/gqcnn-one" >/dev/null 2>&1 || fail "gqcnn-dataset in one process"
bash "$batch" --tasks 2 --sim "$sim" -- "${gq[@]}" --out "$work/gqcnn" >/dev/null 2>&1 ||
  fail "slurm-batch.sh gqcnn-dataset"
same_bytes "$work/gqcnn-one" "$work/gqcnn"
log "gqcnn-dataset: 2 array tasks merged = one process, byte for byte"

# ---- wall time: one process and an array job of $cpus tasks ---------------------------------
scenes=$((8 * cpus))
started=$SECONDS
"$sim" generate --scenes "$scenes" --seed 5 --out "$work/speed-one" >/dev/null 2>&1 || fail "speed run, one process"
one_s=$((SECONDS - started))
started=$SECONDS
bash "$batch" --tasks "$cpus" --sim "$sim" -- generate --scenes "$scenes" --seed 5 --out "$work/speed" >/dev/null 2>&1 ||
  fail "speed run, array job"
array_s=$((SECONDS - started))
same_bytes "$work/speed-one" "$work/speed"
log "wall time for $scenes scenes: one process $one_s s, array job of $cpus tasks $array_s s (Slurm starts tasks in waves a few seconds apart)"
log "PASS"
