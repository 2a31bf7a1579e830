#!/usr/bin/env bash
# The held-out evaluation of the shipped models (models/README.md), on this CPU.
# Held-out data, never used in training:
#   - material sets: make-materials seed 1 (training used seeds 0 and 2-8), 40 per class, and
#     the real set materialx_wood (wood);
#   - probes: the 8 probes of HELD_OUT_PROBES (training used the other 26 shared probes).
# The 40 sets of a class are split into 4 groups of 10; group g is rendered with Mitsuba under
# the probe pair g (render-dataset, 1 rotation, a 512 px render per set and probe, one 256 px
# crop of it: the scale of the training crops; 128 spp), the real sets under every pair:
# 80 samples per class (88 for wood), each probe in 20.
# sa-evaluate takes up to 96 samples evenly spaced over a class's renders and relights each
# estimate under 3 other held-out probes. (Until 2026-12 the test had 10 sets per class and
# 48 samples, which proved too few: the same model scored 0.96x and 0.84x naive on the two.)
#
# MORE_SETS=N (a multiple of 4; default 0) also gives each class network a larger test: the
# same 40 renders and N more sets of seed 1 (indices 40 to 39 + N), N / 4 to each probe pair,
# two renders each, all of them evaluated ($WORK/eval/<class>-larger).
#
# CLASSES (default "wood plastic metal") names the class networks to test. Re-run with the
# same WORK: finished renders are kept.
#
#   [CLASSES=plastic] [MORE_SETS=80] bash scripts/evaluate_shipped_models.sh SHARED_DATA WORK \
#       [MODELS_DIR]
set -euo pipefail
SHARED=$1 WORK=$2 MODELS=${3:-models} BIN=${BIN:-.venv/bin}
CLASSES=${CLASSES:-wood plastic metal}
MORE_SETS=${MORE_SETS:-0}
if (( MORE_SETS % 4 != 0 )); then echo "MORE_SETS: $MORE_SETS is not a multiple of 4" >&2; exit 2; fi
for class in $CLASSES; do
    case $class in wood|plastic|metal) ;; *) echo "CLASSES: unknown class $class" >&2; exit 2;; esac
done
PAIRS=("aristea_wreck_puresky brown_photostudio_02" "circus_arena dikhololo_night"
       "env-lab kiara_1_dawn" "modern_buildings_2 rainforest_trail")
mkdir -p "$WORK/probes" "$WORK/eval"
for g in 0 1 2 3; do
    mkdir -p "$WORK/probes/pair$g"
    for probe in ${PAIRS[$g]}; do
        ln -sfn "$(realpath "$SHARED/probes/$probe.exr")" "$WORK/probes/pair$g/"
        ln -sfn "$(realpath "$SHARED/probes/$probe.exr")" "$WORK/probes/"
    done
done
for class in $CLASSES; do
    if [ ! -d "$WORK/sets/$class" ]; then
        "$BIN/make-materials" --class "$class" --count 40 --seed 1 --resolution 512 \
            --out "$WORK/sets/$class"
    fi
done
real_sets() {  # the real held-out sets of a class
    case $1 in wood) echo materialx_wood;; esac
}
link_sets() {  # link_sets GROUP FOLDER CLASS FIRST LAST: sets FIRST..LAST of FOLDER into GROUP
    local i
    for i in $(seq "$4" "$5"); do
        ln -sfn "$(realpath "$2/${3}_s1_$(printf %04d "$i")")" "$WORK/groups/$1/"
    done
}
render_group() {  # render_group GROUP G: the sets of groups/GROUP under probe pair G
    "$BIN/render-dataset" --probes "$WORK/probes/pair$2" --svbrdfs "$WORK/groups/$1" \
        --out "$WORK/heldout/$1" --resolution 256 --render-size 512 --rotations 1 \
        --crops 1 --spp 128 --test-materials 0 --test-probes 0
}
for class in $CLASSES; do
    for g in 0 1 2 3; do
        mkdir -p "$WORK/groups/$class-$g"
        link_sets "$class-$g" "$WORK/sets/$class" "$class" $((g * 10)) $((g * 10 + 9))
        for set in $(real_sets "$class"); do
            ln -sfn "$(realpath "$SHARED/svbrdfs/$set")" "$WORK/groups/$class-$g/"
        done
        render_group "$class-$g" "$g"
    done
done
if (( MORE_SETS > 0 )); then  # the larger tests' further sets and renders
    for class in $CLASSES; do
        if [ ! -d "$WORK/sets/$class-more" ]; then  # make-materials draws set i from (seed, i)
            "$BIN/make-materials" --class "$class" --count $((40 + MORE_SETS)) --seed 1 \
                --resolution 512 --out "$WORK/sets/$class-more"
        fi
        per_group=$((MORE_SETS / 4))
        for g in 0 1 2 3; do
            mkdir -p "$WORK/groups/$class-more-$g"
            link_sets "$class-more-$g" "$WORK/sets/$class-more" "$class" \
                $((40 + g * per_group)) $((39 + (g + 1) * per_group))
            render_group "$class-more-$g" "$g"
        done
    done
fi
datasets() {  # --dataset options of the classes given
    for class in "$@"; do for g in 0 1 2 3; do echo --dataset "$WORK/heldout/$class-$g"; done; done
}
for class in $CLASSES; do
    "$BIN/sa-evaluate" --model "$MODELS/svbrdf-$class.safetensors" $(datasets "$class") \
        --split all --probes "$WORK/probes" --samples 96 --out "$WORK/eval/$class" \
        > "$WORK/eval/$class.json"
    if (( MORE_SETS > 0 )); then
        "$BIN/sa-evaluate" --model "$MODELS/svbrdf-$class.safetensors" $(datasets "$class") \
            $(for g in 0 1 2 3; do echo --dataset "$WORK/heldout/$class-more-$g"; done) \
            --split all --probes "$WORK/probes" --samples 100000 \
            --out "$WORK/eval/$class-larger" > "$WORK/eval/$class-larger.json"
    fi
done
