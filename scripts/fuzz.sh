#!/usr/bin/env bash
# libFuzzer run of the asset loader (tests/c/fuzz_asset.c: plAssetData_Parse with the checksum checked and skipped,
# under ASan + UBSan). Installs Debian's clang and libFuzzer runtime with apt when clang is missing, builds build/fuzz
# with CC=clang -DPLEAT_FUZZ=ON, seeds out/fuzz/corpus with small valid assets (tests/c/fuzz_asset_seed.c) and runs
# for FUZZ_SECONDS (60). A crash leaves its input in out/fuzz/ (crash-*) and makes this script fail.
# Environment: FUZZ_SECONDS (60), BUILD_DIR (build/fuzz).
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${BUILD_DIR:-build/fuzz}
OUT=out/fuzz
if ! command -v clang >/dev/null 2>&1; then
  SUDO=""
  [ "$(id -u)" -ne 0 ] && SUDO=sudo
  $SUDO apt-get install -y --no-install-recommends clang libclang-rt-14-dev >/dev/null
fi
CC=clang cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPLEAT_FUZZ=ON -DPLEAT_GL=OFF \
  -DPLEAT_BUILD_TESTS=ON >/dev/null
cmake --build "$BUILD_DIR" --target fuzz_asset fuzz_asset_seed >/dev/null
mkdir -p "$OUT/corpus"
"$BUILD_DIR/tests/c/fuzz_asset_seed" "$OUT/corpus"
# -max_len: the seeds are a few KB; allow growth to 64 KB. -rss_limit_mb: the parser must not allocate per input.
status=0
nice "$BUILD_DIR/tests/c/fuzz_asset" "$OUT/corpus" -max_total_time="${FUZZ_SECONDS:-60}" -max_len=65536 \
  -rss_limit_mb=2048 -print_final_stats=1 -artifact_prefix="$OUT/" >"$OUT/fuzz.log" 2>&1 || status=$?
grep -E "INITED|DONE|ERROR|SUMMARY|stat::" "$OUT/fuzz.log" | tail -20 || true
if [ "$status" -ne 0 ] || ls "$OUT"/crash-* "$OUT"/leak-* "$OUT"/timeout-* >/dev/null 2>&1; then
  echo "fuzz.sh: the fuzzer found a problem (exit $status); see $OUT/fuzz.log and the artifacts in $OUT/" >&2
  exit 1
fi
