#!/usr/bin/env bash
# Regenerates every example grid in scenes/vdb (the results are committed, so a render needs
# no generation step). Run from the repository root.
set -euo pipefail
out=scenes/vdb
mkdir -p "$out"
# OpenVDB's own tool: level sets converted to fog volumes by OpenVDB itself. Their interiors
# are active tiles, so they exercise the tile path of the reader.
vdb_tool -quiet -sphere r=1.0 dim=64 name=surface -write keep=1 "$out/sphere_ls.vdb" \
    -ls2fog name=density -write "$out/sphere_fog.vdb"
vdb_tool -quiet -platonic f=12 s=1.0 dim=64 name=surface -ls2fog name=density \
    -write "$out/dodeca_fog.vdb"
# dense_fog.gltf: an icosahedron, nearly constant density inside (mostly active tiles).
vdb_tool -quiet -platonic f=20 s=1.0 dim=64 name=surface -ls2fog name=density \
    -write "$out/icosa_fog.vdb"
# Procedural clouds, smoke, fire and a tile block, written through Brume's OpenVDB shim.
cargo run --release --quiet --example make_grids -- "$out"
ls -l "$out"
