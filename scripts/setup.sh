#!/usr/bin/env bash
# Installs what Pleat needs and is missing: Debian packages (GL headless, cmocka, libpng) and the project venv .venv/
# with the tools package. Idempotent; safe to run on every demo/test. PLEAT_EXTRAS=train,body adds PyTorch and anny.
set -euo pipefail
cd "$(dirname "$0")/.."

DEBS="cmake ninja-build pkg-config gcc libegl-dev libegl-mesa0 libgl1-mesa-dri libepoxy-dev libosmesa6-dev libcmocka-dev libpng-dev zlib1g-dev"
missing=""
for p in $DEBS; do dpkg -s "$p" >/dev/null 2>&1 || missing="$missing $p"; done
if [ -n "$missing" ]; then
  echo "setup: installing Debian packages:$missing"
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq $missing
fi

PY=${PYTHON:-python3}
if [ ! -x .venv/bin/python ]; then
  echo "setup: creating .venv"
  "$PY" -m venv .venv
fi
extras="test,onnx${PLEAT_EXTRAS:+,$PLEAT_EXTRAS}"
stamp=".venv/.pleat-installed-$(echo "$extras" | tr ',' '_')-$(sha1sum tools/pyproject.toml | cut -c1-12)"
if [ ! -f "$stamp" ]; then
  echo "setup: installing the tools package into .venv ($extras)"
  .venv/bin/pip install -q --upgrade pip >/dev/null
  .venv/bin/pip install -q -e "tools[$extras]"
  touch "$stamp"
fi

scripts/fetch-ort-header.sh || echo "setup: note: ONNX Runtime C API header not fetched; the ONNX Runtime backend builds as a stub (BACKEND_UNAVAILABLE)"

# Motion capture: ../shared/motion or $PLEAT_MOTION_DIR when present, otherwise fetched once into data/motion from the
# clips' own sources (PyPI's pybullet wheel; GitHub for the long takes, when reachable).
if ! .venv/bin/python -c "from pleat.motion.loaders import find_motion_dir; find_motion_dir()" >/dev/null 2>&1; then
  scripts/fetch-motion.sh || echo "setup: note: motion clips not fetched; tests that need real mocap skip"
fi
