#!/usr/bin/env bash
# All tests: builds the SDK with warnings as errors, runs ctest (C unit tests, GL-vs-CPU on Mesa llvmpipe), then the
# Python tests. .ci/run calls this. BUILD_DIR and CMAKE_BUILD_TYPE may be overridden.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
BUILD_DIR=${BUILD_DIR:-build/test}
cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=${CMAKE_BUILD_TYPE:-Debug} -DPLEAT_WERROR=ON \
  -DPLEAT_PYTHON="$PWD/.venv/bin/python" ${PLEAT_CMAKE_ARGS:-}
cmake --build "$BUILD_DIR"
ctest --test-dir "$BUILD_DIR" --output-on-failure -j2
PLEAT_BUILD_DIR="$PWD/$BUILD_DIR" .venv/bin/python -m pytest -q tests/python "$@"
