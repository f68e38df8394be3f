#!/usr/bin/env bash
# Install → consume, as an integrator does it (docs/integrate.md, "Install and consume"): `cmake --install` the build tree into a
# temporary prefix, then build samples/minimal (a T-pose engine skeleton retargeted through the skeleton API) against
# the installed package twice — with find_package(Pleat) and with pkg-config plus an rpath — and run both on the asset.
# The consumer builds run without libepoxy's development files: when this machine has them, its headers and .pc
# directory are hidden behind empty directories in a private mount namespace (unshare), and the script first proves
# they are invisible there; a pleat.pc that asked for epoxy (Requires.private) is shown to fail in that environment.
#
#   install_and_consume.sh BUILD_DIR SOURCE_DIR WORK_DIR ASSET
set -euo pipefail
build=$(cd "$1" && pwd) source=$(cd "$2" && pwd) work=$3 asset=$(cd "$(dirname "$4")" && pwd)/$(basename "$4")
rm -rf "$work"
mkdir -p "$work"
work=$(cd "$work" && pwd)
prefix="$work/prefix"

say() { printf 'install_and_consume: %s\n' "$*"; }
fail() { say "FAIL: $*"; exit 1; }

cmake --install "$build" --prefix "$prefix" >"$work/install.log"
pc=$(find "$prefix" -name pleat.pc -print -quit)
[ -n "$pc" ] || fail "no pleat.pc installed"
pcdir=$(dirname "$pc")
say "installed into $prefix"

# One version everywhere: the installed header's PLEAT_VERSION_* is what the CMake package (asked for EXACT below),
# pleat.pc and the shared library's file name must say, and the soname carries its major.
header="$prefix/include/pleat/pleat.h"
[ -f "$header" ] || fail "no pleat.h installed"
version_part() { sed -n "s/^#define PLEAT_VERSION_$1 \([0-9][0-9]*\)\$/\1/p" "$header"; }
major=$(version_part MAJOR) minor=$(version_part MINOR) patch=$(version_part PATCH)
[ -n "$major" ] && [ -n "$minor" ] && [ -n "$patch" ] || fail "pleat.h has no PLEAT_VERSION_MAJOR/MINOR/PATCH"
version="$major.$minor.$patch"
pc_version=$(sed -n 's/^Version: //p' "$pc")
[ "$pc_version" = "$version" ] || fail "pleat.pc says Version: $pc_version, pleat.h says $version"
library=$(find "$prefix" -name "libpleat.so.$version" -print -quit)
[ -n "$library" ] || { find "$prefix" -name 'libpleat.so*'; fail "no libpleat.so.$version installed (pleat.h says $version)"; }
soname=$(readelf -d "$library" | sed -n 's/.*Library soname: \[\(.*\)\].*/\1/p')
[ "$soname" = "libpleat.so.$major" ] || fail "libpleat.so.$version has soname '$soname', not libpleat.so.$major"
say "version $version: pleat.h, pleat.pc, libpleat.so.$version (soname $soname)"

# What a shared-library consumer reads never asks for epoxy: only pleat.pc's Libs.private (static links) names it, and
# the shared library's CMake export set does not mention it.
if grep -n -i epoxy "$pc" | grep -v ':Libs.private:'; then fail "pleat.pc asks for epoxy outside Libs.private"; fi
if grep -l -i epoxy "$prefix"/lib*/cmake/Pleat/PleatTargets*.cmake 2>/dev/null; then
  fail "the shared library's CMake targets mention epoxy"
fi

# Where this machine keeps epoxy's development files (outside the hidden environment).
epoxy_pcdir=$(pkg-config --variable=pcfiledir epoxy 2>/dev/null || true)
epoxy_include=$(pkg-config --variable=includedir epoxy 2>/dev/null || true)

# The static library through COMPONENTS static, where epoxy's development files are present (before hiding them): it
# must still configure, link and run.
if [ -n "$epoxy_pcdir" ]; then
  CMAKE_PREFIX_PATH="$prefix" cmake -S "$source/tests/install/consumer" -B "$work/static-consumer" -G "Unix Makefiles" \
    -DPLEAT_SAMPLE_DIR="$source/samples/minimal" -DPLEAT_REQUIRED_VERSION="$version" -DPLEAT_CONSUMER_STATIC=ON \
    >"$work/static-consumer.log" 2>&1 &&
    cmake --build "$work/static-consumer" >>"$work/static-consumer.log" 2>&1 ||
    { cat "$work/static-consumer.log"; fail "the COMPONENTS static consumer"; }
  "$work/static-consumer/consumer" "$asset" 10 >"$work/static-consumer.out" 2>&1 &&
    grep -q "all outputs finite" "$work/static-consumer.out" || { cat "$work/static-consumer.out"; fail "static consumer run"; }
  if ldd "$work/static-consumer/consumer" | grep libpleat.so >/dev/null; then fail "the static consumer loads libpleat.so"; fi
  say "COMPONENTS static: Pleat::pleat_static links and runs (with epoxy's development files present)"
fi

