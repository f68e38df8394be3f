#!/usr/bin/env bash
# Fetches the 31 DeepMimic-format motion clips of shared/motion from their original sources and checks them against
# the SHA-256 sums below (the same as shared/motion/SHA256SUMS). See docs/motion.md and shared/motion/PROVENANCE.md.
#   A. deepmimic_pybullet/: the pybullet 3.2.7 wheel on PyPI (zlib licence), pybullet_data/data/motions/
#   B. deepmimic_github/:   github.com/xbpeng/DeepMimic at commit 1f915c5 (MIT), data/motions/
# Usage: [REQUIRE_ALL=1] scripts/fetch-motion.sh [DEST]   (default: data/motion, where the loaders look after $PLEAT_MOTION_DIR
#        and ../shared/motion). Needs python3 with pip, curl, unzip-free (python's zipfile), sha256sum.
set -euo pipefail
cd "$(dirname "$0")/.."
DEST="${1:-data/motion}"
PYBULLET_VERSION=3.2.7
WHEEL=pybullet-3.2.7-cp311-cp311-manylinux_2_17_x86_64.manylinux2014_x86_64.whl
WHEEL_SHA256=5d858abf7c12a21ef3ed351cf81dac1b5e486ec25c9ab59bfc84beb89034edff
DEEPMIMIC_COMMIT=${DEEPMIMIC_COMMIT:-1f915c5}
DEEPMIMIC_RAW="https://raw.githubusercontent.com/xbpeng/DeepMimic/$DEEPMIMIC_COMMIT"
PY=${PYTHON:-python3}
[ -x .venv/bin/python ] && PY=.venv/bin/python

TMP="$(mktemp -d)"; trap 'rm -rf "$TMP"' EXIT
mkdir -p "$DEST/deepmimic_pybullet/walker" "$DEST/deepmimic_github"

echo "fetch-motion: pybullet $PYBULLET_VERSION wheel from PyPI (~100 MB)"
"$PY" -m pip download -q --no-deps --only-binary :all: --python-version 3.11 --platform manylinux2014_x86_64 \
    -d "$TMP" "pybullet==$PYBULLET_VERSION"
echo "$WHEEL_SHA256  $TMP/$WHEEL" | sha256sum -c --quiet -
"$PY" - "$TMP/$WHEEL" "$DEST/deepmimic_pybullet" <<'PY'
import shutil, sys, zipfile
wheel, out = sys.argv[1], sys.argv[2]
base = "pybullet_data/data/motions/"
with zipfile.ZipFile(wheel) as z:
    for n in z.namelist():
        if n.startswith(base) and n.endswith(".txt") and ("humanoid3d_" in n or "/walker/" in n):
            with z.open(n) as s, open(f"{out}/{n[len(base):]}", "wb") as d:
                shutil.copyfileobj(s, d)
    with z.open("pybullet-3.2.7.dist-info/LICENSE.txt") as s, open(f"{out}/LICENSE-pybullet-zlib.txt", "wb") as d:
        shutil.copyfileobj(s, d)
PY

echo "fetch-motion: DeepMimic clips at commit $DEEPMIMIC_COMMIT from GitHub"
# A file is written under its name only once complete, so a failed download leaves nothing the loaders would list.
fetch() { if curl -fsSL --retry 2 --connect-timeout 10 -o "$2.part" "$1"; then mv "$2.part" "$2"; else rm -f "$2.part"; return 1; fi; }
GITHUB_CLIPS="dance_spin jog sideflip stealthy_walk zombie_walk long/long_walk1 long/long_walk2 long/long_walk3
  long/long_zombie long/stealthy_walk0 long/stealthy_walk1"
failed=()          # what could not be fetched: paths under DEST without .txt
if fetch "$DEEPMIMIC_RAW/LICENSE" "$DEST/deepmimic_github/LICENSE-DeepMimic-MIT.txt"; then
  for clip in $GITHUB_CLIPS; do
    name="humanoid3d_${clip#long/}"; dir="data/motions"; [ "$clip" != "${clip#long/}" ] && dir="data/motions/long"
    fetch "$DEEPMIMIC_RAW/$dir/$name.txt" "$DEST/deepmimic_github/$name.txt" || failed+=("deepmimic_github/$name")
  done
else
  # unreachable (or the licence is gone): the clips are not tried one by one (each would wait for its time-out),
  # and without the licence none of them is kept
  failed+=(deepmimic_github/LICENSE-DeepMimic-MIT)
  for clip in $GITHUB_CLIPS; do failed+=("deepmimic_github/humanoid3d_${clip#long/}"); done
  rmdir "$DEST/deepmimic_github" 2>/dev/null || true
fi
missing_clips=$(printf '%s\n' "${failed[@]}" | grep -c /humanoid3d_ || true)
fetched=$((31 - missing_clips))
if [ "$missing_clips" -gt 0 ]; then
  # Training uses the clips that are there and warns about the others; pleat-motion list shows them as missing.
  echo "fetch-motion: WARNING: $missing_clips clips could not be fetched from GitHub, $fetched of the 31 are in" \
       "$DEST; missing: $(printf '%s\n' "${failed[@]}" | grep /humanoid3d_ | paste -sd' ')" >&2
  [ "${REQUIRE_ALL:-0}" = 1 ] && exit 1
fi

