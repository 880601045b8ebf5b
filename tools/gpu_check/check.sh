#!/usr/bin/env bash
# Brume's GPU checks on a bare machine with an NVIDIA GPU and no network, from what pack.sh
# wrote into DIR (first argument, default .gpu_check), run in the repository root: the GPU
# tests (they find scenes/ through the directory they were built in, linked here if absent),
# `brume bench gpu`, and GPU-against-CPU renders compared by `brume compare`. Logs go to OUT
# (default /tmp/gpu_check).
set -uo pipefail
dir="${1:-.gpu_check}"
out="${OUT:-/tmp/gpu_check}"
mkdir -p "$out" /tmp/gc/b /tmp/gc/t /tmp/gc/img
tar xzf "$dir/brume.tgz" -C /tmp/gc/b && tar xzf "$dir/tests.tgz" -C /tmp/gc/t
for f in "$dir"/*.deb; do dpkg -x "$f" /; done
ldconfig
export LD_LIBRARY_PATH=/tmp/gc/b/lib
icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
[ -f "$icd" ] && export VK_DRIVER_FILES="$icd"
built_in="${BUILT_IN:-/work/main}"
[ -e "$built_in" ] || { mkdir -p "$(dirname "$built_in")" && ln -s "$PWD" "$built_in"; }
b=/tmp/gc/b/brume
for t in gpu_dda gpu_distance gpu_transmittance gpu_render gpu_media_overlap; do
    timeout 300 /tmp/gc/t/$t --nocapture > "$out/$t.txt" 2>&1
    echo "$t: exit $?; $(grep -E '^test result' "$out/$t.txt")"
done
for s in cloud fire dense_fog; do timeout 120 "$b" bench gpu "scenes/$s.gltf" --spp 64; done
for s in fire cornell_smoke cloud chromatic_smoke smoke_tank textured_backdrop; do
    echo "-- $s"
    for be in gpu cpu; do
        seed=$([ "$be" = gpu ] && echo 1 || echo 2)
        timeout 120 "$b" render "scenes/$s.gltf" -o "/tmp/gc/img/$be.exr" --width 160 --height 120 \
            --spp 256 --backend "$be" --seed "$seed" 2>&1 | grep -E 'samples/s|rror'
    done
    "$b" compare /tmp/gc/img/gpu.exr /tmp/gc/img/cpu.exr | grep -E 'z of the mean|z-test'
done
