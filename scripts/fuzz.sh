#!/usr/bin/env bash
# libFuzzer runs of the two fuzz targets under ASan + UBSan (both non-recoverable: any finding stops the run):
#   fuzz_asset           raw bytes into the loader (tests/c/fuzz_asset.c), then the runtime on what it accepts;
#   fuzz_asset_semantic  a control block + a valid asset whose section contents are mutated (CRC recomputed), loaded
#                        and driven through the public API with varied defs (tests/c/fuzz_asset_semantic.c).
# Installs Debian's clang and libFuzzer runtime with apt when clang is missing, builds BUILD_DIR with CC=clang
# -DPLEAT_FUZZ=ON and seeds out/fuzz/<target>/corpus at run time: small assets from the C test asset builder
# (fuzz_asset_seed) and from pleat-pack's writer in the project venv (tests/c/fuzz_seeds.py: PINS, OXLP/OXDC, the SMPL
# skeleton, no β). The semantic target's ONNX Runtime path runs when the venv has the onnxruntime wheel.
# Each target runs for FUZZ_SECONDS; a crash leaves its input in out/fuzz/<target>/ (crash-*) and fails the script.
# FUZZ_COVERAGE=1 then replays each corpus through a coverage build (BUILD_DIR-coverage) and writes llvm-cov's
# per-file line coverage to out/fuzz/<target>/coverage.txt.
# Environment: FUZZ_SECONDS (60 per target), FUZZ_TARGETS ("fuzz_asset fuzz_asset_semantic"), FUZZ_COVERAGE (0),
# BUILD_DIR (build/fuzz), FUZZ_OUT (out/fuzz).
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${BUILD_DIR:-build/fuzz}
OUT=${FUZZ_OUT:-out/fuzz}
TARGETS=${FUZZ_TARGETS:-fuzz_asset fuzz_asset_semantic}
SECONDS_PER_TARGET=${FUZZ_SECONDS:-60}

# clang 14 is Debian 12's; libclang-rt-14-dev carries libFuzzer and the sanitizer runtimes, llvm the coverage tools.
need=""
command -v clang >/dev/null 2>&1 || need="clang libclang-rt-14-dev"
if [ "${FUZZ_COVERAGE:-0}" = 1 ] && ! command -v llvm-profdata >/dev/null 2>&1; then need="$need llvm"; fi
if [ -n "$need" ]; then
  echo "fuzz.sh: installing Debian packages: $need"
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends $need >/dev/null
fi

build() { # build DIR TARGETS CMAKE_ARGS...: quiet unless it fails
  local dir=$1 targets=$2; shift 2
  mkdir -p "$dir"
  if ! { CC=clang cmake -S . -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPLEAT_FUZZ=ON -DPLEAT_GL=OFF \
           -DPLEAT_BUILD_TESTS=ON "$@" && nice cmake --build "$dir" --target $targets; } >"$dir/fuzz-build.log" 2>&1; then
    cat "$dir/fuzz-build.log" >&2
    echo "fuzz.sh: the build in $dir failed" >&2
    exit 1
  fi
}
build "$BUILD_DIR" "$TARGETS fuzz_asset_seed" -DPLEAT_FUZZ_COVERAGE=OFF

# Seeds, written fresh each run next to what earlier runs found.
seeds=$(mktemp -d)
trap 'rm -rf "$seeds"' EXIT
mkdir -p "$seeds/raw" "$seeds/semantic"
if [ -x .venv/bin/python ]; then
  PYTHONPATH="$PWD/tools" .venv/bin/python tests/c/fuzz_seeds.py "$seeds/raw" ||
    echo "fuzz.sh: note: the pleat-pack seeds failed; C seeds only" >&2
  ort=$(.venv/bin/python -c "import glob, os, onnxruntime as o; print((glob.glob(os.path.join(os.path.dirname(o.__file__), 'capi', 'libonnxruntime.so*')) or [''])[0])" 2>/dev/null || true)
  [ -n "$ort" ] && [ -z "${PLEAT_ONNXRUNTIME_LIBRARY:-}" ] && export PLEAT_ONNXRUNTIME_LIBRARY="$ort"
else
  echo "fuzz.sh: note: no .venv (scripts/setup.sh); the pleat-pack seeds (PINS, OXLP/OXDC) are skipped" >&2
fi
"$BUILD_DIR/tests/c/fuzz_asset_seed" "$seeds/raw" "$seeds/semantic"

status=0
for target in $TARGETS; do
  dir="$OUT/$target"
  mkdir -p "$dir/corpus"
  if [ "$target" = fuzz_asset_semantic ]; then cp "$seeds"/semantic/* "$dir/corpus/"; max_len=262144
  else cp "$seeds"/raw/* "$dir/corpus/"; max_len=131072; fi
  # -rss_limit_mb: the loader and an instance of a seed-sized asset need a few MB; growth means a leak.
  # -timeout: one input runs in milliseconds; 10 s is a hang.
  s=0
  LSAN_OPTIONS="suppressions=$PWD/tests/sanitizers/lsan-libc.supp:print_suppressions=0" \
  nice "$BUILD_DIR/tests/c/$target" "$dir/corpus" -max_total_time="$SECONDS_PER_TARGET" -max_len=$max_len \
    -rss_limit_mb=2048 -timeout=10 -print_final_stats=1 -artifact_prefix="$dir/" >"$dir/fuzz.log" 2>&1 || s=$?
  echo "== $target ($SECONDS_PER_TARGET s)"
  grep -E "INITED|DONE|ERROR|SUMMARY|contract broken|stat::number_of_executed_units|stat::average_exec_per_sec|stat::peak_rss_mb" \
    "$dir/fuzz.log" | tail -12 || true
  if [ "$s" -ne 0 ] || ls "$dir"/crash-* "$dir"/leak-* "$dir"/timeout-* "$dir"/oom-* >/dev/null 2>&1; then
    echo "fuzz.sh: $target found a problem (exit $s); see $dir/fuzz.log and the artifacts in $dir/" >&2
    status=1
  fi
done

if [ "${FUZZ_COVERAGE:-0}" = 1 ]; then
  build "$BUILD_DIR-coverage" "$TARGETS" -DPLEAT_FUZZ_COVERAGE=ON
  for target in $TARGETS; do
    dir="$OUT/$target"
    rm -f "$dir"/coverage-*.profraw
    # -runs=0: execute every corpus input once, no mutation.
    LLVM_PROFILE_FILE="$PWD/$dir/coverage-%p.profraw" nice "$BUILD_DIR-coverage/tests/c/$target" "$dir/corpus" \
      -runs=0 >"$dir/coverage-run.log" 2>&1 || true
    llvm-profdata merge -sparse "$dir"/coverage-*.profraw -o "$dir/coverage.profdata"
    llvm-cov report "$BUILD_DIR-coverage/tests/c/$target" -instr-profile="$dir/coverage.profdata" \
      "$PWD/sdk/src" >"$dir/coverage.txt"
    rm -f "$dir"/coverage-*.profraw
    echo "== $target line coverage of sdk/src over $(ls "$dir/corpus" | wc -l) corpus inputs ($dir/coverage.txt)"
    awk 'NR > 2 && NF >= 10 && $1 !~ /^-/ { printf "  %-28s lines %6s of %5s\n", $1, $(NF-3), $(NF-5) }' "$dir/coverage.txt"
  done
fi
exit $status