echo "fetch-motion: checking SHA-256 sums"
verify() {
  if [ ${#failed[@]} -gt 0 ]; then grep -v -F -f <(printf './%s.txt\n' "${failed[@]}"); else cat; fi \
    | (cd "$DEST" && sha256sum -c --quiet)
}
verify <<'SUMS'
885cd516a8420acb7c3e0b1a7119913b686495001ae564e3229740460e8cff59  ./deepmimic_pybullet/LICENSE-pybullet-zlib.txt
ffc5e117f69364e239eeedc86d6a30ab854500a375a1c137a405f1b7652905e6  ./deepmimic_pybullet/humanoid3d_backflip.txt
17453459a40ec4ea08346072748ae3c7c384b49e619753e9779637fa8a9f7c49  ./deepmimic_pybullet/humanoid3d_cartwheel.txt
104a3b675131a43e7a214e24c0ed631c6a0d814b85c8b66b71ce63b23a5731ae  ./deepmimic_pybullet/humanoid3d_crawl.txt
15ef3731f594edc9ed078170f1075815cc164acaca9e35a46db12a31ac64b717  ./deepmimic_pybullet/humanoid3d_dance_a.txt
b5a9d7a3f2304f6242776d7ff6d19d1f6bcb98d78d68622761c3843b614a92b5  ./deepmimic_pybullet/humanoid3d_dance_b.txt
1bd1a96e9175f65eb66e10f225473b4467bd70c68e283f4006b2ab090e337c0b  ./deepmimic_pybullet/humanoid3d_getup_facedown.txt
5936c32d51dad9b0cd5e61df681079d160436cdce845c312f200d7a347c4040d  ./deepmimic_pybullet/humanoid3d_getup_faceup.txt
a433557e94b193d8a95530572a0e32f387eb6d9996987b4216efb65444c3c641  ./deepmimic_pybullet/humanoid3d_jump.txt
177cfb399466309ba7f4a8a987c3b6f6edde1cbe8b2d476e53dc6061ec5d4bac  ./deepmimic_pybullet/humanoid3d_kick.txt
1ab4b654cecdb4ff3b2a4bf4086e50397bef28435bb59ab3aedd6a6bdc926fde  ./deepmimic_pybullet/humanoid3d_punch.txt
50d75c2243b2859f8dcae4ad8fa14b59054dd9ee529b4fb52ec14470cd982c55  ./deepmimic_pybullet/humanoid3d_roll.txt
2cbe488023b243e5769299158ce7c78875ec4b701a2ffe6c0beeaf83d16ca87b  ./deepmimic_pybullet/humanoid3d_run.txt
9614f10b92e7a8b123990ad5bcfafc65aa4d8fa8ac7f10ade3c3591122d34425  ./deepmimic_pybullet/humanoid3d_spin.txt
60ec9c200d96e0cd71693061f24db0bd8da9eb295daf487f6f60f8dfb324075a  ./deepmimic_pybullet/humanoid3d_spinkick.txt
32d082c3599bc40aac50b1afa196ff1e2cf3842bb40f0541ab088845f6328a41  ./deepmimic_pybullet/humanoid3d_walk.txt
a8790c45361077ff07d99c3f00a1fa73b78ff3ec77d083188f13eac75dcc0a58  ./deepmimic_pybullet/walker/0walk_forward.txt
5120bb55a4eb3ecfa75bcffcd472ad0b5be01647536f707896b9a9af655d6fce  ./deepmimic_pybullet/walker/turn_left0.txt
e78540dcccfad969ff1304182de293714c1db163096ee37a02dbf34930e0c3d0  ./deepmimic_pybullet/walker/turn_left1.txt
c1fa371a7d7d625970ad7fec0bb2d7ba59205acb74f8fac15f46799ae3a80ce3  ./deepmimic_pybullet/walker/turn_right0.txt
3a655a1e9334cef592b5b7bef4fd7a52e46fcacc8c7c807cfa1bee8249e6350d  ./deepmimic_pybullet/walker/turn_right1.txt
eb4aa4f4f1e9a18875e996e12a7aaf9dc078562ef5db372b55910c6599dbcdc5  ./deepmimic_github/LICENSE-DeepMimic-MIT.txt
c79919274430cb7de08972f439bad1ccac21bdca19c2c319c705948f025bddf1  ./deepmimic_github/humanoid3d_dance_spin.txt
8664855dc19871fe859b543cd27d113e6f85769cb3fe7819efb47a0341bc6fd9  ./deepmimic_github/humanoid3d_jog.txt
1cf7f7f2609e0fce801658598b5b04699a440aba079909dc21a30ec9d53e1a61  ./deepmimic_github/humanoid3d_long_walk1.txt
82ad47ff79aece906a873b500835311ce1301a194810e15083b86e4eb5568a6b  ./deepmimic_github/humanoid3d_long_walk2.txt
cab525d1eeb7b44f701fc091bdf5a4a6bfa2e77106a9d6167ba7a635a31f17d8  ./deepmimic_github/humanoid3d_long_walk3.txt
ef5c5a20994ff8bff1d80b11ba65ffcaaa955748ca87e0c5a89ae2dd4de6d4ae  ./deepmimic_github/humanoid3d_long_zombie.txt
18ec3f7402e966fd4503a21c4f1b788daf8c96eab0cee8036b7a64ef6f40d9eb  ./deepmimic_github/humanoid3d_sideflip.txt
7db28ee85721eea0ae44c3e726fb48bb5532d38f5d9aff8e18d791227476f5bb  ./deepmimic_github/humanoid3d_stealthy_walk.txt
c531a43a375137edc9f1371cab5f65e86d6d669d15a4d029e42259338f8ab44e  ./deepmimic_github/humanoid3d_stealthy_walk0.txt
e63156dc618a819f9d25391c58cd95a3f02496e7f3f9689fd86541824a632e03  ./deepmimic_github/humanoid3d_stealthy_walk1.txt
6935eaa0a83a0ca13fbf4aaba58efa391f582a83436875fe08212b2029bcfbac  ./deepmimic_github/humanoid3d_zombie_walk.txt
SUMS
echo "fetch-motion: $fetched clips in $DEST verified"