cat >"$work/consume.sh" <<INNER
#!/usr/bin/env bash
set -euo pipefail
say() { printf 'install_and_consume: %s\n' "\$*"; }
fail() { say "FAIL: \$*"; exit 1; }
hidden=0
if [ "\${HIDE_EPOXY:-0}" = 1 ]; then
  mkdir -p "$work/empty"
  [ -z "$epoxy_include" ] || mount --bind "$work/empty" "$epoxy_include/epoxy"
  [ -z "$epoxy_pcdir" ] || mount --bind "$work/empty" "$epoxy_pcdir"
  hidden=1
fi
# Proof that the environment has no epoxy development files: the default pkg-config search and the header both fail.
if env -u PKG_CONFIG_PATH -u PKG_CONFIG_LIBDIR pkg-config --exists epoxy; then
  fail "epoxy.pc is still visible"
fi
if [ -e "${epoxy_include:-/usr/include}/epoxy/gl.h" ]; then fail "epoxy/gl.h is still visible"; fi
say "epoxy's pkg-config file and headers are not visible (hidden by a mount namespace: \$hidden)"

export PKG_CONFIG_LIBDIR="$pcdir" PKG_CONFIG_PATH="" CMAKE_PREFIX_PATH="$prefix"
# Control: the same package with "Requires.private: epoxy" (what pleat.pc used to say) fails right here.
mkdir -p "$work/control"
{ cat "$pc"; echo "Requires.private: epoxy"; } | sed "s|^prefix=.*|prefix=$prefix|" >"$work/control/pleat.pc"
if PKG_CONFIG_LIBDIR="$work/control" pkg-config --cflags pleat >/dev/null 2>&1; then
  fail "control: a pleat.pc requiring epoxy resolved, so this environment would not catch that mistake"
fi
say "control: a pleat.pc with Requires.private: epoxy fails here, as it would for a user"

run() { # program: run it on the asset, require the retarget line and finite output, from the installed library
  "\$1" "$asset" 30 >"\$1.out" 2>&1 || { cat "\$1.out"; fail "\$1 exited non-zero"; }
  grep -q "all outputs finite" "\$1.out" || { cat "\$1.out"; fail "\$1: outputs not finite"; }
  grep -q "T-pose engine bind pose as asset rotations.*left_shoulder 2[0-9]" "\$1.out" ||
    { cat "\$1.out"; fail "\$1: no T-pose retarget of the shoulders"; }
  ldd "\$1" | grep "$prefix/.*libpleat.so" >/dev/null || { ldd "\$1"; fail "\$1 does not load the installed libpleat.so"; }
  if readelf -d "\$1" | grep NEEDED | grep epoxy >/dev/null; then fail "\$1 links libepoxy itself"; fi
  say "\$1: \$(grep 'T-pose' "\$1.out")"
}

# 1. CMake: find_package(Pleat <pleat.h's version> EXACT) from CMAKE_PREFIX_PATH.
cmake -S "$source/tests/install/consumer" -B "$work/cmake-consumer" -G "Unix Makefiles" \
  -DPLEAT_SAMPLE_DIR="$source/samples/minimal" -DPLEAT_REQUIRED_VERSION="$version" \
  -DPLEAT_CONSUMER_EXPECT_NO_STATIC=\$hidden >"$work/cmake-consumer.log" 2>&1 ||
  { cat "$work/cmake-consumer.log"; fail "configuring the find_package consumer"; }
cmake --build "$work/cmake-consumer" >>"$work/cmake-consumer.log" 2>&1 ||
  { cat "$work/cmake-consumer.log"; fail "building the find_package consumer"; }
for made in link.txt flags.make; do
  [ -f "$work/cmake-consumer/CMakeFiles/consumer.dir/\$made" ] || fail "no \$made to check (generator changed?)"
done
if grep -i epoxy "$work/cmake-consumer/CMakeFiles/consumer.dir/link.txt" "$work/cmake-consumer/CMakeFiles/consumer.dir/flags.make"; then
  fail "the find_package consumer's compile or link line mentions epoxy"
fi
run "$work/cmake-consumer/consumer"

# 2. pkg-config, with the rpath docs/integrate.md gives.
cflags=\$(pkg-config --cflags pleat) libs=\$(pkg-config --libs pleat) libdir=\$(pkg-config --variable=libdir pleat)
case "\$cflags \$libs" in *epoxy*) fail "pkg-config pleat gives epoxy flags: \$cflags \$libs";; esac
cc -std=c11 -O1 "$source/samples/minimal/minimal.c" "$source/samples/minimal/retarget.c" \$cflags -o "$work/pkgconfig-consumer" \
  \$libs -lm -Wl,-rpath,"\$libdir"
run "$work/pkgconfig-consumer"
INNER
chmod +x "$work/consume.sh"

# Hide epoxy's development files when there are any: a private mount namespace (root: unshare -m; otherwise a user
# namespace: unshare -rm). Without either, the consumer steps still run with a clean PKG_CONFIG_LIBDIR and
# CMAKE_PREFIX_PATH, and the visibility check above fails loudly instead of passing by accident.
if [ -z "$epoxy_pcdir$epoxy_include" ]; then
  say "this machine has no epoxy development files"
  "$work/consume.sh"
elif unshare -m true 2>/dev/null; then
  HIDE_EPOXY=1 unshare -m "$work/consume.sh"
elif unshare -rm true 2>/dev/null; then
  HIDE_EPOXY=1 unshare -rm "$work/consume.sh"
else
  say "SKIP: epoxy's development files are installed and no mount namespace is available to hide them"
  exit 77
fi
say "PASS"
