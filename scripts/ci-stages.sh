#!/usr/bin/env bash
# The CI stages of .ci/run: what ships is what is tested. Each stage builds in its own build/ci-<stage> directory, so
# any subset runs locally on its own:
#
#     PLEAT_CI_STAGES="asan tsan" scripts/ci-stages.sh
#
#   default  scripts/test.sh: Debug build, warnings as errors, ctest, the Python tests (the README's test command)
#   release  Release build (what ships) + ctest
#   asan     ASan + UBSan, nothing recoverable, leaks checked (tests/sanitizers/lsan-mesa.supp: leaks inside Mesa
#            only) + ctest, GL tests on llvmpipe included
#   tsan     ThreadSanitizer + the "threads" tests: the multi-worker determinism test and two threads stepping
#            different instances at once
#   scalar   PLEAT_FORCE_SCALAR=ON Release build (no AVX2 kernels compiled) + ctest
#   fuzz     scripts/fuzz.sh: both libFuzzer targets for PLEAT_CI_FUZZ_SECONDS each (60)
#   soak     test_soak_live_bytes_flat for PLEAT_CI_SOAK_STEPS steps (100,000) on the release build: live bytes flat
#   slow     the pytest tests marked slow (PLEAT_SLOW_TESTS=1 -m slow); the others ran in `default`, the CLI
#            bad-input tests among them
#   blender  the Blender add-on's headless round trip (tests/python/test_blender_roundtrip.py) and Blender's cloth as
#            a teacher (test_blender_teacher.py), in Blender as a Python module: installs the blender extra (bpy
#            4.4.0, a ~370 MB wheel for Python 3.11) and train
#   ray      pleat-wardrobe on a local two-node Ray cluster (tests/python/test_wardrobe.py): installs the ray extra
#
# PLEAT_CI_STAGES (default: all of the above, in that order) picks stages; every chosen stage runs even after one
# fails, and the script fails if any did. A table of stage times ends the log.
# Measured on the 2-core development machine under load (docs/ci.md has the table): CPU minutes release 0:30,
# asan 1:00, tsan 0:24, scalar 0:38, fuzz 0:33 (+ 2:00 of fixed fuzzing), soak < 0:01, slow 0:06, blender 0:22
# (+ the wheel's download), ray 1:44, default 4:02 — about 10 minutes of work beyond the installs, well inside CI's 90 minutes.
set -euo pipefail
SELF="$(cd "$(dirname "$0")" && pwd)/$(basename "$0")"
cd "$(dirname "$0")/.."
STAGES=${PLEAT_CI_STAGES:-default release asan tsan scalar fuzz soak slow blender ray}
PY="$PWD/.venv/bin/python"
SUPPRESSIONS="$PWD/tests/sanitizers/lsan-mesa.supp"

configure() { # configure DIR CMAKE_ARGS...
  local dir=$1; shift
  cmake -S . -B "$dir" -G Ninja -DPLEAT_WERROR=ON -DPLEAT_PYTHON="$PY" "$@" >/dev/null
}

build_and_ctest() { # build_and_ctest DIR [CTEST_ARGS...]
  local dir=$1; shift
  nice cmake --build "$dir"
  nice ctest --test-dir "$dir" --output-on-failure -j2 "$@"
}

stage_default() {
  PLEAT_EXTRAS=${PLEAT_EXTRAS:-train} scripts/test.sh
}

stage_release() {
  configure build/ci-release -DCMAKE_BUILD_TYPE=Release
  build_and_ctest build/ci-release
}

stage_asan() {
  configure build/ci-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPLEAT_SANITIZE=ON
  nice cmake --build build/ci-asan
  # Mesa unloads its driver at exit; keep_modules_loaded.c keeps it mapped so leak reports name their module.
  cc -shared -fPIC -O2 -o build/ci-asan/libkeep_modules_loaded.so tests/sanitizers/keep_modules_loaded.c
  LD_PRELOAD="$PWD/build/ci-asan/libkeep_modules_loaded.so" \
  ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:detect_stack_use_after_return=1:strict_string_checks=1:verify_asan_link_order=0" \
  LSAN_OPTIONS="suppressions=$SUPPRESSIONS:print_suppressions=0" \
  UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1" \
    nice ctest --test-dir build/ci-asan --output-on-failure -j2
}

stage_tsan() {
  # The GL path is not threaded by the SDK (one GL context per instance, calls on the owning thread): left out here.
  configure build/ci-tsan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPLEAT_TSAN=ON -DPLEAT_GL=OFF
  TSAN_OPTIONS="halt_on_error=1:second_deadlock_stack=1" build_and_ctest build/ci-tsan -L threads
}

stage_scalar() {
  configure build/ci-scalar -DCMAKE_BUILD_TYPE=Release -DPLEAT_FORCE_SCALAR=ON
  build_and_ctest build/ci-scalar
}

