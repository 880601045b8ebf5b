#!/usr/bin/env python3
"""Writes the generated example scenes (run from the repository root):

- furnace.gltf: the cloud grid with albedo 1 inside an index-matched cube (transmission 1,
  ior 1) under a constant environment of radiance 1 and no other light. Every path ends in
  the environment with weight 1, so the exact image is 1 everywhere: the white furnace.
- chromatic_smoke.gltf: the smoke grid with strongly chromatic extinction (Principled Volume
  absorptionColor far from grey), lit by a sun and sky: the case spectral tracking exists for.
- plume_sun.gltf, plume_sky.gltf: a thin procedural smoke plume (scenes/vdb/plume.vdb, optical
  depth across it of order 1-3) with albedo 0.9 (color 0.9, absorptionColor 0, so
  sigma_s = 0.9 d and sigma_a = 0.1 d), lit by a sun over a black background, or by a
  constant sky alone. plume_blur.gltf: plume_sun with the plume's velocity grid
  (scenes/vdb/plume_vel.vdb) and a half-frame shutter: velocity motion blur. plume_bulb.gltf:
  the plume in the dark, lit only by a point light inside its dense lower part (a lamp in the
  smoke: what equiangular sampling is for).
- textured_backdrop.gltf: the cloud in front of a textured backdrop (base-colour texture,
  clamped), on a textured ground (repeat, KHR_texture_transform scale and rotation, nearest
  filter) beside an emissive sign (emissive texture), under a sun and a sky: textures/*.png
  are written here too.
- fire2.gltf: a fire made of two overlapping grids from separate files, as simulators cache
  them: the smoke (scenes/vdb/fire2_smoke.vdb, dark, scattering) and the flame
  (scenes/vdb/fire2_flame.vdb: its own density, an emission colour and blackbody emission from
  its temperature grid), over a floor. Where they overlap their coefficients and emission add.
- smoke_tank.gltf: a smoke plume (scenes/vdb/smoke.vdb) inside a glass tank: a closed
  dielectric box (ior 1.33, KHR_materials_volume with a faint blue-green water tint) around the
  VDB medium, which adds to the tank's homogeneous medium inside it (nested media), lit by a
  sun and sky over a floor.
- dense_fog.gltf: an icosahedral fog volume of nearly constant density (optical depth ~20
  through its centre) with chromatic albedo: color (0.95, 0.8, 0.6), absorptionColor 0, so the
  extinction is grey (sigma_t = densityScale * d) and sigma_a = 1 - color; HG g = 0.5; a sun
  plus a constant sky.
"""
import base64
import json
import math
import struct
import zlib


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


SUN_ROTATION = [-0.3303661, 0.2432103, 0.0885213, 0.9076734]  # as cloud.gltf


def plume(name, sun, sky, blur=False, bulb=False):
    """The plume grid spans about [-1, 1]^3 (height along y); scale 2 makes it 4 m tall. Its
    column integral across the axis is 0.060 grid units at most and 0.039 at the median height
    (printed by make_grids), so with the node's scale 2 densityScale 20 gives optical depths
    across the plume of about 1.6 (median) to 2.4 (largest): thin, as smoke from a chimney.
    With `blur`, the plume's velocity grid (scenes/vdb/plume_vel.vdb) at velocityScale 8 under
    a half-frame shutter at 24 fps: the smoke moves by up to about 7 voxels either side of
    the frame."""
    nodes = [
        {"name": "camera_node", "camera": 0, "translation": [0.0, 0.0, 9.0]},
        {"name": "plume", "scale": [2.0, 2.0, 2.0], "extensions": {"BRUME_medium_vdb": {
            "uri": "vdb/plume.vdb", "densityGrid": "density", "densityScale": PLUME_DENSITY_SCALE,
            "color": [0.9, 0.9, 0.9], "absorptionColor": [0.0, 0.0, 0.0], "anisotropy": 0.0}}},
    ]
    ext = {}
    used = ["BRUME_medium_vdb"]
    if blur:
        medium = nodes[1]["extensions"]["BRUME_medium_vdb"]
        medium.update({"uri": "vdb/plume_vel.vdb", "velocityGrid": "velocity", "velocityScale": 8.0,
                       "velocityUnit": "second"})
        ext["BRUME_render"] = {"fps": 24, "shutter": {"open": -0.25, "close": 0.25}}
        used.append("BRUME_render")
    if sun:
        nodes.append({"name": "sun", "rotation": SUN_ROTATION, "extensions": {"KHR_lights_punctual": {"light": 0}}})
        ext["KHR_lights_punctual"] = {"lights": [{"name": "sun", "type": "directional", "color": [1.0, 0.97, 0.9], "intensity": 3.0}]}
        used.append("KHR_lights_punctual")
    if sky:
        ext["BRUME_environment"] = {"color": [0.55, 0.7, 1.0], "strength": 1.0}
        used.append("BRUME_environment")
    if bulb:
        nodes.append({"name": "bulb", "translation": PLUME_BULB, "extensions": {"KHR_lights_punctual": {"light": 0}}})
        ext["KHR_lights_punctual"] = {"lights": [{"name": "bulb", "type": "point", "color": [1.0, 0.8, 0.55], "intensity": 4.0}]}
        used.append("KHR_lights_punctual")
    doc = {
        "asset": {"version": "2.0", "generator": "brume scenes/make_scenes.py"},
        "scene": 0,
        "scenes": [{"nodes": list(range(len(nodes)))}],
        "nodes": nodes,
        "cameras": [{"name": "camera", "type": "perspective", "perspective": {"yfov": 0.55, "znear": 0.05}}],
        "extensions": ext,
        "extensionsUsed": used,
    }
    write(f"scenes/{name}", doc)


