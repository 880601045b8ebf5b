#!/usr/bin/env python3
"""Writes the generated example scenes (run from the repository root):

- furnace.gltf: the cloud grid with albedo 1 inside an index-matched cube (transmission 1,
  ior 1) under a constant environment of radiance 1 and no other light. Every path ends in
  the environment with weight 1, so the exact image is 1 everywhere: the white furnace.
- chromatic_smoke.gltf: the smoke grid with strongly chromatic extinction (Principled Volume
  absorptionColor far from grey), lit by a sun and sky: the case spectral tracking exists for.
"""
import base64
import json
import struct


def cube(half):
    """8 corners, 12 triangles wound counter-clockwise seen from outside."""
    p = [(x, y, z) for z in (-half, half) for y in (-half, half) for x in (-half, half)]
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    idx = []
    for a, b, c, d in quads:
        idx += [a, b, c, a, c, d]
    return p, idx


def mesh_buffer(positions, indices):
    pos = b"".join(struct.pack("<3f", *v) for v in positions)
    ind = b"".join(struct.pack("<H", i) for i in indices)
    ind += b"\0" * (-len(ind) % 4)
    data = ind + pos
    lo = [min(v[k] for v in positions) for k in range(3)]
    hi = [max(v[k] for v in positions) for k in range(3)]
    return {
        "buffers": [{"byteLength": len(data), "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 2 * len(indices), "target": 34963},
            {"buffer": 0, "byteOffset": len(ind), "byteLength": len(pos), "target": 34962},
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5123, "count": len(indices), "type": "SCALAR"},
            {"bufferView": 1, "componentType": 5126, "count": len(positions), "type": "VEC3", "min": lo, "max": hi},
        ],
    }


def write(path, doc):
    with open(path, "w") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")
    print("wrote", path)


def furnace():
    positions, indices = cube(3.0)
    doc = {
        "asset": {"version": "2.0", "generator": "brume scenes/make_scenes.py"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2]}],
        "nodes": [
            {"name": "camera_node", "camera": 0, "translation": [0.0, 0.0, 6.0]},
            {"name": "cloud", "scale": [1.5, 1.5, 1.5], "extensions": {"BRUME_medium_vdb": {
                "uri": "vdb/cloud.vdb", "densityScale": 6.0, "color": [1.0, 1.0, 1.0], "anisotropy": 0.5}}},
            {"name": "boundary", "mesh": 0},
        ],
        "cameras": [{"name": "camera", "type": "perspective", "perspective": {"yfov": 0.7, "znear": 0.05}}],
        "meshes": [{"name": "boundary", "primitives": [{"attributes": {"POSITION": 1}, "indices": 0, "material": 0}]}],
        "materials": [{"name": "index_matched", "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0},
                       "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": 1.0}}}],
        "extensions": {"BRUME_environment": {"color": [1.0, 1.0, 1.0], "strength": 1.0}},
        "extensionsUsed": ["BRUME_medium_vdb", "BRUME_environment", "KHR_materials_transmission", "KHR_materials_ior"],
    }
    doc.update(mesh_buffer(positions, indices))
    write("scenes/furnace.gltf", doc)


def chromatic_smoke():
    doc = {
        "asset": {"version": "2.0", "generator": "brume scenes/make_scenes.py"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2]}],
        "nodes": [
            {"name": "camera_node", "camera": 0, "translation": [0.0, 0.0, 5.5]},
            {"name": "sun", "rotation": [-0.3303661, 0.2432103, 0.0885213, 0.9076734], "extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"name": "smoke", "scale": [1.6, 1.6, 1.6], "extensions": {"BRUME_medium_vdb": {
                "uri": "vdb/smoke.vdb", "densityScale": 24.0, "color": [0.2, 0.5, 0.9],
                "absorptionColor": [0.9, 0.35, 0.05], "anisotropy": 0.3}}},
        ],
        "cameras": [{"name": "camera", "type": "perspective", "perspective": {"yfov": 0.7, "znear": 0.05}}],
        "extensions": {
            "KHR_lights_punctual": {"lights": [{"name": "sun", "type": "directional", "color": [1.0, 1.0, 1.0], "intensity": 3.0}]},
            "BRUME_environment": {"color": [0.5, 0.6, 0.8], "strength": 0.5},
        },
        "extensionsUsed": ["KHR_lights_punctual", "BRUME_medium_vdb", "BRUME_environment"],
    }
    write("scenes/chromatic_smoke.gltf", doc)


if __name__ == "__main__":
    furnace()
    chromatic_smoke()
