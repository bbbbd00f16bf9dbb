#!/usr/bin/env bash
# Generates the simulated training and validation sets of the segmentation model
# (models/segmentation.md): bins of 3-8 objects and dense bins of 15-30 whose piles reach the
# walls, tables with a few objects, brush piles, sponge-packed bins, three cameras (SR305-like at
# 0.32 and 0.55 m, Primesense at 0.70-0.80 m, PhoXi-like at 0.80 m). Validation uses shapes never
# seen in training (--split val).
# Usage: scripts/make-segmentation-data.sh OUT_DIR   (about 30 min on 2 cores; runs 2 at a time)
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
out="${1:?usage: make-segmentation-data.sh OUT_DIR}"
sim="${SOFTGRASP_SIM:-$root/build/sim/softgrasp-sim}"
prime="$root/tests/data/gqcnn/primesense/primesense.intr"

gen() {  # NAME ARGS...: one set, skipped when it is already complete
  local name="$1"; shift
  if [ -f "$out/$name/index.json" ]; then echo "$name: present"; return; fi
  "$sim" generate --out "$out/$name" "$@" >/dev/null
  echo "$name: done"
}
train_a() {
  gen train-bin      --scenes 600 --seed 101 --objects 3-8
  gen train-table    --scenes 300 --seed 103 --objects 3-8 --support table --camera-height 0.70 --intrinsics "$prime"
  gen train-single   --scenes 200 --seed 104 --objects 1-3 --support table --camera-height 0.80 --intrinsics "$prime"
  gen train-near     --scenes 200 --seed 105 --objects 3-8 --camera-height 0.32
  gen val-bin        --scenes 100 --seed 201 --objects 3-8 --split val
  gen val-table      --scenes 50  --seed 203 --objects 3-8 --split val --support table --camera-height 0.70 --intrinsics "$prime"
  # Selection sets (held-out shapes, other seeds) for choosing grouping thresholds, so the
  # validation sets stay untouched until the final scores.
  gen sel-bin        --scenes 40  --seed 301 --objects 3-8 --split val
  # The fine-tuning stage's sets (models/segmentation.md): brush piles and sponge-packed bins
  # like the deformability tasks' scenes (training shapes, other seeds).
  gen train-brush    --scenes 200 --seed 108 --objects 4-8 --categories brush
  gen train-sponge   --scenes 200 --seed 109 --objects 6-10 \
    --categories box,can,bottle,block,cup,sponge,sponge,sponge,sponge,sponge
}
train_b() {
  gen train-dense    --scenes 300 --seed 102 --objects 15-30
  gen val-dense      --scenes 50  --seed 202 --objects 15-30 --split val
  gen sel-dense      --scenes 20  --seed 302 --objects 15-30 --split val
  # Fine-tuning stage: more dense bins (the weak part after the first 2500 steps), and dense bins
  # seen by a PhoXi-like camera (the real heap in tests/data/gqcnn/phoxi) from 0.80 m.
  gen train-dense-b  --scenes 300 --seed 106 --objects 15-30
  gen train-phoxi    --scenes 200 --seed 107 --objects 15-30 --camera-height 0.80 \
    --intrinsics "$root/tests/data/gqcnn/phoxi/phoxi.intr"
}
mkdir -p "$out"
train_a & a=$!
train_b & b=$!
wait "$a"; wait "$b"