def dense_fog():
    """The icosahedral fog (scenes/vdb/icosa_fog.vdb, about 1.7 x 1.7 x 2 grid units, density 1
    inside) scaled by 1.5: optical depth DENSE_FOG_SCALE * ~3 m ~ 20 through its centre."""
    doc = {
        "asset": {"version": "2.0", "generator": "brume scenes/make_scenes.py"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2]}],
        "nodes": [
            {"name": "camera_node", "camera": 0, "translation": [0.0, 0.0, 8.0]},
            {"name": "sun", "rotation": SUN_ROTATION, "extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"name": "fog", "scale": [1.5, 1.5, 1.5], "extensions": {"BRUME_medium_vdb": {
                "uri": "vdb/icosa_fog.vdb", "densityGrid": "density", "densityScale": DENSE_FOG_SCALE,
                "color": [0.95, 0.8, 0.6], "absorptionColor": [0.0, 0.0, 0.0], "anisotropy": 0.5}}},
        ],
        "cameras": [{"name": "camera", "type": "perspective", "perspective": {"yfov": 0.6, "znear": 0.05}}],
        "extensions": {
            "KHR_lights_punctual": {"lights": [{"name": "sun", "type": "directional", "color": [1.0, 0.97, 0.9], "intensity": 3.0}]},
            "BRUME_environment": {"color": [0.5, 0.6, 0.8], "strength": 0.5},
        },
        "extensionsUsed": ["KHR_lights_punctual", "BRUME_medium_vdb", "BRUME_environment"],
    }
    write("scenes/dense_fog.gltf", doc)


def write_png(path, width, height, pixel):
    """An 8-bit RGB PNG; pixel(x, y) -> (r, g, b) in 0..255, y = 0 the top row."""
    rows = b"".join(b"\0" + bytes(c for x in range(width) for c in pixel(x, y)) for y in range(height))
    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)
    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(rows, 9)) + chunk(b"IEND", b"")
    with open(path, "wb") as f:
        f.write(png)
    print("wrote", path)


