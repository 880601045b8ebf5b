#!/usr/bin/env bash
# Renders the picture at the top of the README (docs/images/cloud.png): scenes/cloud.gltf on the
# CPU backend, converted from linear EXR to an sRGB PNG with OpenImageIO's oiiotool.
# Run from the repository root after `cargo build --release`; BRUME_BIN=path uses another build.
set -euo pipefail
cd "$(dirname "$0")/.."
brume="${BRUME_BIN:-target/release/brume}"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
"$brume" render scenes/cloud.gltf -o "$work/cloud.exr" --width 480 --height 320 --spp 1024 \
    --seed 1 --backend cpu
mkdir -p docs/images
oiiotool "$work/cloud.exr" --ch R,G,B --colorconvert linear sRGB -d uint8 -o docs/images/cloud.png
echo "wrote docs/images/cloud.png ($(stat -c %s docs/images/cloud.png) bytes)"
