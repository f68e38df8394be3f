#!/usr/bin/env bash
# Stage 1 on a lent GPU, in one call (docs/training-speed.md, "The GPU route"): the throughput bench (the old per-window
# path on that machine's CPU against the batched path on the GPU, alternately, with the nearest-body search in the
# KD-trees or on the device, and larger batches), then a short real run of the trainer at the GPU recipe. On an H100
# with 16 host cores 12 workers and the trees gave 21x at K = 64 (a first call with 8 workers, "torch,kdtree" and
# --bf16 gave less; docs/training-speed.md, "The GPU route").
#
# The machine has no network and no .venv: it runs its own python3 (torch, numpy, scipy) with PYTHONPATH=tools, the
# garment as an npz (generating one needs gpytoolbox) and the motion from data/motion. Prepare here, then carry data:
#   pleat-garment tshirt --vertices 1000 --out data/garments/tshirt.npz && cp -r ../shared/motion data/motion
#   (device run, carry ["data"]) bash bench/gpu_stage1.sh        # results in $OUT (default out/gpu)
# BENCH_S, TRAIN_MIN and TRAIN_S bound the two parts so that the call ends inside its limit.
set -uo pipefail
cd "$(dirname "$0")/.."
OUT=${OUT:-out/gpu}
mkdir -p "$OUT"
PY=${PYTHON:-python3}
GARMENT=${GARMENT:-data/garments/tshirt.npz}
export PYTHONPATH=tools PYTHONUNBUFFERED=1 PYTHONHASHSEED=0 PLEAT_MOTION_DIR=${PLEAT_MOTION_DIR:-data/motion}

{ nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader
  echo "cpu: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2)"
  $PY -c "import torch, numpy, scipy; print('torch', torch.__version__, 'numpy', numpy.__version__, 'scipy', scipy.__version__)"
} 2>&1 | tee "$OUT/machine.txt"

timeout "${BENCH_S:-270}" $PY bench/train_throughput.py --stages stage1 --garment "$GARMENT" --device cuda \
    --windows 32 --worker --data-workers 12 --nearest kdtree,torch --more-windows 64,128 \
    --rounds 3 --iterations 2 --json "$OUT/train_throughput.json" 2>&1 | tee "$OUT/bench.log"

run=$(mktemp -d)
timeout "${TRAIN_S:-180}" $PY -m pleat.train.cli stage1 --preset default --garment "$GARMENT" \
    --device cuda --set stage1.windows_per_iteration=64 --set stage1.data_worker=12 \
    --set 'stage1.autocast_bf16="auto"' --max-minutes "${TRAIN_MIN:-1.5}" --out "$run" --no-progress 2>&1 \
    | tail -4 | tee "$OUT/train.log"
cp "$run/metrics_stage1.jsonl" "$OUT/" 2>/dev/null
exit 0
