#!/usr/bin/env bash
# Benchmark (not a test): builds Pleat in Release, makes the 4,424-vertex reference-size assets (bench/make_assets.py)
# and runs bench/bench_step.c, then the per-phase breakdown (pleat_bench_phases --phases, merged in as "phase_us", and
# for the shipped t-shirt as "tshirt_phase_us"); writes out/bench/step.json and prints it. See docs/benchmarks.md.
# Environment: BUILD_DIR (default build/bench), ITERATIONS (default 2000), WARMUP (200), SCALAR_ITERATIONS (300),
# CLOCK (wall, default, or cpu = the thread's CPU time, for a busy shared machine), PLEAT_ONNXRUNTIME_LIBRARY (default:
# libonnxruntime.so* of the onnxruntime wheel in .venv). OUT_JSON (default out/bench/step.json). The crowd sweep:
# CROWD_COUNTS (1,8,64,256), CROWD_SECONDS (0.5 per case and round), CROWD_ROUNDS (3), CROWD_CLOCK (wall); then the
# 64-instance crowd's stages (pleat_bench_crowd_phases, "crowd_phases").
set -euo pipefail
cd "$(dirname "$0")/.."
if ! setup_log=$(scripts/setup.sh 2>&1); then echo "$setup_log" >&2; exit 1; fi
BUILD_DIR=${BUILD_DIR:-build/bench}
OUT=out/bench
PY="$PWD/.venv/bin/python"

cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=Release -DPLEAT_BUILD_TESTS=OFF -DPLEAT_PYTHON="$PY" >/dev/null
cmake --build "$BUILD_DIR" --target pleat_bench_step pleat_bench_phases pleat_bench_crowd pleat_bench_crowd_phases >/dev/null

mkdir -p "$OUT"
if [ ! -f "$OUT/asset_fp32.pleat" ] || [ ! -f "$OUT/asset_fp16.pleat" ] || [ ! -f "$OUT/case.bin" ] \
   || [ bench/make_assets.py -nt "$OUT/case.bin" ] || [ tools/pleat/reference/golden.py -nt "$OUT/case.bin" ] \
   || [ tools/pleat/asset.py -nt "$OUT/case.bin" ]; then
  # (golden.py makes the weights, asset.py writes them: a change to either changes what is measured)
  "$PY" bench/make_assets.py "$OUT" --vertices 4424 --frames 300
fi

if [ ! -f "$OUT/tshirt_fp32.pleat" ] || [ ! -f "$OUT/tshirt_fp16.pleat" ] || [ assets/tshirt.pleat -nt "$OUT/tshirt_fp32.pleat" ]; then
  "$PY" bench/make_crowd_assets.py assets/tshirt.pleat "$OUT"
fi

# int8 networks (ranged inputs) of both, with fp16 blend shapes (the crowd sweep's int8 keys) and with int8 blend
# shapes (int8s: everything int8)
for pair in "asset_fp32:asset_int8" "tshirt_fp32:tshirt_int8" "asset_fp32:asset_int8s" "tshirt_fp32:tshirt_int8s"; do
  src="$OUT/${pair%%:*}.pleat" dst="$OUT/${pair##*:}.pleat"
  if [ ! -f "$dst" ] || [ "$src" -nt "$dst" ] || [ tools/pleat/quantise.py -nt "$dst" ] \
     || [ tools/pleat/asset.py -nt "$dst" ]; then
    shapes=()
    [ "${dst%s.pleat}" != "$dst" ] && shapes=(--int8-blend-shapes)
    "$PWD/.venv/bin/pleat-pack" "$src" --int8 --fp16 "${shapes[@]}" -o "$dst" --quiet
  fi
done

ORT_LIB=${PLEAT_ONNXRUNTIME_LIBRARY:-$("$PY" - <<'PY' 2>/dev/null || true
import glob, os, onnxruntime
print(sorted(glob.glob(os.path.join(os.path.dirname(onnxruntime.__file__), "capi", "libonnxruntime.so*")))[0])
PY
)}
ort_args=()
[ -n "$ORT_LIB" ] && ort_args=(--onnxruntime "$ORT_LIB")

"$BUILD_DIR/bench/pleat_bench_step" --asset "$OUT/asset_fp32.pleat" --asset-fp16 "$OUT/asset_fp16.pleat" \
  --case "$OUT/case.bin" --iterations "${ITERATIONS:-2000}" --warmup "${WARMUP:-200}" \
  --scalar-iterations "${SCALAR_ITERATIONS:-300}" --clock "${CLOCK:-wall}" "${ort_args[@]}" \
  --out "${OUT_JSON:-$OUT/step.json}"
