#!/usr/bin/env bash
# The allocator setting every softgrasp program applies at start (process::KeepFreedMemoryForReuse,
# service/process/allocator.h) against glibc's defaults, in the same run on the same machine:
# each benchmark below runs alternately with both settings (bench_main.cpp's
# --glibc-default-malloc), each run 3 repetitions. Prints one JSON object: per benchmark, the
# upper median over rounds (with 2 rounds: the higher) of the runs' medians (ms, real time) and
# glibc / kept. docs/performance.md ("The allocator") has the figures.
#
#   bash scripts/bench-allocator.sh [--quick] [--build-dir DIR] [--rounds N]
#
# --quick: one round of one short benchmark (the CTest smoke run, label "bench").
# Needs jq (scripts/setup.sh installs it) and a build (scripts/build.sh).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${SOFTGRASP_BUILD_DIR:-$root/build}"
rounds=2
repetitions=3
# benchmark program, then a --benchmark_filter regex
benches=(
  "segmentation_bench" "Model"
  "stiffness_bench" "StiffnessPredict|DetectGraspsFge"
  "fge_bench" "FgeFast"
  "gqcnn_plan_bench" "Primesense"
  "deformability_plan_bench" "PlanClutterLeastDeformable|FgeClutter"
  "gqcnn_dataset_bench" "FullImageWithCrops"
  "fractal_bench" "FractalModel/30/50"
)
while [ $# -gt 0 ]; do
  case "$1" in
    --quick) rounds=1; repetitions=1; benches=("fge_bench" "FgeFast/1/1"); shift ;;
    --build-dir) build="$2"; shift 2 ;;
    --rounds) rounds="$2"; shift 2 ;;
    *) echo "bench-allocator: unknown argument $1" >&2; exit 2 ;;
  esac
done
command -v jq >/dev/null || { echo "bench-allocator: jq missing: run scripts/setup.sh" >&2; exit 2; }

work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
# run BENCH FILTER SETTING ROUND: one run's medians as {"name": ms, ...} in $work.
run() {
  local bin="$build/tests/bench/$1" extra=()
  [ -x "$bin" ] || { echo "bench-allocator: $bin missing: run scripts/build.sh" >&2; exit 2; }
  [ "$3" = glibc ] && extra=(--glibc-default-malloc)
  "$bin" "${extra[@]}" --benchmark_filter="$2" --benchmark_repetitions="$repetitions" \
    --benchmark_time_unit=ms --benchmark_format=json 2>/dev/null |
    jq --arg setting "$3" '
      if .context.malloc != (if $setting == "glibc" then "glibc defaults" else "freed memory kept" end)
      then error("the benchmark did not report the allocator setting asked for") else . end
      | [.benchmarks[]
         | select(.run_type == "iteration")
         | {key: .run_name, value: .real_time}]
      | group_by(.key) | map({key: .[0].key, value: (map(.value) | sort | .[length / 2 | floor])})
      | from_entries' >"$work/$1.$3.$4.json"
}
for ((round = 0; round < rounds; ++round)); do
  for ((i = 0; i < ${#benches[@]}; i += 2)); do
    echo "bench-allocator: round $((round + 1))/$rounds ${benches[i]}" >&2
    # Alternate which setting goes first, so drift in the machine's load favours neither.
    if ((round % 2 == 0)); then order=(kept glibc); else order=(glibc kept); fi
    for setting in "${order[@]}"; do run "${benches[i]}" "${benches[i + 1]}" "$setting" "$round"; done
  done
done
# Per benchmark and setting, the upper median over the rounds of the runs' medians.
for setting in kept glibc; do
  jq -s 'map(to_entries[]) | group_by(.key)
         | map({key: .[0].key, value: (map(.value) | sort | .[length / 2 | floor])})
         | from_entries' "$work"/*."$setting".*.json >"$work/all.$setting"
done
jq -n --slurpfile kept "$work/all.kept" --slurpfile glibc "$work/all.glibc" \
  --argjson rounds "$rounds" --argjson repetitions "$repetitions" '
  {rounds: $rounds, repetitions_per_run: $repetitions, unit: "ms, median real time",
   benchmarks: ($kept[0] | keys | map(. as $k | {key: $k, value: {
     freed_memory_kept: ($kept[0][$k] * 100 | round / 100),
     glibc_defaults: ($glibc[0][$k] * 100 | round / 100),
     glibc_over_kept: (($glibc[0][$k] / $kept[0][$k]) * 100 | round / 100)}}) | from_entries)}'
