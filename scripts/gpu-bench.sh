#!/usr/bin/env bash
# GPU crowd benchmark (not a test): n t-shirts stepped with plStepInstances in one GL context, the networks on the GPU
# (PLEAT_MLP_BACKEND_GPU) against the networks on the CPU, for 1, 64, 640 and 4,096 instances (bench/gl_crowd_timing.c
# says what each figure is). Writes OUT_JSON (default out/bench/gpu-crowd.json) with the GL renderer, driver and CPU,
# and prints a line per count. On Mesa llvmpipe it runs (a smoke test of the route) but its GPU times read 0; the
# figures in docs/gpu.md come from a lent GPU, their JSON committed under bench/results/.
#
# Environment: COUNTS (default 1,64,640,4096), FRAMES (60), ASSET (assets/tshirt.pleat), BUILD_DIR (build/gpu-bench),
# BIN (a prebuilt pleat_gl_crowd_timing: skips the build). A lent GPU machine has no network and no toolchain of ours:
# bench/gpu_crowd.sh prepares the binaries and libraries here and runs this script there with BIN set.
set -euo pipefail
cd "$(dirname "$0")/.."
COUNTS=${COUNTS:-1,64,640,4096}
FRAMES=${FRAMES:-60}
ASSET=${ASSET:-assets/tshirt.pleat}
BUILD_DIR=${BUILD_DIR:-build/gpu-bench}
OUT_JSON=${OUT_JSON:-out/bench/gpu-crowd.json}
if [ -z "${BIN:-}" ]; then
  cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=Release -DPLEAT_BUILD_TESTS=OFF >/dev/null
  cmake --build "$BUILD_DIR" --target pleat_gl_crowd_timing >/dev/null
  BIN="$BUILD_DIR/bench/pleat_gl_crowd_timing"
fi
mkdir -p "$(dirname "$OUT_JSON")"
"$BIN" --frames "$FRAMES" --counts "$COUNTS" --out "$OUT_JSON.tmp" "$ASSET"
# The command beside the figures (the JSON's last brace replaced).
python3 - "$OUT_JSON.tmp" "$OUT_JSON" "COUNTS=$COUNTS FRAMES=$FRAMES ASSET=$ASSET scripts/gpu-bench.sh" <<'PY'
import json, sys
data = json.load(open(sys.argv[1]))
data["command"] = sys.argv[3]
json.dump(data, open(sys.argv[2], "w"), indent=2)
PY
rm -f "$OUT_JSON.tmp"
echo "wrote $OUT_JSON"
