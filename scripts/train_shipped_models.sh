#!/usr/bin/env bash
# Trains the shipped models (models/README.md) on one GPU, the three networks concurrently:
# procedural material sets per class (make-materials, 400 sets of 512 px each: 50 of each seed
# in SEEDS), labeled
# minibatches rendered on the fly from them (sa-train --labeled-maps) under the training probes,
# the `compact` network at 256 px.
# Each run stops after MINUTES (default 6); its newest checkpoint (an epoch's end) is exported
# as models/svbrdf-<name>.safetensors-like files into OUT_DIR; the runs live in
# OUT_DIR/runs/<name>, so each stage (OUT_DIR) has its own.
#
# Environment: NAMES (networks to train, default all three); INIT (a folder of svbrdf-<name>
# .safetensors files to start from: fine-tuning, see models/README.md); LEARNING_RATE.
#
#   bash scripts/train_shipped_models.sh WORK PROBES OUT_DIR [MINUTES] [PYTHON]
set -euo pipefail
WORK=$1 PROBES=$2 OUT_DIR=$3 MINUTES=${4:-6} PY=${5:-.venv/bin/python}
NAMES=${NAMES:-wood plastic metal} LEARNING_RATE=${LEARNING_RATE:-0.002}
EPOCH_SAMPLES=3200  # 200 minibatches of 16: a checkpoint at every epoch's end
SEEDS="0 2 3 4 5 6 7 8"  # seed 1 makes the held-out sets
SETS_PER_SEED=50
mkdir -p "$OUT_DIR"
for class in wood plastic metal; do
    for seed in $SEEDS; do
        "$PY" -m render.cli.make_materials --class "$class" --count "$SETS_PER_SEED" --seed "$seed" \
            --resolution 512 --out "$WORK/sets/$class-$seed" > "$WORK/sets-$class-$seed.log" 2>&1 &
    done
done
wait
for class in wood plastic metal; do
    mkdir -p "$WORK/maps/$class"
    for seed in $SEEDS; do
        for set in "$WORK/sets/$class-$seed"/*/; do
            ln -sfn "$(realpath "$set")" "$WORK/maps/$class/"
        done
    done
done
for name in $NAMES; do
    init=()
    if [ -n "${INIT:-}" ]; then init=(--init-from "$INIT/svbrdf-$name.safetensors"); fi
    OMP_NUM_THREADS=4 timeout "$((MINUTES * 60))" "$PY" -m train.cli.sa_train "${init[@]}" \
        --labeled-maps "$WORK/maps/$name" --probes "$PROBES" --out "$OUT_DIR/runs/$name" \
        --network compact --labeled-epochs 100 --self-augmented-epochs 0 --lr-gamma 1e-3 \
        --learning-rate "$LEARNING_RATE" \
        --epoch-samples "$EPOCH_SAMPLES" --checkpoint-every 200 --log-every 50 \
        --device cuda > "$WORK/train-$name.log" 2>&1 &
done
wait || true
for name in $NAMES; do
    "$PY" scripts/export_model.py "$OUT_DIR/runs/$name" "$OUT_DIR/svbrdf-$name.safetensors" \
        --class "$name" --recipe "scripts/train_shipped_models.sh, $MINUTES min, lr $LEARNING_RATE, from ${INIT:-scratch}"
done