stage_fuzz() {
  FUZZ_SECONDS=${PLEAT_CI_FUZZ_SECONDS:-60} BUILD_DIR=build/ci-fuzz FUZZ_OUT=out/ci-fuzz scripts/fuzz.sh
}

stage_soak() {
  configure build/ci-release -DCMAKE_BUILD_TYPE=Release
  nice cmake --build build/ci-release --target test_soak_live_bytes_flat
  build/ci-release/tests/c/test_soak_live_bytes_flat "${PLEAT_CI_SOAK_STEPS:-100000}"
}

stage_slow() {
  # Uses libpleat.so from the release stage when it ran, else builds it.
  configure build/ci-release -DCMAKE_BUILD_TYPE=Release
  nice cmake --build build/ci-release --target pleat
  local status=0
  PLEAT_SLOW_TESTS=1 PLEAT_BUILD_DIR="$PWD/build/ci-release" "$PY" -m pytest -q -m slow tests/python || status=$?
  [ "$status" -eq 5 ] && status=0 # no test marked slow: nothing to run
  return $status
}

stage_blender() {
  # Not in `default` or scripts/test.sh: the wheel is large and pinned to one Python. The test skips unless
  # PLEAT_BLENDER_TESTS=1, so bpy is imported here first: a missing bpy fails the stage instead of skipping it.
  local version
  version=$("$PY" -c 'import sys; print("%d.%d" % sys.version_info[:2])')
  if [ "$version" != 3.11 ]; then
    echo "stage blender: bpy 4.4.0 exists for Python 3.11 only; .venv is Python $version" >&2
    return 1
  fi
  PLEAT_EXTRAS="train,blender" scripts/setup.sh
  "$PY" -c 'import bpy; print("stage blender: Blender", bpy.app.version_string)'
  # Uses libpleat.so from the release stage when it ran, else builds it.
  configure build/ci-release -DCMAKE_BUILD_TYPE=Release
  nice cmake --build build/ci-release --target pleat
  PLEAT_BLENDER_TESTS=1 PLEAT_BUILD_DIR="$PWD/build/ci-release" "$PY" -m pytest -q -rs \
    tests/python/test_blender_roundtrip.py tests/python/test_blender_teacher.py
}

stage_ray() {
  PLEAT_EXTRAS="train,ray" scripts/setup.sh
  "$PY" -c 'import ray; print("stage ray: Ray", ray.__version__)'
  "$PY" -m pytest -q -rs tests/python/test_wardrobe.py
}

# One stage in a process of its own, so that `set -e` holds inside it (the loop below tests its exit status).
if [ -n "${PLEAT_CI_RUN_STAGE:-}" ]; then
  "stage_$PLEAT_CI_RUN_STAGE"
  exit 0
fi

if [ -n "${STAGES// /}" ] && [ "$STAGES" != default ]; then
  scripts/setup.sh # Debian packages and the venv; quick when present (stage_default runs it itself)
fi
# CPU seconds (user + sys) of this shell's finished children so far: with the wall time it shows how much of a
# stage's time was its own work on a shared machine.
# (`times` runs in this shell, not in a $(...) subshell, whose children would be its own.)
times_file=$(mktemp)
trap 'rm -f "$times_file"' EXIT
cpu_seconds() { # sets CPU
  times >"$times_file"
  CPU=$(tail -1 "$times_file" | awk '{ split($1, u, /[ms]/); split($2, s, /[ms]/); printf "%d", u[1] * 60 + u[2] + s[1] * 60 + s[2] }')
}
summary=""
failed=""
for stage in $STAGES; do
  if ! declare -F "stage_$stage" >/dev/null; then
    echo "ci-stages: unknown stage '$stage' (default release asan tsan scalar fuzz soak slow blender ray)" >&2
    exit 2
  fi
  echo "=== stage $stage"
  start=$(date +%s)
  cpu_seconds
  cpu_start=$CPU
  status=0
  PLEAT_CI_RUN_STAGE=$stage bash "$SELF" || status=$?
  elapsed=$(( $(date +%s) - start ))
  cpu_seconds
  cpu=$(( CPU - cpu_start ))
  verdict=passed
  if [ "$status" -ne 0 ]; then verdict="FAILED (exit $status)"; failed="$failed $stage"; fi
  line=$(printf "%-8s wall %3d:%02d  cpu %3d:%02d  %s" "$stage" $((elapsed / 60)) $((elapsed % 60)) \
    $((cpu / 60)) $((cpu % 60)) "$verdict")
  echo "=== $line"
  summary="$summary$line"$'\n'
done
echo "=== CI stages"
printf "%s" "$summary"
if [ -n "$failed" ]; then
  echo "ci-stages: failed:$failed" >&2
  exit 1
fi
