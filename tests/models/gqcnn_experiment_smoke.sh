#!/usr/bin/env bash
# The Table 4.1 experiment script (scripts/gqcnn-experiment.sh) end to end at toy size, with the
# real binaries: five datasets, five trainings of a few steps, the held-out evaluations (the bar
# clamp from tests/data as both real sets instead of the downloaded meshes) and simulated picks;
# then a rerun, which must skip every step.
#   gqcnn_experiment_smoke.sh SOURCE_DIR SOFTGRASP_SIM SOFTGRASP_TRAIN
set -euo pipefail
root="$1"
export SOFTGRASP_SIM="$2" SOFTGRASP_TRAIN="$3"
work="$(mktemp -d "${TMPDIR:-/tmp}/softgrasp-gqcnn-experiment-XXXXXX")"
trap 'rm -rf "$work"' EXIT
mkdir "$work/meshes"
cp "$root/tests/data/meshes/dexnet_bar_clamp.obj" "$work/meshes/"
export GQ_OBJECTS=3 GQ_IMAGES=3 GQ_STEPS=10 GQ_HELDOUT_IMAGES=6 GQ_PICK_SCENES=1 \
  GQ_CLUTTER_SCENES=1 GQ_HELDOUT_MESHES="$work/meshes" GQ_SECOND_MESHES="$work/meshes" \
  GQ_ROBUST_SAMPLES=25
bash "$root/scripts/gqcnn-experiment.sh" "$work/out" > "$work/first.log" 2>&1 ||
  { cat "$work/first.log"; exit 1; }

fail() { echo "gqcnn_experiment_smoke: $*" >&2; exit 1; }
for s in fractal-006 fractal-030 fractal-070 primitive catalogue; do
  [ -f "$work/out/models/$s.pt" ] || fail "no model for $s"
  [ "$(jq '.training.steps_done' "$work/out/models/$s.json")" -ge 1 ] || fail "$s: no training step"
  [ "$(jq '.data.objects' "$work/out/models/$s.json")" = 3 ] || fail "$s: not 3 objects"
  e="$work/out/eval/$s.json"
  [ "$(jq '.gqcnn.grasps' "$e")" -gt 0 ] || fail "$s: no held-out grasp evaluated"
  jq -e '.data == ["'"$work/out/heldout"'"] and (.warning | not)' "$e" >/dev/null ||
    fail "$s: not evaluated on the held-out set alone"
  jq -e '.gqcnn.balanced_accuracy | (. == null) or (. >= 0 and . <= 1)' "$e" >/dev/null ||
    fail "$s: balanced accuracy out of range"
  # The shipped network's options reach every training.
  jq -e '.architecture.output | startswith("factored")' "$work/out/models/$s.json" >/dev/null ||
    fail "$s: not trained with the default options"
  # Both real sets, each at the threshold chosen on the other.
  x="$work/out/eval/$s-cross.json"
  jq -e '.data == ["'"$work/out/heldout"'", "'"$work/out/second"'"] and
    (.gqcnn.thresholds_per_set | length == 2) and (.gqcnn.grasps > 0)' "$x" >/dev/null ||
    fail "$s: no cross-calibrated evaluation on the two real sets"
done
# Picks: FGE and the five models on the same scenes, one single-object and one clutter scene.
jq -e '[.sets[].planners | length] == [6, 6]' "$work/out/picks.json" >/dev/null ||
  fail "picks.json does not compare FGE with the five models in both scene sets"
jq -e '[.sets[].planners[].scenes] | all(. == 1)' "$work/out/picks.json" >/dev/null ||
  fail "picks.json: not one scene per set"
# One record per scene and planner, each with the simulator's outcome and its reason.
[ "$(wc -l < "$work/out/picks.jsonl")" = 12 ] || fail "picks.jsonl: not 12 records"
jq -s -e 'all(.[]; (.outcome | type == "string") and (.reason | type == "string"))' \
  "$work/out/picks.jsonl" >/dev/null || fail "picks.jsonl: a record without outcome or reason"
jq -e '.opening_stroke_m == 0.05' "$work/out/picks.json" >/dev/null ||
  fail "picks.json: not the datasets' 5 cm gripper by default"
# The same network without each of the policy's checks, beside it on the same scene, with
# another gripper.
"$SOFTGRASP_TRAIN" gqcnn-picks --model "$work/out/models/fractal-030.pt" --clutter-scenes 1 \
  --also-without-contact-check --also-without-clearance-check --out "$work/checks.json" \
  --records "$work/checks.jsonl" --stroke-mm 85 2>/dev/null
jq -e '.opening_stroke_m == 0.085' "$work/checks.json" >/dev/null ||
  fail "gqcnn-picks --stroke-mm 85 did not set the gripper"
jq -e '[.sets[0].planners[].planner] == ["fge", "gqcnn:fractal-030",
  "gqcnn:fractal-030:no-contact-check", "gqcnn:fractal-030:no-clearance-check"]' "$work/checks.json" \
  >/dev/null || fail "gqcnn-picks: not the planners without each check"
[ "$(wc -l < "$work/checks.jsonl")" = 4 ] || fail "checks.jsonl: not 4 records"

# A rerun finds everything done and changes nothing.
before="$(cd "$work/out" && find . -type f -newer "$work/out/picks.json" | wc -l)"
bash "$root/scripts/gqcnn-experiment.sh" "$work/out" > "$work/second.log" 2>&1 ||
  { cat "$work/second.log"; exit 1; }
after="$(cd "$work/out" && find . -type f -newer "$work/out/picks.json" | wc -l)"
[ "$before" = "$after" ] || fail "the rerun rewrote files ($before -> $after newer than picks.json)"
grep -q 'present' "$work/second.log" || fail "the rerun did not skip the datasets"
echo "gqcnn_experiment_smoke: ok"
