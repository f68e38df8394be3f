#!/usr/bin/env bash
# Fetches Microsoft's ONNX Runtime C API header (onnxruntime_c_api.h, ORT_API_VERSION 24, and the
# onnxruntime_ep_c_api.h it includes) into third_party/onnxruntime/include/ (gitignored, never committed).
# No Debian or PyPI package ships the header; the Go module github.com/yalue/onnxruntime_go carries the official copy,
# so we fetch it through the Go module proxy (checksummed by sum.golang.org) and pin the SHA-256 of each file here.
# Without the header, ort_backend.c builds as a stub that returns PLEAT_RESULT_BACKEND_UNAVAILABLE.
# Exit status: 0 = header present and verified; 1 = fetch failed (no Go, no network) or checksum mismatch.
set -euo pipefail
cd "$(dirname "$0")/.."

MODULE="github.com/yalue/onnxruntime_go"
VERSION="v1.27.0"
DEST="third_party/onnxruntime/include"
declare -A PINNED=(
	[onnxruntime_c_api.h]=9ed0d7054a4e74249467365b25b415d36f51a44a6349e2a994a1812e4723d1e2
	[onnxruntime_ep_c_api.h]=e94ac3490697bdb107844fa9d403952ee7136134132a057eae5c1207b57ce352
)

verify_dir() {
	local dir=$1 name
	for name in "${!PINNED[@]}"; do
		[ -f "$dir/$name" ] || return 1
		[ "$(sha256sum "$dir/$name" | cut -d' ' -f1)" = "${PINNED[$name]}" ] || return 1
	done
}

if verify_dir "$DEST"; then
	echo "fetch-ort-header: $DEST is present and verified"
	exit 0
fi

if ! command -v go >/dev/null 2>&1; then
	echo "fetch-ort-header: 'go' not found; cannot fetch the ONNX Runtime header" >&2
	exit 1
fi

# A private GOPATH keeps the user's module cache untouched and needs no go.mod.
gopath=$(mktemp -d)
trap 'chmod -R u+w "$gopath" 2>/dev/null; rm -rf "$gopath"' EXIT
json=$(GOPATH="$gopath" GOFLAGS=-mod=mod go mod download -json "$MODULE@$VERSION") || {
	echo "fetch-ort-header: 'go mod download $MODULE@$VERSION' failed (network?)" >&2
	exit 1
}
dir=$(printf '%s\n' "$json" | sed -n 's/^[[:space:]]*"Dir": "\(.*\)",\{0,1\}$/\1/p')
if [ -z "$dir" ] || ! verify_dir "$dir"; then
	echo "fetch-ort-header: downloaded header missing or SHA-256 mismatch (expected the pinned values in $0)" >&2
	exit 1
fi
mkdir -p "$DEST"
for name in "${!PINNED[@]}"; do
	install -m 0644 "$dir/$name" "$DEST/$name"
done
verify_dir "$DEST"
echo "fetch-ort-header: installed $MODULE@$VERSION headers into $DEST"
