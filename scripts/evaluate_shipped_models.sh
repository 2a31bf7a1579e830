#!/usr/bin/env bash
# The held-out evaluation of the shipped models (models/README.md), on this CPU.
# Held-out data, never used in training:
#   - material sets: make-materials seed 1 (training used seeds 0 and 2-8), 10 per class, and
#     the real set materialx_wood (wood); the general network is also tested on
#     godot_aluminium, a real set without a metalness map, which the reduction makes a
#     dielectric, so it is not in the metal network's test;
#   - probes: the 8 probes of HELD_OUT_PROBES (training used the other 26 shared probes).
# Each set is rendered with Mitsuba under each held-out probe (render-dataset, 1 rotation,
# 2 crops of 256 px from a 512 px render, 128 spp); sa-evaluate takes 48 samples evenly
# spaced over each class's renders and relights each estimate under 3 other held-out probes.
#
#   bash scripts/evaluate_shipped_models.sh SHARED_DATA WORK
set -euo pipefail
SHARED=$1 WORK=$2 BIN=${BIN:-.venv/bin}
HELD_OUT_PROBES="aristea_wreck_puresky brown_photostudio_02 circus_arena dikhololo_night
                 env-lab kiara_1_dawn modern_buildings_2 rainforest_trail"
mkdir -p "$WORK/probes" "$WORK/eval"
for probe in $HELD_OUT_PROBES; do ln -sfn "$(realpath "$SHARED/probes/$probe.exr")" "$WORK/probes/"; done
for class in wood plastic metal; do
    "$BIN/make-materials" --class "$class" --count 10 --seed 1 --resolution 512 \
        --out "$WORK/sets/$class"
done
ln -sfn "$(realpath "$SHARED/svbrdfs/materialx_wood")" "$WORK/sets/wood/"
mkdir -p "$WORK/sets/aluminium"
ln -sfn "$(realpath "$SHARED/svbrdfs/godot_aluminium")" "$WORK/sets/aluminium/"
for class in wood plastic metal aluminium; do
    "$BIN/render-dataset" --probes "$WORK/probes" --svbrdfs "$WORK/sets/$class" \
        --out "$WORK/heldout_$class" --resolution 256 --render-size 512 --rotations 1 \
        --crops 2 --spp 128 --test-materials 0 --test-probes 0
done
for class in wood plastic metal; do
    "$BIN/sa-evaluate" --class "$class" --dataset "$WORK/heldout_$class" --split all \
        --probes "$WORK/probes" --samples 48 --out "$WORK/eval/$class" > "$WORK/eval/$class.json"
done
"$BIN/sa-evaluate" --class general --dataset "$WORK/heldout_wood" \
    --dataset "$WORK/heldout_plastic" --dataset "$WORK/heldout_aluminium" \
    --dataset "$WORK/heldout_metal" --split all --probes "$WORK/probes" --samples 48 \
    --out "$WORK/eval/general" > "$WORK/eval/general.json"
