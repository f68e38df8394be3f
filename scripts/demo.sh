#!/usr/bin/env bash
# The one-command demo: installs what is missing (scripts/setup.sh), builds Pleat in Release (build/release), exports
# the body and a walking clip for the renderer, dresses the body in assets/tshirt.pleat through the clip and writes
# out/demo/frame_*.png and out/demo/contact_sheet.png. See docs/demo.md.
#
# Usage: scripts/demo.sh [--garment NAME[,NAME...]|all]  — NAME is a shipped garment (assets/NAME.pleat, default
# tshirt). With several garments each is rendered into OUT_DIR/NAME/ and their contact sheets are stacked, a row
# each, into OUT_DIR/wardrobe_sheet.png.
#
# Environment overrides: PLEAT_DEMO_ASSET (default assets/tshirt.pleat), PLEAT_DEMO_CLIP (a clip name or file the
# motion loaders accept; default: humanoid3d_long_walk3, a long walk held out of training), PLEAT_DEMO_FRAMES (clip frames at 30 fps, default 120),
# PLEAT_DEMO_PATH (cpu|gl, default cpu), PLEAT_DEMO_SIZE (default 640x480), BUILD_DIR, OUT_DIR.
set -euo pipefail
cd "$(dirname "$0")/.."

GARMENTS=""
while [ $# -gt 0 ]; do
  case "$1" in
    --garment) GARMENTS=${2:?--garment needs a name, a comma-separated list or all}; shift 2 ;;
    --garment=*) GARMENTS=${1#--garment=}; shift ;;
    *) echo "demo: unknown argument '$1' (usage: scripts/demo.sh [--garment NAME[,NAME...]|all])" >&2; exit 2 ;;
  esac
done
if [ "$GARMENTS" = all ]; then
  GARMENTS=$(ls assets/*.pleat | sed -n 's|^assets/\([a-z_]*\)\.pleat$|\1|p' | grep -vE '_(medium|small|xsmall)$' | paste -sd, -)
fi
if [ -n "$GARMENTS" ]; then
  for g in ${GARMENTS//,/ }; do
    [ -f "assets/$g.pleat" ] || { echo "demo: no shipped garment '$g' (assets/$g.pleat); shipped: $(ls assets/*.pleat | xargs -n1 basename | tr '\n' ' ')" >&2; exit 2; }
  done
fi

scripts/setup.sh

BUILD_DIR=${BUILD_DIR:-build/release}
OUT_DIR=${OUT_DIR:-out/demo}
ASSET=${PLEAT_DEMO_ASSET:-assets/tshirt.pleat}
CLIP=${PLEAT_DEMO_CLIP:-humanoid3d_long_walk3}
FRAMES=${PLEAT_DEMO_FRAMES:-120}
RENDER_PATH=${PLEAT_DEMO_PATH:-cpu}
SIZE=${PLEAT_DEMO_SIZE:-640x480}
PY=.venv/bin/python

echo "demo: building (Release, $BUILD_DIR)"
cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=Release -DPLEAT_PYTHON="$PWD/$PY" >/dev/null
cmake --build "$BUILD_DIR" --target pleat-render minimal

if [ ! -f "$ASSET" ]; then
  echo "demo: $ASSET is missing; building the LBS-only placeholder from the procedural t-shirt"
  "$PY" -m pleat.garment_asset --garment tshirt --out "$ASSET"
fi

have_clip() { "$PY" -c "from pleat.motion.loaders import resolve_clip; resolve_clip('$1')" >/dev/null 2>&1; }
if ! have_clip "$CLIP"; then
  echo "demo: clip '$CLIP' not found on the motion search path; fetching the mocap clips (scripts/fetch-motion.sh)"
  scripts/fetch-motion.sh || echo "demo: fetch-motion.sh did not fetch everything (no network to one source?)"
  if ! have_clip "$CLIP" && [ -z "${PLEAT_DEMO_CLIP:-}" ] && have_clip humanoid3d_walk; then
    echo "demo: using humanoid3d_walk (from the pybullet wheel) instead"
    CLIP=humanoid3d_walk
  fi
fi

render_one() {   # render_one ASSET DIR
  mkdir -p "$2"
  rm -f "$2"/frame_*.png "$2"/contact_sheet.png
  echo "demo: exporting the body and the clip '$CLIP' for $1"
  "$PY" -m pleat.render_export body --asset "$1" --out "$2/body.bin"
  "$PY" -m pleat.render_export motion --clip "$CLIP" --fps 30 --frames "$FRAMES" --asset "$1" --out "$2/clip.bin"
  echo "demo: rendering $1"
  "$BUILD_DIR/samples/pleat-render" --asset "$1" --body "$2/body.bin" --clip "$2/clip.bin" \
    --out "$2" --size "$SIZE" --frames "0:$FRAMES:4" --path "$RENDER_PATH" --sheet 8
  echo
  echo "demo: frames        $(ls "$2"/frame_*.png | head -1) ... ($(ls "$2"/frame_*.png | wc -l) files)"
  echo "demo: contact sheet $2/contact_sheet.png"
}

case "$GARMENTS" in
  "") render_one "$ASSET" "$OUT_DIR" ;;
  *,*)
    sheets=()
    for g in ${GARMENTS//,/ }; do render_one "assets/$g.pleat" "$OUT_DIR/$g"; sheets+=("$OUT_DIR/$g/contact_sheet.png"); done
    "$PY" -m pleat.render_export stack --out "$OUT_DIR/wardrobe_sheet.png" "${sheets[@]}"
    echo "demo: wardrobe      $OUT_DIR/wardrobe_sheet.png (a row per garment: ${GARMENTS//,/, })" ;;
  *) render_one "assets/$GARMENTS.pleat" "$OUT_DIR" ;;
esac
