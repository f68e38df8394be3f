#!/usr/bin/env bash
# The GPU path's checks and the GPU crowd benchmark on a lent GPU machine, in one call (docs/gpu.md, "Timings"). That
# machine has no network and none of our toolchain or packages, so everything is prepared here and carried:
#
#   bench/gpu_crowd.sh prepare
#       here: a Release build with the GL path and its tests (build/gpu); the GL tests and the crowd timing program
#       copied to out/gpu-bin, with glvnd's loader, libepoxy and cmocka unpacked from their Debian packages into
#       out/gpu-bin/lib (a GPU container may ship the NVIDIA EGL vendor library without glvnd's libEGL.so.1)
#   (device run, carry ["out/gpu-bin"]) bench/gpu_crowd.sh run
#       there: the machine (nvidia-smi, CPU), the GL tests (the networks on the GPU against the CPU, the two-device
#       scene, the deformation, batches, the headless route), then scripts/gpu-bench.sh for 1, 64, 640 and 4,096
#       t-shirts; everything under $OUT (default out/gpu): machine.txt, tests.log, gpu-crowd.json, bench.log.
#
# TEST_S and BENCH_S bound the two parts (seconds) so that the call ends inside its limit; COUNTS and FRAMES pass on to
# scripts/gpu-bench.sh. Commit the JSON as bench/results/gpu-crowd-<gpu>.json with the device, driver and command.
set -uo pipefail
cd "$(dirname "$0")/.."
BIN_DIR=out/gpu-bin
GL_TESTS="test_gl_headless_reports_platform test_gl_deformer test_gl_instance test_gl_batch_matches_single
          test_gl_networks test_gl_scene_two_devices"

prepare() {
  set -e
  cmake -S . -B build/gpu -G Ninja -DCMAKE_BUILD_TYPE=Release -DPLEAT_BUILD_TESTS=ON >/dev/null
  cmake --build build/gpu --target pleat_gl_crowd_timing $GL_TESTS >/dev/null
  rm -rf "$BIN_DIR" && mkdir -p "$BIN_DIR/lib" "$BIN_DIR/debs"
  cp build/gpu/bench/pleat_gl_crowd_timing "$BIN_DIR/"
  for t in $GL_TESTS; do cp "build/gpu/$t" "$BIN_DIR/"; done
  ( cd "$BIN_DIR/debs" && apt-get download libegl1 libglvnd0 libopengl0 libgl1 libglx0 libgles2 libepoxy0 libcmocka0 \
      >/dev/null 2>&1 )
  for deb in "$BIN_DIR"/debs/*.deb; do dpkg -x "$deb" "$BIN_DIR/debs/root"; done
  find "$BIN_DIR/debs/root" -name '*.so*' -exec cp -P {} "$BIN_DIR/lib/" \;
  rm -rf "$BIN_DIR/debs"
  du -sh "$BIN_DIR"
}

run() {
  OUT=${OUT:-out/gpu}
  mkdir -p "$OUT"
  export LD_LIBRARY_PATH="$PWD/$BIN_DIR/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
  { nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader 2>&1 || echo "no nvidia-smi"
    echo "cpu: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2)"
  } | tee "$OUT/machine.txt"
  local deadline=$(( SECONDS + ${TEST_S:-150} ))
  for t in $GL_TESTS; do
    left=$(( deadline - SECONDS )); [ "$left" -gt 5 ] || { echo "$t: no time left" | tee -a "$OUT/tests.log"; continue; }
    echo "== $t" >> "$OUT/tests.log"
    timeout "$left" "$BIN_DIR/$t" >> "$OUT/tests.log" 2>&1; echo "$t: rc $?" | tee -a "$OUT/tests.log"
  done
  timeout "${BENCH_S:-300}" env BIN="$BIN_DIR/pleat_gl_crowd_timing" OUT_JSON="$OUT/gpu-crowd.json" \
      scripts/gpu-bench.sh 2>&1 | tee "$OUT/bench.log"
}

case "${1:-}" in
  prepare) prepare ;;
  run) run ;;
  *) echo "usage: bench/gpu_crowd.sh prepare | run" >&2; exit 2 ;;
esac
