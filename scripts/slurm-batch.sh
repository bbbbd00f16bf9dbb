#!/usr/bin/env bash
# Runs a softgrasp-sim batch command (generate, fractals, gqcnn-dataset) as a Slurm array job of
# N tasks, waits for it, and merges the tasks' partial indexes into DIR/index.json: the same
# bytes, file for file, as one process with the same arguments. A failed task is named with its log; re-run it
# alone with --only K (the finished tasks are kept). DIR and the softgrasp-sim executable must be
# on a file system every node sees. docs/slurm.md.
#
# usage: slurm-batch.sh --tasks N [--only K,L,...] [--sim PATH] [--sbatch-arg ARG]... \
#          -- generate|fractals|gqcnn-dataset ARGS... --out DIR
#   --tasks N         the batch's split (the same N for every run of one batch)
#   --only K,L        run only these tasks (e.g. the failed ones), then merge if all are done
#   --sim PATH        softgrasp-sim (default: build/sim/softgrasp-sim of this checkout, else PATH)
#   --sbatch-arg ARG  passed to sbatch (e.g. --partition=cpu, --time=2:00:00); repeatable
# Logs, markers and the job script go to DIR.slurm/ beside DIR. Exit 0 when DIR/index.json is
# written, 1 when tasks failed (named on stderr), 2 for bad usage.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
usage() {
  sed -n '8,15p' "$0" | sed 's/^# \{0,1\}//' >&2
  exit 2
}
log() { echo "slurm-batch: $*" >&2; }

tasks="" only="" sim="" sbatch_args=()
while [ $# -gt 0 ]; do
  case "$1" in
    --tasks) tasks="${2:-}"; shift 2 ;;
    --only) only="${2:-}"; shift 2 ;;
    --sim) sim="${2:-}"; shift 2 ;;
    --sbatch-arg) sbatch_args+=("${2:-}"); shift 2 ;;
    --) shift; break ;;
    *) usage ;;
  esac
done
[ $# -ge 1 ] || usage
command="$1"
shift
args=("$@")
case "$command" in
  generate | fractals | gqcnn-dataset) ;;
  *) log "only generate, fractals and gqcnn-dataset run as array jobs"; usage ;;
esac
[[ "$tasks" =~ ^[1-9][0-9]*$ ]] || { log "--tasks N is required (N >= 1)"; usage; }
for a in "${args[@]}"; do
  case "$a" in --task | --tasks) log "give --tasks to slurm-batch.sh, not to $command"; usage ;; esac
done
out=""
for ((i = 0; i < ${#args[@]}; i++)); do
  [ "${args[$i]}" = --out ] && out="${args[$((i + 1))]:-}"
done
[ -n "$out" ] || { log "$command needs --out DIR"; usage; }
if [ -z "$sim" ]; then
  if [ -x "$root/build/sim/softgrasp-sim" ]; then sim="$root/build/sim/softgrasp-sim"; else sim="$(command -v softgrasp-sim || true)"; fi
fi
[ -x "$sim" ] || { log "softgrasp-sim not found (build it, or give --sim PATH)"; exit 2; }
for tool in sbatch squeue; do
  command -v "$tool" >/dev/null || { log "$tool is missing (Slurm's client tools)"; exit 2; }
done

mkdir -p "$out"
out="$(cd "$out" && pwd)"
sim="$(cd "$(dirname "$sim")" && pwd)/$(basename "$sim")"
state="$out.slurm"
mkdir -p "$state"

if [ -n "$only" ]; then
  [[ "$only" =~ ^[0-9]+(,[0-9]+)*$ ]] || { log "--only takes task numbers, e.g. 3,5"; usage; }
  selected="$only"
else
  selected="0-$((tasks - 1))"
fi
for k in ${only//,/ }; do
  [ "$k" -lt "$tasks" ] || { log "--only $k: tasks are 0..$((tasks - 1))"; usage; }
done

# The job script: one task runs the command on its part, then leaves a marker. Slurm's accounting
# may be off (sacct), so the markers say which tasks finished.
job="$state/job.sh"
{
  echo "#!/usr/bin/env bash"
  echo "set -euo pipefail"
  echo "k=\"\$SLURM_ARRAY_TASK_ID\""
  echo "rm -f $(printf '%q' "$state")/task-\"\$k\".ok"
  printf '%q ' "$sim" "$command" "${args[@]}"
  echo "--task \"\$k\" --tasks $tasks"
  echo "touch $(printf '%q' "$state")/task-\"\$k\".ok"
} >"$job"
chmod +x "$job"
if [ -n "$only" ]; then
  for k in ${only//,/ }; do rm -f "$state/task-$k.ok"; done
else
  rm -f "$state"/task-*.ok
fi

started=$SECONDS
job_id="$(sbatch --parsable --job-name="softgrasp-$command" --array="$selected" \
  --output="$state/task-%a.log" "${sbatch_args[@]}" "$job")"
job_id="${job_id%%;*}"
log "submitted array job $job_id ($command, tasks $selected of $tasks); logs in $state/"
while [ -n "$(squeue -h -j "$job_id" 2>/dev/null || true)" ]; do sleep 0.5; done

failed=""
for ((k = 0; k < tasks; k++)); do
  [ -f "$state/task-$k.ok" ] || failed+="${failed:+,}$k"
done
if [ -n "$failed" ]; then
  for k in ${failed//,/ }; do
    [ -f "$state/task-$k.log" ] && log "task $k: $(tail -n 1 "$state/task-$k.log")"
  done
  log "tasks $failed of $tasks did not finish; re-run them alone:"
  log "  $0 --tasks $tasks --only $failed -- $command ${args[*]}"
  exit 1
fi
"$sim" merge-tasks "$out" >/dev/null
# The folder now holds what one process writes; the tasks' partial files go beside the logs.
shopt -s nullglob
for f in "$out"/index.task-*-of-"$tasks".json "$out"/skipped.task-*-of-"$tasks".json; do
  mv "$f" "$state"/
done
log "all $tasks tasks done in $((SECONDS - started)) s; merged $out/index.json"
echo "$out/index.json"
