#!/usr/bin/env bash
# Shows Mesa 22.3's lavapipe corrupting its heap while it creates a compute pipeline, and the
# bindings that avoid it. Creates the pipeline of kernel.wgsl (Brume's generic sample_medium
# kernel, reduced: three uniform blocks in bind group 0) under valgrind's memcheck with Mesa's
# shader cache off; then the same kernel with its third group-0 uniform block (the blackbody
# table) bound as read-only storage, and with it kept a uniform block but moved to group 1;
# and prints what memcheck found in each.
#
#   tools/lavapipe_ubo/run.sh
#
# Needs valgrind and lavapipe (mesa-vulkan-drivers) as the only Vulkan driver. On Debian 12
# (Mesa 22.3.6) the first prints an invalid read of 4 bytes just past a 4,064-byte block that
# vkCreateComputePipelines allocated and invalid writes of 4 bytes into the free heap; the
# other two print none. Takes about a minute a variant.
set -euo pipefail
cd "$(dirname "$0")/../.."
cargo build --release --example lavapipe_ubo_repro
repro=target/release/examples/lavapipe_ubo_repro
here=tools/lavapipe_ubo
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
sed 's/var<uniform> blackbody_table/var<storage, read> blackbody_table/' "$here/kernel.wgsl" \
    > "$tmp/storage.wgsl"
sed 's/@group(0) @binding(6) var<uniform> blackbody_table/@group(1) @binding(30) var<uniform> blackbody_table/' \
    "$here/kernel.wgsl" > "$tmp/group1.wgsl"
for variant in "uniform:$here/kernel.wgsl" "storage:$tmp/storage.wgsl" "group1:$tmp/group1.wgsl"; do
    name=${variant%%:*}
    file=${variant#*:}
    MESA_SHADER_CACHE_DISABLE=true XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-$tmp}" \
        valgrind --error-limit=no "$repro" "$file" sample_medium \
        > "$tmp/$name.out" 2> "$tmp/$name.vg" || echo "  the program failed: $(grep -v "^==" "$tmp/$name.vg" | tail -1)"
    echo "blackbody table $name: $(cat "$tmp/$name.out")"
    echo "  places lavapipe reads out of bounds:  $(grep -A1 'Invalid read' "$tmp/$name.vg" | grep -c libvulkan_lvp || true)"
    echo "  places lavapipe writes out of bounds: $(grep -A1 'Invalid write' "$tmp/$name.vg" | grep -c libvulkan_lvp || true)"
    grep -E "Address .* (after a block|unallocated)" "$tmp/$name.vg" | sed 's/^==[0-9]*==/ /' || true
    grep "ERROR SUMMARY" "$tmp/$name.vg" | sed 's/^==[0-9]*==/ /'
done