def textures():
    import os
    os.makedirs("scenes/textures", exist_ok=True)
    # Backdrop: a coloured gradient with a dark grid, so both filtering and orientation show.
    def backdrop(x, y):
        if x % 16 == 0 or y % 16 == 0:
            return (30, 30, 40)
        return (40 + x * 215 // 127, 60 + y * 160 // 127, 200 - x * 150 // 127)
    write_png("scenes/textures/backdrop.png", 128, 128, backdrop)
    # Ground: a 4x4 checker of two stone tones (read with nearest filtering).
    write_png("scenes/textures/checker.png", 4, 4, lambda x, y: (200, 190, 170) if (x + y) % 2 else (70, 80, 90))
    # Sign: warm and cool stripes, emitted.
    write_png("scenes/textures/sign.png", 32, 8, lambda x, y: (255, 180, 60) if (x // 4) % 2 else (60, 140, 255))


def quads_buffer(quads):
    """Meshes of one quad each: quads = [(corners (4 x 3), uvs (4 x 2))]. Positions, normals,
    uvs, indices in one buffer; accessor k*4 + 0..3 = indices, POSITION, NORMAL, TEXCOORD_0."""
    data = b""
    views, accessors = [], []
    for corners, uvs in quads:
        e1 = [corners[1][i] - corners[0][i] for i in range(3)]
        e2 = [corners[2][i] - corners[0][i] for i in range(3)]
        n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]]
        ln = math.sqrt(sum(c * c for c in n))
        n = [c / ln for c in n]
        parts = [
            (struct.pack("<6H", 0, 1, 2, 0, 2, 3) + b"\0" * 4, {"componentType": 5123, "count": 6, "type": "SCALAR"}, 34963),
            (b"".join(struct.pack("<3f", *v) for v in corners), {"componentType": 5126, "count": 4, "type": "VEC3",
                "min": [min(v[i] for v in corners) for i in range(3)], "max": [max(v[i] for v in corners) for i in range(3)]}, 34962),
            (struct.pack("<3f", *n) * 4, {"componentType": 5126, "count": 4, "type": "VEC3"}, 34962),
            (b"".join(struct.pack("<2f", *t) for t in uvs), {"componentType": 5126, "count": 4, "type": "VEC2"}, 34962),
        ]
        for blob, acc, target in parts:
            length = len(blob) - (4 if target == 34963 else 0)
            views.append({"buffer": 0, "byteOffset": len(data), "byteLength": length, "target": target})
            acc["bufferView"] = len(views) - 1
            accessors.append(acc)
            data += blob
    return {
        "buffers": [{"byteLength": len(data), "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()}],
        "bufferViews": views,
        "accessors": accessors,
    }


FLOOR = ([(-6.0, -1.5, -6.0), (-6.0, -1.5, 6.0), (6.0, -1.5, 6.0), (6.0, -1.5, -6.0)], [0, 1, 2, 0, 2, 3])


def flat_meshes(meshes):
    """Flat-shaded triangle meshes in one buffer: mesh k gets accessors 3k (indices), 3k + 1
    (POSITION) and 3k + 2 (NORMAL, the face normal at each corner), corners unshared."""
    data = b""
    views, accessors = [], []
    for positions, indices in meshes:
        pos, nrm = [], []
        for t in range(0, len(indices), 3):
            a, b, c = (positions[i] for i in indices[t:t + 3])
            u = [b[k] - a[k] for k in range(3)]
            v = [c[k] - a[k] for k in range(3)]
            n = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]
            ln = sum(x * x for x in n) ** 0.5
            n = [x / ln for x in n]
            pos += [a, b, c]
            nrm += [n, n, n]
        ind = b"".join(struct.pack("<H", i) for i in range(len(pos)))
        ind += b"\0" * (-len(ind) % 4)
        blobs = [(ind, 34963), (b"".join(struct.pack("<3f", *p) for p in pos), 34962),
                 (b"".join(struct.pack("<3f", *n) for n in nrm), 34962)]
        for blob, target in blobs:
            views.append({"buffer": 0, "byteOffset": len(data), "byteLength": len(blob), "target": target})
            data += blob
        k = len(views) - 3
        lo = [min(p[i] for p in pos) for i in range(3)]
        hi = [max(p[i] for p in pos) for i in range(3)]
        accessors += [
            {"bufferView": k, "componentType": 5123, "count": len(pos), "type": "SCALAR"},
            {"bufferView": k + 1, "componentType": 5126, "count": len(pos), "type": "VEC3", "min": lo, "max": hi},
            {"bufferView": k + 2, "componentType": 5126, "count": len(pos), "type": "VEC3"},
        ]
    return {
        "buffers": [{"byteLength": len(data), "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()}],
        "bufferViews": views,
        "accessors": accessors,
    }


def textured_backdrop():
    textures()
    quads = [
        # Backdrop, facing +z, behind the cloud: uv (0, 0) top-left as glTF wants.
        ([(-4.0, -1.0, -3.0), (4.0, -1.0, -3.0), (4.0, 5.0, -3.0), (-4.0, 5.0, -3.0)], [(0, 1), (1, 1), (1, 0), (0, 0)]),
        # Ground, facing +y.
        ([(-6.0, -1.0, 4.0), (6.0, -1.0, 4.0), (6.0, -1.0, -3.0), (-6.0, -1.0, -3.0)], [(0, 1), (1, 1), (1, 0), (0, 0)]),
        # Emissive sign, facing +z, to the right of the cloud.
        ([(2.2, 2.4, -2.0), (3.6, 2.4, -2.0), (3.6, 2.75, -2.0), (2.2, 2.75, -2.0)], [(0, 1), (1, 1), (1, 0), (0, 0)]),
    ]
    meshes = [{"name": name, "primitives": [{"attributes": {"POSITION": 4 * k + 1, "NORMAL": 4 * k + 2, "TEXCOORD_0": 4 * k + 3},
                                             "indices": 4 * k, "material": k}]}
              for k, name in enumerate(["backdrop", "ground", "sign"])]
    lambert = {"metallicFactor": 0.0, "roughnessFactor": 1.0}
    doc = {
        "asset": {"version": "2.0", "generator": "brume scenes/make_scenes.py"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2, 3, 4, 5]}],
        "nodes": [
            {"name": "camera_node", "camera": 0, "translation": [0.0, 1.2, 9.0], "rotation": [-0.0499792, 0.0, 0.0, 0.9987503]},
            {"name": "sun", "rotation": SUN_ROTATION, "extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"name": "cloud", "translation": [-0.6, 1.4, 0.0], "scale": [1.6, 1.6, 1.6], "extensions": {"BRUME_medium_vdb": {
                "uri": "vdb/cloud.vdb", "densityGrid": "density", "densityScale": 8.0,
                "color": [1.0, 1.0, 1.0], "absorptionColor": [0.0, 0.0, 0.0], "anisotropy": 0.6}}},
            {"name": "backdrop", "mesh": 0},
            {"name": "ground", "mesh": 1},
            {"name": "sign", "mesh": 2},
        ],
        "cameras": [{"name": "camera", "type": "perspective", "perspective": {"yfov": 0.75, "znear": 0.05}}],
        "meshes": meshes,
        "materials": [
            {"name": "backdrop", "pbrMetallicRoughness": dict(lambert, baseColorTexture={"index": 0})},
            {"name": "ground", "pbrMetallicRoughness": dict(lambert, baseColorFactor=[0.9, 0.9, 0.9, 1.0], baseColorTexture={"index": 1,
                "extensions": {"KHR_texture_transform": {"scale": [6.0, 3.5], "rotation": 0.3, "offset": [0.25, 0.0]}}})},
            {"name": "sign", "pbrMetallicRoughness": dict(lambert, baseColorFactor=[0.05, 0.05, 0.05, 1.0]),
             "emissiveFactor": [1.0, 1.0, 1.0], "emissiveTexture": {"index": 2},
             "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 6.0}}},
        ],
        "textures": [{"source": 0, "sampler": 0}, {"source": 1, "sampler": 1}, {"source": 2, "sampler": 0}],
        "images": [{"uri": "textures/backdrop.png"}, {"uri": "textures/checker.png"}, {"uri": "textures/sign.png"}],
        "samplers": [
            {"magFilter": 9729, "minFilter": 9987, "wrapS": 33071, "wrapT": 33071},
            {"magFilter": 9728, "minFilter": 9728, "wrapS": 10497, "wrapT": 10497},
        ],
        "extensions": {
            "KHR_lights_punctual": {"lights": [{"name": "sun", "type": "directional", "color": [1.0, 0.97, 0.9], "intensity": 3.0}]},
            "BRUME_environment": {"color": [0.45, 0.62, 1.0], "strength": 0.4},
        },
        "extensionsUsed": ["KHR_lights_punctual", "BRUME_medium_vdb", "BRUME_environment", "KHR_texture_transform",
                           "KHR_materials_emissive_strength"],
    }
    doc.update(quads_buffer(quads))
    write("scenes/textured_backdrop.gltf", doc)
def fire2():
    doc = {
        "asset": {"version": "2.0", "generator": "brume scenes/make_scenes.py"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2, 3]}],
        "nodes": [
            {"name": "camera_node", "camera": 0, "translation": [0.0, 0.3, 6.5]},
            {"name": "floor", "mesh": 0},
            {"name": "smoke", "scale": [1.6, 1.6, 1.6], "extensions": {"BRUME_medium_vdb": {
                "uri": "vdb/fire2_smoke.vdb", "densityGrid": "density", "densityScale": 3.0,
                "color": [0.25, 0.25, 0.25], "absorptionColor": [0.0, 0.0, 0.0], "anisotropy": 0.2}}},
            {"name": "flame", "scale": [1.6, 1.6, 1.6], "extensions": {"BRUME_medium_vdb": {
                "uri": "vdb/fire2_flame.vdb", "densityGrid": "density", "densityScale": 1.5,
                "color": [0.5, 0.5, 0.5], "absorptionColor": [0.0, 0.0, 0.0],
                "emissionGrid": "density", "emissionStrength": 3.0, "emissionColor": [1.0, 0.45, 0.1],
                "temperatureGrid": "temperature", "blackbodyIntensity": 1.0,
                "temperatureScale": 1000.0, "temperatureOffset": 0.0}}},
        ],
        "cameras": [{"name": "camera", "type": "perspective", "perspective": {"yfov": 0.6, "znear": 0.05}}],
        "meshes": [{"name": "floor", "primitives": [{"attributes": {"POSITION": 1, "NORMAL": 2}, "indices": 0, "material": 0}]}],
        "materials": [{"name": "floor", "pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.2, 0.2, 1], "metallicFactor": 0, "roughnessFactor": 1}}],
        "extensions": {"BRUME_environment": {"color": [1.0, 1.0, 1.0], "strength": 0.02}},
        "extensionsUsed": ["BRUME_medium_vdb", "BRUME_environment"],
    }
    doc.update(flat_meshes([FLOOR]))
    write("scenes/fire2.gltf", doc)


def smoke_tank():
    """The tank is 2.4 x 2.6 x 2.4 m of water-tinted glass (ior 1.33: the tank and its
    contents as one dielectric volume, as a glass tank of water is usually modelled), the
    smoke grid (scale 1) inside it with densityScale 12."""
    tank_p, tank_i = cube(1.0)
    tank_p = [(1.2 * x, 1.3 * y - 0.15, 1.2 * z) for x, y, z in tank_p]
    doc = {
        "asset": {"version": "2.0", "generator": "brume scenes/make_scenes.py"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2, 3]}],
        "nodes": [
            {"name": "camera_node", "camera": 0, "translation": [0.0, 0.4, 7.0]},
            {"name": "sun", "rotation": SUN_ROTATION, "extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"name": "floor_and_tank", "mesh": 0},
            {"name": "smoke", "translation": [0.0, -0.15, 0.0], "scale": [1.0, 1.0, 1.0], "extensions": {"BRUME_medium_vdb": {
                "uri": "vdb/smoke.vdb", "densityGrid": "density", "densityScale": 12.0,
                "color": [0.8, 0.8, 0.8], "absorptionColor": [0.0, 0.0, 0.0], "anisotropy": 0.3}}},
        ],
        "cameras": [{"name": "camera", "type": "perspective", "perspective": {"yfov": 0.6, "znear": 0.05}}],
        "meshes": [{"name": "floor_and_tank", "primitives": [
            {"attributes": {"POSITION": 1, "NORMAL": 2}, "indices": 0, "material": 0},
            {"attributes": {"POSITION": 4, "NORMAL": 5}, "indices": 3, "material": 1}]}],
        "materials": [
            {"name": "floor", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0, "roughnessFactor": 1}},
            {"name": "water_glass", "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0, "roughnessFactor": 0},
             "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": 1.33},
                            "KHR_materials_volume": {"thicknessFactor": 1.0, "attenuationDistance": 4.0,
                                                     "attenuationColor": [0.85, 0.95, 0.95]}}},
        ],
        "extensions": {
            "KHR_lights_punctual": {"lights": [{"name": "sun", "type": "directional", "color": [1.0, 0.97, 0.9], "intensity": 3.0}]},
            "BRUME_environment": {"color": [0.5, 0.6, 0.8], "strength": 0.5},
        },
        "extensionsUsed": ["KHR_lights_punctual", "BRUME_medium_vdb", "BRUME_environment",
                           "KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_volume"],
    }
    doc.update(flat_meshes([FLOOR, (tank_p, tank_i)]))
    write("scenes/smoke_tank.gltf", doc)


PLUME_DENSITY_SCALE = 20.0
# Inside the plume's lower part, where it is densest (world metres; the plume is 4 m tall).
PLUME_BULB = [0.0, -1.2, 0.0]
DENSE_FOG_SCALE = 7.0


if __name__ == "__main__":
    furnace()
    chromatic_smoke()
    plume("plume_sun.gltf", sun=True, sky=False)
    plume("plume_sky.gltf", sun=False, sky=True)
    plume("plume_blur.gltf", sun=True, sky=False, blur=True)
    plume("plume_bulb.gltf", sun=False, sky=False, bulb=True)
    dense_fog()
    textured_backdrop()
    fire2()
    smoke_tank()
