#!/usr/bin/env bash
# The Table 4.1 experiment of thesis chapter 4 (docs/gqcnn.md): equal-sized GQ-CNN datasets
# (same objects, same images) from fractal meshes at alpha 0.06, 0.3 and 0.7, from procedural
# primitives and from the catalogue; one GQ-CNN per dataset with the same command and budget;
# all tested on the same held-out real-object meshes (scripts/heldout-meshes.sh: the 22 and the
# second set of 18) and, as strategy=gqcnn, in the simulator against FGE on the same scenes.
# The defaults are the shipped network's data and training (docs/gqcnn.md, "Clearance as an
# input": 1,000 objects, 200 robust samples per label, 8,000 steps, no gain, clearance inputs,
# factored output).
#
#   bash scripts/gqcnn-experiment.sh OUT_DIR   (several hours on 2 cores: not timed end to end at
#                                               these sizes; its steps' times are in docs/gqcnn.md)
#
# Writes OUT_DIR/<source>/ (datasets), OUT_DIR/models/<source>.pt (+ cards and curves),
# OUT_DIR/eval/<source>.json (the 22 held-out meshes at P >= 0.5),
# OUT_DIR/eval/<source>-cross.json (all 40 real meshes, each set at the threshold chosen on the
# other: gqcnn-eval --cross-calibrate) and OUT_DIR/picks.json (+ picks.jsonl, one line per scene
# and planner with the simulator's reason). Every step is skipped when its output is there, so
# a killed run is resumed by running it again. The shipped model is the fractal one:
# `cp OUT_DIR/models/fractal-030.* models/` renamed to gqcnn.*.
# Sizes and budget can be changed with the environment variables below (a smoke run:
# GQ_OBJECTS=4 GQ_IMAGES=4 GQ_STEPS=20 GQ_HELDOUT_IMAGES=4 GQ_PICK_SCENES=2 GQ_CLUTTER_SCENES=1,
# and GQ_HELDOUT_MESHES=DIR GQ_SECOND_MESHES=DIR to test on the meshes of DIR instead of
# downloading CGAL's; the thesis' sizes: GQ_OBJECTS=150 GQ_ROBUST_SAMPLES=25 GQ_STEPS=4000
# GQ_TRAIN_OPTIONS="").
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
out="${1:?usage: gqcnn-experiment.sh OUT_DIR}"
sim="${SOFTGRASP_SIM:-$root/build/sim/softgrasp-sim}"
train="${SOFTGRASP_TRAIN:-$root/build/tools/train/softgrasp-train}"
objects="${GQ_OBJECTS:-1000}"         # objects per training set (the thesis' sets: 150)
images="${GQ_IMAGES:-40}"             # rendered images per object, spread over its stable poses
robust_samples="${GQ_ROBUST_SAMPLES:-200}"  # samples per training label (Dex-Net: 25)
steps="${GQ_STEPS:-8000}"             # training steps of batch 64, the same for every set
threads="${GQ_THREADS:-2}"            # torch threads of the trainings
# The same training options for every set (the shipped network's).
train_options="${GQ_TRAIN_OPTIONS---no-gain --clearance-inputs --factored}"
heldout_images="${GQ_HELDOUT_IMAGES:-40}"
pick_scenes="${GQ_PICK_SCENES:-66}"   # single held-out objects (3 per mesh with 22 meshes)
clutter_scenes="${GQ_CLUTTER_SCENES:-40}"
sources="fractal-006 fractal-030 fractal-070 primitive catalogue"

mkdir -p "$out/models" "$out/eval"
heldout_meshes="${GQ_HELDOUT_MESHES:-$out/heldout-meshes}"
[ -n "${GQ_HELDOUT_MESHES:-}" ] || bash "$root/scripts/heldout-meshes.sh" "$heldout_meshes"
second_meshes="${GQ_SECOND_MESHES:-$out/second-meshes}"
[ -n "${GQ_SECOND_MESHES:-}" ] || bash "$root/scripts/heldout-meshes.sh" "$second_meshes" second

dataset() {  # NAME ARGS...: generated once (the generator resumes and refuses other arguments)
  local name="$1"; shift
  if [ -f "$out/$name/.done" ]; then echo "dataset $name: present"; return; fi
  "$sim" gqcnn-dataset --out "$out/$name" --images-per-object "$images" --seed 1 \
    --robust-samples "$robust_samples" "$@"
  touch "$out/$name/.done"
}
source_args() {
  case "$1" in
    fractal-006) echo "--source fractal --alpha 0.06 --objects $objects" ;;
    fractal-030) echo "--source fractal --alpha 0.3 --objects $objects" ;;
    fractal-070) echo "--source fractal --alpha 0.7 --objects $objects" ;;
    primitive) echo "--source primitive --objects $objects" ;;
    catalogue) echo "--source catalogue --split train --objects $objects" ;;
  esac
}
# Datasets two at a time (the generator is single-threaded).
# shellcheck disable=SC2046
(dataset fractal-006 $(source_args fractal-006); dataset fractal-070 $(source_args fractal-070)
 dataset catalogue $(source_args catalogue)) &
first=$!
# shellcheck disable=SC2046
(dataset fractal-030 $(source_args fractal-030); dataset primitive $(source_args primitive)
 # The held-out sets: every real mesh, other seeds, the same images per object, Dex-Net's
 # 25-sample labels.
 if [ ! -f "$out/heldout/.done" ]; then
   "$sim" gqcnn-dataset --out "$out/heldout" --source meshes --meshes "$heldout_meshes" \
     --images-per-object "$heldout_images" --seed 2
   touch "$out/heldout/.done"
 fi
 if [ ! -f "$out/second/.done" ]; then
   "$sim" gqcnn-dataset --out "$out/second" --source meshes --meshes "$second_meshes" \
     --images-per-object "$heldout_images" --seed 3
   touch "$out/second/.done"
 fi) &
second=$!
wait "$first"
wait "$second"

for s in $sources; do
  model="$out/models/$s.pt"
  if [ ! -f "$model" ] || [ -f "$out/models/$s.ckpt.running" ]; then
    touch "$out/models/$s.ckpt.running"
    # shellcheck disable=SC2086
    "$train" gqcnn --data "$out/$s" --out "$model" --steps "$steps" --seed 1 --resume \
      --threads "$threads" $train_options
    rm -f "$out/models/$s.ckpt.running"
  fi
  [ -f "$out/eval/$s.json" ] ||
    "$train" gqcnn-eval --model "$model" --data "$out/heldout" --json "$out/eval/$s.json" >/dev/null
  [ -f "$out/eval/$s-cross.json" ] ||
    "$train" gqcnn-eval --model "$model" --data "$out/heldout" --data "$out/second" \
      --cross-calibrate --resamples 2000 --json "$out/eval/$s-cross.json" >/dev/null
done

if [ ! -f "$out/picks.json" ]; then
  models=()
  for s in $sources; do models+=(--model "$out/models/$s.pt"); done
  "$train" gqcnn-picks "${models[@]}" --meshes "$heldout_meshes" \
    --single-scenes "$pick_scenes" --clutter-scenes "$clutter_scenes" --seed 7 \
    --records "$out/picks.jsonl" --out "$out/picks.json"
fi
echo "gqcnn-experiment: results in $out/eval/*.json and $out/picks.json"
