#!/usr/bin/env bash
# Fine-tunes shipped networks on a CPU (models/README.md, "stage 3"): one network of the
# three at a time (NETWORK: homogeneous or albedo), starting from the shipped file (or from
# INIT_DIR/svbrdf-CLASS.safetensors, an earlier fine-tune's output), with the
# relit loss (sa-train --relit-loss-weight) added to the parameter losses; labeled minibatches
# rendered on the fly under the 26 training probes from 200 procedural sets of the class
# (make-materials seeds 0, 2, 3, 4; seed 1 makes the held-out sets). The runs
# live in OUT_DIR/runs/CLASS; re-run with the same OUT_DIR after an interruption, it resumes
# each run from its newest checkpoint.
#
# Environment: NETWORK (default homogeneous; a comma-separated list trains several), EPOCHS
# (of 200 steps, default 10), RELIT_WEIGHT (default 300), LEARNING_RATE (default 0.0005),
# ALBEDO_LOSS (linear or log, default linear), SPECULAR (own or mix: sa-train
# --mix-specular; default own), POOLING (flatten or mean: sa-train --homogeneous-pooling;
# mean starts a new homogeneous network beside the file's map networks; default flatten),
# ALBEDO_NETWORK (map or photo-affine: sa-train --albedo-network; another kind than the
# starting file's starts a new albedo network, NETWORK must include albedo; default: the
# starting file's),
# RELIT_PARTNERS (truth or estimate: sa-train --relit-partners; default truth),
# RELIT_FORM (log or rmse: sa-train --relit-loss-form; default log),
# PROBE_TILTS (tilted copies of each training probe: sa-train --probe-tilts; default 0),
# SEEDS (a class's
# make-materials seeds, each SEED or SEED:COUNT sets, default "0 2 3 4" of 50 sets each).
#
#   bash scripts/finetune_shipped_models_cpu.sh WORK PROBES_TRAIN OUT_DIR CLASS...
set -euo pipefail
WORK=$1 PROBES=$2 OUT_DIR=$3
shift 3
NETWORK=${NETWORK:-homogeneous} EPOCHS=${EPOCHS:-10} RELIT_WEIGHT=${RELIT_WEIGHT:-300}
LEARNING_RATE=${LEARNING_RATE:-0.0005} ALBEDO_LOSS=${ALBEDO_LOSS:-linear} BIN=${BIN:-.venv/bin}
SPECULAR=${SPECULAR:-own} INIT_DIR=${INIT_DIR:-models} POOLING=${POOLING:-flatten}
RELIT_PARTNERS=${RELIT_PARTNERS:-truth} RELIT_FORM=${RELIT_FORM:-log}
PROBE_TILTS=${PROBE_TILTS:-0}
mkdir -p "$OUT_DIR"
link_sets() {  # link_sets CLASS SEED[:COUNT]...: make missing sets, link them into the maps
    local class=$1 seed count
    shift
    for each in "$@"; do
        seed=${each%%:*} count=50
        [ "$each" != "$seed" ] && count=${each#*:}
        if [ ! -d "$WORK/sets/$class-$seed" ]; then
            "$BIN/make-materials" --class "$class" --count "$count" --seed "$seed" \
                --resolution 512 --out "$WORK/sets/$class-$seed"
        fi
        for set in "$WORK/sets/$class-$seed"/*/; do ln -sfn "$(realpath "$set")" "$MAPS/"; done
    done
}
for class in "$@"; do
    MAPS="$WORK/maps/$class"
    mkdir -p "$MAPS"
    link_sets "$class" ${SEEDS:-0 2 3 4}
    run="$OUT_DIR/runs/$class"  # each stage (OUT_DIR) has its own run folders
    init="$INIT_DIR/svbrdf-$class.safetensors"
    albedo_network=${ALBEDO_NETWORK:-$("$BIN/python" -c "import sys
from train.networks.model_files import shipped_network_config
print(shipped_network_config(sys.argv[1]).albedo_network)" "$init")}
    "$BIN/sa-train" --init-from "$init" --train-networks "$NETWORK" \
        --homogeneous-pooling "$POOLING" --albedo-network "$albedo_network" \
        --relit-loss-weight "$RELIT_WEIGHT" --relit-loss-size 64 \
        --relit-partners "$RELIT_PARTNERS" --relit-loss-form "$RELIT_FORM" \
        --albedo-loss "$ALBEDO_LOSS" --probe-tilts "$PROBE_TILTS" \
        --"$SPECULAR"-specular --labeled-maps "$WORK/maps/$class" --probes "$PROBES" \
        --out "$run" --network compact --labeled-epochs "$EPOCHS" --self-augmented-epochs 0 \
        --learning-rate "$LEARNING_RATE" --lr-gamma 1e-3 --epoch-samples 3200 \
        --checkpoint-every 200 --log-every 50
    "$BIN/python" scripts/export_model.py "$run" "$OUT_DIR/svbrdf-$class.safetensors" \
        --class "$class" --recipe "scripts/finetune_shipped_models_cpu.sh: $NETWORK, $EPOCHS epochs, relit weight $RELIT_WEIGHT, relit partners $RELIT_PARTNERS, relit loss $RELIT_FORM, $PROBE_TILTS tilted probe copies, lr $LEARNING_RATE, albedo loss $ALBEDO_LOSS, $SPECULAR specular, $POOLING pooling, $albedo_network albedo network, sets of seeds ${SEEDS:-0 2 3 4}, from $init"
done