# Per-phase medians of one-thread steps (the library copy built with PLEAT_STEP_PHASES), merged in as phase_us.
"$BUILD_DIR/bench/pleat_bench_phases" --phases --asset "$OUT/asset_fp32.pleat" --asset-fp16 "$OUT/asset_fp16.pleat" \
  --case "$OUT/case.bin" --iterations "${ITERATIONS:-2000}" --warmup "${WARMUP:-200}" --clock "${CLOCK:-wall}" \
  --out "$OUT/phases.json"
# The same phases for the shipped t-shirt (fp32 and fp16, the shipped precision): its full body contact shows there
# (body_contact); merged in as "tshirt_phase_us".
"$BUILD_DIR/bench/pleat_bench_phases" --phases --asset "$OUT/tshirt_fp32.pleat" --asset-fp16 "$OUT/tshirt_fp16.pleat" \
  --case "$OUT/case.bin" --iterations "${ITERATIONS:-2000}" --warmup "${WARMUP:-200}" --clock "${CLOCK:-wall}" \
  --out "$OUT/tshirt_phases.json"
# Crowds (docs/scene-budget.md): plStepInstances against one-by-one plInstance_Step, per instance, for 1, 8,
# 64 and 256 instances of the shipped t-shirt and of the reference-size assets (fp32, fp16, int8, int8s), 1 and 2 workers,
# the whole sweep three times (medians over the rounds: a neighbour busy for a few seconds spoils one round, not the number); merged in as
# "crowd".
"$BUILD_DIR/bench/pleat_bench_crowd" --case "$OUT/case.bin" \
  --asset tshirt_fp32="$OUT/tshirt_fp32.pleat" --asset tshirt_fp16="$OUT/tshirt_fp16.pleat" \
  --asset reference_fp32="$OUT/asset_fp32.pleat" --asset reference_fp16="$OUT/asset_fp16.pleat" \
  --asset tshirt_int8="$OUT/tshirt_int8.pleat" --asset reference_int8="$OUT/asset_int8.pleat" \
  --asset tshirt_int8s="$OUT/tshirt_int8s.pleat" --asset reference_int8s="$OUT/asset_int8s.pleat" \
  --counts "${CROWD_COUNTS:-1,8,64,256}" --workers 1,2 --seconds "${CROWD_SECONDS:-0.5}" --rounds "${CROWD_ROUNDS:-3}" \
  --clock "${CROWD_CLOCK:-wall}" \
  --out "$OUT/crowd.json"
# Where a 64-instance crowd step's time goes (the library copy built with PLEAT_STEP_PHASES: prepare, networks, blend,
# geometry, finish per instance), one round; merged in as "crowd_phases".
"$BUILD_DIR/bench/pleat_bench_crowd_phases" --case "$OUT/case.bin" \
  --asset tshirt_fp32="$OUT/tshirt_fp32.pleat" --asset tshirt_fp16="$OUT/tshirt_fp16.pleat" \
  --asset reference_fp32="$OUT/asset_fp32.pleat" --asset reference_fp16="$OUT/asset_fp16.pleat" \
  --asset tshirt_int8="$OUT/tshirt_int8.pleat" --asset reference_int8="$OUT/asset_int8.pleat" \
  --asset tshirt_int8s="$OUT/tshirt_int8s.pleat" --asset reference_int8s="$OUT/asset_int8s.pleat" \
  --counts 64 --workers 1,2 --seconds "${CROWD_SECONDS:-0.5}" --rounds 1 --only batch --clock "${CROWD_CLOCK:-wall}" \
  --out "$OUT/crowd_phases.json"
"$PY" - "${OUT_JSON:-$OUT/step.json}" "$OUT/phases.json" "$OUT/crowd.json" "$OUT/crowd_phases.json" \
  "$OUT/tshirt_phases.json" <<'PY'
import json, sys
step = json.load(open(sys.argv[1]))
step["phase_us"] = json.load(open(sys.argv[2]))
step["crowd"] = json.load(open(sys.argv[3]))
step["crowd_phases"] = json.load(open(sys.argv[4]))
step["tshirt_phase_us"] = json.load(open(sys.argv[5]))
json.dump(step, open(sys.argv[1], "w"), indent=2)
PY
cat "${OUT_JSON:-$OUT/step.json}"
