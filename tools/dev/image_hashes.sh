#!/usr/bin/env bash
# Renders every example scene on the CPU with both samplers (small, fixed seed) and prints a
# hash of each image's pixels (beauty, variance and sample count; all attributes erased, so
# timings and paths do not count).
# Two trees whose lists are equal render bit-identical images: the check that a refactoring
# changed no result.
#
#   tools/dev/image_hashes.sh [BRUME_BINARY] > hashes.txt
set -euo pipefail
cd "$(dirname "$0")/../.."
brume=${1:-target/release/brume}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# render NAME SCENE ARGS...: one line "NAME hash".
render() {
    local name=$1 scene=$2
    shift 2
    "$brume" render "$scene" -o "$tmp/a.exr" --backend cpu --width 40 --height 30 --spp 4 \
        --seed 11 --threads 2 "$@" > "$tmp/log" 2>&1 \
        || { echo "$name FAILED"; cat "$tmp/log"; return; }
    # The image's channels only: the accumulator state's layout may change without changing
    # a pixel.
    oiiotool --nosoftwareattrib "$tmp/a.exr" --ch R,G,B,A,variance.R,variance.G,variance.B,samples.Y \
        --eraseattrib ".*" --attrib DateTime - -o "$tmp/b.exr"
    echo "$name $(sha256sum < "$tmp/b.exr" | cut -c1-16)"
}
for scene in scenes/*.gltf; do
    for sampler in sobol independent; do
        render "$(basename "$scene") $sampler" "$scene" --sampler "$sampler"
    done
done
# Every estimator, majorant mode and shadow estimator on the media that exercise them.
for scene in cloud chromatic_smoke fire cornell_smoke; do
    for est in delta weighted-delta decomposition weighted-decomposition; do
        for maj in global leaf culled adaptive; do
            render "$scene $est $maj" "scenes/$scene.gltf" --estimator $est --majorant $maj
        done
    done
    for shadow in ratio residual-ratio; do
        render "$scene shadow $shadow" "scenes/$scene.gltf" --shadow $shadow
    done
    render "$scene generic" "scenes/$scene.gltf" --generic
    render "$scene spectral event" "scenes/$scene.gltf" --spectral --absorption event
done
