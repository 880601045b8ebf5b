"""Render a Brume glTF scene with Blender Cycles (Blender as a Python module, bpy 5.0.1).

Usage (Python 3.11 with `pip install bpy==5.0.1`, see tools/cycles/ci.sh):

    python brume_to_cycles.py scene.gltf -o out.exr --spp 256 --width 96 --height 72 \
        [--seed 0] [--runs 1] [--threads 2] [--max-depth D]

With `--runs K > 1` it renders K independent images (seeds seed .. seed+K-1) and writes
`out.run<k>.exr` for each; `brume cycles` merges them into one EXR with a variance layer.
Each render's time is printed as `render_seconds <k> <s>`.

A `.blend` instead of a glTF is rendered as it is, with only the render settings below changed
(tests/external/blender_roundtrip.rs compares it with Brume's render of its export). `--save-blend X
--no-render` saves the Blender scene built from a glTF without rendering it.

The Blender scene is built as follows (docs/comparing.md has the table and the reasons):
- meshes, camera and lights by Blender's own glTF importer, lighting mode "COMPAT"
  (point/spot: W = 4 pi * intensity, sun: W/m^2 = intensity), which is Brume's factor-1
  convention because a Cycles point light of power P has radiant intensity P / (4 pi) W/sr;
  light radius 0, sun angle 0, no soft falloff;
- the camera's vertical field of view is glTF's `yfov` at the render's own aspect (as Brume);
- surface materials are rebuilt as Brume's model, not the importer's Principled BSDF:
  Lambert(base * (1 - metallic)) + GGX with Schlick Fresnel (Metallic BSDF, F82 tint white,
  which is exactly Schlick), smooth Glass BSDF for transmission, Transparent BSDF for an
  index-matched boundary, front-face-only emission unless double-sided;
- base-colour and emissive textures as Image Texture nodes (sRGB, Linear or Closest, the
  sampler's wrap mode, KHR_texture_transform composed with glTF's flipped v into UV math);
- `KHR_materials_volume` + `BRUME_materials_volume_scattering` as Volume Scatter + Volume
  Absorption with sigma_s = albedo * sigma_t, sigma_a = (1 - albedo) * sigma_t, the Volume
  Scatter nodes of the `phase` object's phase (`scatter_lobes`), else Henyey-Greenstein;
- each `BRUME_medium_vdb` node as a Volume object reading the .vdb, placed at
  (Y-up to Z-up) * (node world matrix); the grid's own transform is applied by Blender as by
  Brume; space WORLD, full precision, no clipping; a Principled Volume mapped one to one
  (with a `phase` object, Volume Scatter nodes of that phase do the scattering:
  `phase_scattering`);
  the volume datablock named so that Cycles' name-hashed mesh offset vanishes
  (`new_unshifted_volume`);
- a medium's `velocityGrid`, `velocityUnit`, `velocityScale` as the Volume's velocity grid,
  unit and scale; a sequence (`uri` with a run of `#`) as the one file of the frame
  (frame + `frameOffset`);
- `BRUME_environment` as the world background: color * strength, times an Environment
  Texture (equirectangular, through a Mapping node with the same Euler rotation) when `uri`
  is given;
- node animations as imported by Blender (key time t at frame t * fps, `BRUME_render.fps`),
  every animation playing at once as in Brume; the scene at `BRUME_render.frame`;
  `BRUME_render.shutter` as Blender's motion blur (length, and Center, Start or End on the
  frame), with object motion blur off on everything but the camera and media with a velocity
  grid (Brume renders the rest at the frame's instant);
- render settings that remove avoidable differences (see `configure_render`).
"""
import argparse
import json
import math
import os
import sys
import time

import bpy
from mathutils import Matrix, Quaternion, Vector

# Brume's default maximum number of scattering events
# (`render::settings::DEFAULT_MAX_DEPTH`).
DEFAULT_MAX_DEPTH = 256

# glTF (Y up) to Blender (Z up): (x, y, z) -> (x, -z, y), as the importer converts.
BLENDER_FROM_GLTF = Matrix(((1, 0, 0, 0), (0, 0, -1, 0), (0, 1, 0, 0), (0, 0, 0, 1)))


def node_local(node):
    if "matrix" in node:
        m = node["matrix"]  # column-major
        return Matrix([[m[c * 4 + r] for c in range(4)] for r in range(4)])
    t = Vector(node.get("translation", [0, 0, 0]))
    x, y, z, w = node.get("rotation", [0, 0, 0, 1])
    r = Quaternion((w, x, y, z)).to_matrix().to_4x4()
    s = node.get("scale", [1, 1, 1])
    sm = Matrix.Diagonal((s[0], s[1], s[2], 1.0))
    return Matrix.Translation(t) @ r @ sm


def world_matrices(gltf):
    """glTF world matrix of every node reachable from the default scene."""
    nodes = gltf.get("nodes", [])
    out = {}
    scenes = gltf.get("scenes")
    if scenes:
        roots = scenes[gltf.get("scene", 0)].get("nodes", [])
    else:
        children = {c for n in nodes for c in n.get("children", [])}
        roots = [i for i in range(len(nodes)) if i not in children]
    stack = [(i, Matrix.Identity(4)) for i in roots]
    while stack:
        i, parent = stack.pop()
        m = parent @ node_local(nodes[i])
        out[i] = m
        stack.extend((c, m) for c in nodes[i].get("children", []))
    return out


def new_tree(mat):
    mat.use_nodes = True
    nt = mat.node_tree
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    out.target = "CYCLES"
    return nt, out


def volume_nodes(nt, sigma_s, sigma_a, phase):
    """Volume Scatter with Brume's `phase` object (sigma_s = color * density:
    `scatter_lobes`) + Volume Absorption (sigma_a = (1 - color) * density), colours normalised
    so they stay in [0, 1]."""
    shaders = []
    ds = max(sigma_s)
    if ds > 0:
        shaders += scatter_lobes(nt, phase, [c / ds for c in sigma_s], ds)
    da = max(sigma_a)
    if da > 0:
        ab = nt.nodes.new("ShaderNodeVolumeAbsorption")
        ab.inputs["Color"].default_value = [1.0 - c / da for c in sigma_a] + [1.0]
        ab.inputs["Density"].default_value = da
        shaders.append(ab.outputs[0])
    return add_shaders(nt, shaders)


def add_shaders(nt, outs):
    if not outs:
        return None
    acc = outs[0]
    for o in outs[1:]:
        add = nt.nodes.new("ShaderNodeAddShader")
        nt.links.new(acc, add.inputs[0])
        nt.links.new(o, add.inputs[1])
        acc = add.outputs[0]
    return acc


WRAP = {33071: "EXTEND", 33648: "MIRROR", 10497: "REPEAT"}


def linear_float_copy(img):
    """The image sRGB-decoded into a float buffer read as Non-Color. Cycles keeps an 8-bit sRGB
    image as bytes and decodes after interpolating (`compress_as_srgb`), so a blend of a dark
    and a bright texel comes out darker than the blend of their linear values, which is what
    glTF asks for and Brume does (1 % darker on scenes/textured_backdrop.gltf, 32 % of blocks
    failing; BRUME_CYCLES_NATIVE_TEXTURE=1 keeps the native path to show it)."""
    import numpy as np
    w, h = img.size
    px = np.empty(w * h * 4, dtype=np.float32)
    img.pixels.foreach_get(px)
    rgb = px.reshape(-1, 4)[:, :3]
    px.reshape(-1, 4)[:, :3] = np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
    out = bpy.data.images.new(img.name + ".linear", w, h, alpha=True, float_buffer=True)
    out.colorspace_settings.name = "Non-Color"
    out.pixels.foreach_set(px)
    out.pack()
    return out


def texture_node(nt, gltf, info, base_dir):
    """An Image Texture node reading `info` (a glTF textureInfo) as Brume does
    (src/scene/texture.rs): sRGB-decoded, bilinear unless the sampler's magFilter is NEAREST,
    the sampler's wrap mode, and KHR_texture_transform applied to TEXCOORD_0. Returns its
    Color output (linear RGB)."""
    tex = gltf["textures"][info["index"]]
    image = gltf["images"][tex["source"]]
    uri = image.get("uri")
    if uri is None or uri.startswith("data:"):
        sys.exit("error: only textures in image files next to the glTF are mapped to Cycles")
    from urllib.parse import unquote
    img = bpy.data.images.load(os.path.join(base_dir, unquote(uri)), check_existing=True)
    img.colorspace_settings.name = "sRGB"
    if img.is_float is False and os.environ.get("BRUME_CYCLES_NATIVE_TEXTURE") != "1":
        img = linear_float_copy(img)
    node = nt.nodes.new("ShaderNodeTexImage")
    node.image = img
    sampler = gltf.get("samplers", [])[tex["sampler"]] if "sampler" in tex else {}
    node.interpolation = "Closest" if sampler.get("magFilter") == 9728 else "Linear"
    wrap_s = WRAP[sampler.get("wrapS", 10497)]
    wrap_t = WRAP[sampler.get("wrapT", 10497)]
    if wrap_s != wrap_t:
        sys.exit("error: Cycles has one extension mode per image; wrapS and wrapT differ")
    node.extension = wrap_s
    # glTF's v points down from the image's top row, Blender's up from its bottom row:
    # uv_g = (u_b, 1 - v_b). KHR_texture_transform (M = T R S) acts on uv_g; the result goes
    # back to Blender's convention. Composed into one affine map of Blender's UV.
    t = info.get("extensions", {}).get("KHR_texture_transform", {})
    ox, oy = t.get("offset", [0.0, 0.0])
    sx, sy = t.get("scale", [1.0, 1.0])
    r = t.get("rotation", 0.0)
    a, b, c = math.cos(r) * sx, math.sin(r) * sy, ox
    d, e, f = -math.sin(r) * sx, math.cos(r) * sy, oy
    rows = [((a, -b), b + c), ((-d, e), 1.0 - e - f)]
    uv = nt.nodes.new("ShaderNodeUVMap")
    out = []
    for (cu, cv), k in rows:
        dot = nt.nodes.new("ShaderNodeVectorMath")
        dot.operation = "DOT_PRODUCT"
        nt.links.new(uv.outputs["UV"], dot.inputs[0])
        dot.inputs[1].default_value = (cu, cv, 0.0)
        add = nt.nodes.new("ShaderNodeMath")
        add.operation = "ADD"
        nt.links.new(dot.outputs["Value"], add.inputs[0])
        add.inputs[1].default_value = k
        out.append(add.outputs[0])
    comb = nt.nodes.new("ShaderNodeCombineXYZ")
    nt.links.new(out[0], comb.inputs[0])
    nt.links.new(out[1], comb.inputs[1])
    nt.links.new(comb.outputs[0], node.inputs["Vector"])
    return node.outputs["Color"]


def scaled_color(nt, color_out, factor, offset=None):
    """`factor * color_out (+ offset)` as a Vector Math node; factor and offset are RGB."""
    m = nt.nodes.new("ShaderNodeVectorMath")
    m.operation = "MULTIPLY_ADD"
    nt.links.new(color_out, m.inputs[0])
    m.inputs[1].default_value = tuple(factor)
    m.inputs[2].default_value = tuple(offset or (0.0, 0.0, 0.0))
    return m.outputs["Vector"]


def build_surface_material(mat, gm, gltf, base_dir):
    """Brume's surface model (src/integrator/bsdf.rs, prepare.rs) as Cycles nodes."""
    pbr = gm.get("pbrMetallicRoughness", {})
    base = pbr.get("baseColorFactor", [1, 1, 1, 1])[:3]
    metallic = pbr.get("metallicFactor", 1.0)
    roughness = pbr.get("roughnessFactor", 1.0)
    ext = gm.get("extensions", {})
    transmission = ext.get("KHR_materials_transmission", {}).get("transmissionFactor", 0.0)
    ior = ext.get("KHR_materials_ior", {}).get("ior", 1.5)
    nt, out = new_tree(mat)
    if transmission > 0:
        if abs(ior - 1.0) < 1e-6:
            # Index-matched boundary: Brume only changes the medium there.
            surf = nt.nodes.new("ShaderNodeBsdfTransparent")
            surf.inputs["Color"].default_value = (1, 1, 1, 1)
        else:
            # Brume: smooth dielectric, roughness ignored, base colour on refraction only
            # (white in every example scene).
            surf = nt.nodes.new("ShaderNodeBsdfGlass")
            surf.distribution = "GGX"
            surf.inputs["Color"].default_value = (1, 1, 1, 1)
            surf.inputs["Roughness"].default_value = 0.0
            surf.inputs["IOR"].default_value = ior
        shader = surf.outputs[0]
    else:
        diffuse = nt.nodes.new("ShaderNodeBsdfDiffuse")
        diffuse.inputs["Color"].default_value = [c * (1 - metallic) for c in base] + [1.0]
        diffuse.inputs["Roughness"].default_value = 0.0  # Lambert
        spec = nt.nodes.new("ShaderNodeBsdfMetallic")
        spec.distribution = "GGX"  # single scattering, no energy compensation, as Brume
        spec.fresnel_type = "F82"  # with a white edge tint F82-tint is exactly Schlick
        f0 = [0.04 + (c - 0.04) * metallic for c in base]
        spec.inputs["Base Color"].default_value = f0 + [1.0]
        if "baseColorTexture" in pbr:
            tex = texture_node(nt, gltf, pbr["baseColorTexture"], base_dir)
            kd = scaled_color(nt, tex, [c * (1 - metallic) for c in base])
            nt.links.new(kd, diffuse.inputs["Color"])
            ks = scaled_color(nt, tex, [c * metallic for c in base], [0.04 * (1 - metallic)] * 3)
            nt.links.new(ks, spec.inputs["Base Color"])
        spec.inputs["Edge Tint"].default_value = (1, 1, 1, 1)
        # Brume keeps alpha = max(roughness^2, 2e-3).
        spec.inputs["Roughness"].default_value = max(roughness, math.sqrt(2e-3))
        shader = add_shaders(nt, [diffuse.outputs[0], spec.outputs[0]])
    emissive = gm.get("emissiveFactor", [0, 0, 0])
    strength = ext.get("KHR_materials_emissive_strength", {}).get("emissiveStrength", 1.0)
    if max(emissive) * strength > 0:
        em = nt.nodes.new("ShaderNodeEmission")
        em.inputs["Color"].default_value = list(emissive) + [1.0]
        em.inputs["Strength"].default_value = strength  # radiance = colour * strength
        if "emissiveTexture" in gm:
            tex = texture_node(nt, gltf, gm["emissiveTexture"], base_dir)
            nt.links.new(scaled_color(nt, tex, emissive), em.inputs["Color"])
        lit = add_shaders(nt, [shader, em.outputs[0]])
        if gm.get("doubleSided", False):
            shader = lit
            mat.cycles.emission_sampling = "FRONT_BACK"
        else:
            # glTF emits from the front face only (Brume's `emitted`).
            geo = nt.nodes.new("ShaderNodeNewGeometry")
            mix = nt.nodes.new("ShaderNodeMixShader")
            nt.links.new(geo.outputs["Backfacing"], mix.inputs[0])
            nt.links.new(lit, mix.inputs[1])
            nt.links.new(shader, mix.inputs[2])
            shader = mix.outputs[0]
            mat.cycles.emission_sampling = "FRONT"
    nt.links.new(shader, out.inputs["Surface"])
    vol = ext.get("KHR_materials_volume")
    if vol and transmission > 0 and vol.get("thicknessFactor", 0.0) > 0:
        att = vol.get("attenuationColor", [1, 1, 1])
        dist = vol.get("attenuationDistance", math.inf)
        sigma_t = [0.0 if math.isinf(dist) else -math.log(max(c, 1e-30)) / dist for c in att]
        sc = ext.get("BRUME_materials_volume_scattering", {})
        albedo = sc.get("albedo", [0, 0, 0])
        phase = sc.get("phase", {"type": "henyey-greenstein", "g": sc.get("anisotropy", 0.0)})
        sigma_s = [a * t for a, t in zip(albedo, sigma_t)]
        sigma_a = [(1 - a) * t for a, t in zip(albedo, sigma_t)]
        v = volume_nodes(nt, sigma_s, sigma_a, phase)
        if v is not None:
            nt.links.new(v, out.inputs["Volume"])


def spot_falloff_shader(obj, cos_inner, cos_outer):
    light = obj.data
    light.spot_size = 2.0 * math.acos(cos_outer)
    light.spot_blend = 0.0
    light.use_nodes = True
    nt = light.node_tree
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    out = nt.nodes.new("ShaderNodeOutputLight")
    em = nt.nodes.new("ShaderNodeEmission")
    em.inputs["Color"].default_value = (1, 1, 1, 1)
    geo = nt.nodes.new("ShaderNodeNewGeometry")
    dot = nt.nodes.new("ShaderNodeVectorMath")
    dot.operation = "DOT_PRODUCT"
    axis = (obj.matrix_world.to_3x3() @ Vector((0, 0, -1))).normalized()
    dot.inputs[1].default_value = axis
    nt.links.new(geo.outputs["Normal"], dot.inputs[0])
    # a = clamp((cos - cos_outer) / (cos_inner - cos_outer)), as Brume with its 1e-3 guard.
    ramp = nt.nodes.new("ShaderNodeMath")
    ramp.operation = "MULTIPLY_ADD"
    k = 1.0 / max(cos_inner - cos_outer, 1e-3)
    ramp.inputs[1].default_value = k
    ramp.inputs[2].default_value = -cos_outer * k
    ramp.use_clamp = True
    nt.links.new(dot.outputs["Value"], ramp.inputs[0])
    sq = nt.nodes.new("ShaderNodeMath")
    sq.operation = "MULTIPLY"
    nt.links.new(ramp.outputs[0], sq.inputs[0])
    nt.links.new(ramp.outputs[0], sq.inputs[1])
    nt.links.new(sq.outputs[0], em.inputs["Strength"])
    nt.links.new(em.outputs[0], out.inputs["Surface"])


def cycles_face_overlap_avoidance(name):
    """The fraction Cycles offsets a volume's mesh by, from the volume datablock's name.

    Cycles' `GeometryManager::create_volume_mesh` (intern/cycles/scene/volume.cpp) moves every
    vertex of the volume's bounding mesh by `f * (1 / dim.x, 1 / dim.y, 1 / dim.z)` in the
    grid's world space, `dim` the padded active voxel box, with
    `f = 0.1 * hash_uint_to_float(hash_string(name))` (util/hash.h: a `* 37 + c` string hash,
    then one Jenkins lookup3 `final`), so that overlapping volumes do not share faces. The
    offset is in the grid's world units whatever its voxel size (the plume, 0.025-unit voxels
    and 38 across: 0.07 of a voxel in x), and the box where a constant emission glows moves
    with it.
    """
    m = 0xFFFFFFFF

    def rot(x, k):
        return ((x << k) | (x >> (32 - k))) & m

    h = 0
    for c in name.encode():
        # UTF-8 bytes, unsigned: measured with a non-ASCII name ("fumée"), whose face
        # agreed this way (+0.15 %) and not with sign-extended bytes (-1.35 %).
        h = (h * 37 + c) & m
    a = b = c = (0xDEADBEEF + (1 << 2) + 13) & m
    a = (a + h) & m
    c ^= b; c = (c - rot(b, 14)) & m  # noqa: E702
    a ^= c; a = (a - rot(c, 11)) & m  # noqa: E702
    b ^= a; b = (b - rot(a, 25)) & m  # noqa: E702
    c ^= b; c = (c - rot(b, 16)) & m  # noqa: E702
    a ^= c; a = (a - rot(c, 4)) & m  # noqa: E702
    b ^= a; b = (b - rot(a, 14)) & m  # noqa: E702
    c ^= b; c = (c - rot(b, 24)) & m  # noqa: E702
    return 0.1 * c / m


def new_unshifted_volume(name):
    """A new volume datablock named `name`, or `name~k` for the first `k`, whose `f` is below
    1e-5 (an offset below 1e-5 / dim world units: Cycles' volume box is then the unshifted one
    Brume uses). The name is read back, so a name Blender changes (taken, or too long) is
    never the one hashed."""
    k = 0
    while True:
        candidate = name if k == 0 else f"{name}~{k}"
        k += 1
        if cycles_face_overlap_avoidance(candidate) >= 1e-5 or candidate in bpy.data.volumes:
            continue
        vol = bpy.data.volumes.new(candidate)
        if vol.name == candidate:
            return vol
        bpy.data.volumes.remove(vol)


def for_frame(uri, frame):
    """`uri` with its last run of `#` replaced by `frame`, zero-padded to the run's length (a
    longer number as it is; -005 for -5 on four), as Brume names a sequence's files
    (src/scene/sequence.rs)."""
    end = uri.rfind("#") + 1
    if end == 0:
        return uri
    start = len(uri[:end].rstrip("#"))
    return f"{uri[:start]}{frame:0{end - start}d}{uri[end:]}"


def build_medium(name, ext, base_dir, world_from_node, frame, parent=None):
    """A BRUME_medium_vdb node as a Volume object with a Principled Volume, reading the file
    of `frame` for a sequence (a `uri` with a run of `#`, file = frame + frameOffset). With
    `parent` (the importer's object of an animated node) the Volume hangs under it and follows
    its motion; otherwise it is placed at `world_from_node`."""
    from urllib.parse import unquote

    uri = for_frame(ext["uri"], frame + int(ext.get("frameOffset", 0)))
    path = os.path.join(base_dir, unquote(uri))
    # The datablock's name decides Cycles' mesh offset (`cycles_face_overlap_avoidance`).
    vol = new_unshifted_volume(name)
    vol.filepath = os.path.abspath(path)
    vol.grids.load()
    vol.render.space = "WORLD"  # OBJECT would divide density by the object's scale
    vol.render.precision = "FULL"  # the default HALF quantises the grid
    vol.render.clipping = 0.0  # the default 0.001 drops low-density voxels
    obj = bpy.data.objects.new(name, vol)
    bpy.context.scene.collection.objects.link(obj)
    if parent is None:
        obj.matrix_world = BLENDER_FROM_GLTF @ world_from_node
    else:
        # The importer's object of node W is B W B^-1 (B = BLENDER_FROM_GLTF); the Volume
        # needs B W, which is that object times B whatever W is at the frame.
        obj.parent = parent
        obj.matrix_parent_inverse = Matrix.Identity(4)
        obj.matrix_basis = BLENDER_FROM_GLTF.copy()
    # Velocity motion blur: Blender's own settings, which Brume's fields copy. Cycles also
    # reads a grid named `velocity` as the velocity whatever velocity_grid says, and only
    # blurs objects whose own motion blur is on: a medium without velocityGrid has it off
    # (Brume renders media at the frame's instant; only their velocity blurs them).
    grid = ext.get("velocityGrid")
    obj.cycles.use_motion_blur = grid is not None
    if grid is not None:
        vol.velocity_grid = grid
        vol.velocity_unit = "FRAME" if ext.get("velocityUnit") == "frame" else "SECOND"
        vol.velocity_scale = ext.get("velocityScale", 1.0)
        if grid != "velocity" and any(g.name == "velocity" for g in vol.grids):
            print(
                f"note: {path} also has a grid named 'velocity', which Cycles reads as the velocity "
                f"too; the two renders may differ",
                file=sys.stderr,
            )

    mat = bpy.data.materials.new(name + "_medium")
    nt, out = new_tree(mat)
    mat.cycles.volume_interpolation = "LINEAR"  # trilinear, as Brume
    pv = nt.nodes.new("ShaderNodeVolumePrincipled")
    pv.inputs["Density"].default_value = ext.get("densityScale", 1.0)
    pv.inputs["Density Attribute"].default_value = ext.get("densityGrid", "density")
    pv.inputs["Color"].default_value = list(ext.get("color", [0.5, 0.5, 0.5])) + [1.0]
    pv.inputs["Color Attribute"].default_value = ""
    pv.inputs["Absorption Color"].default_value = list(ext.get("absorptionColor", [0, 0, 0])) + [1.0]
    pv.inputs["Anisotropy"].default_value = ext.get("anisotropy", 0.0)
    strength = ext.get("emissionStrength", 0.0)
    pv.inputs["Emission Strength"].default_value = strength
    pv.inputs["Emission Color"].default_value = list(ext.get("emissionColor", [1, 1, 1])) + [1.0]
    if "emissionGrid" in ext and strength > 0:
        attr = nt.nodes.new("ShaderNodeAttribute")
        attr.attribute_type = "GEOMETRY"
        attr.attribute_name = ext["emissionGrid"]
        mul = nt.nodes.new("ShaderNodeMath")
        mul.operation = "MULTIPLY"
        mul.inputs[1].default_value = strength
        nt.links.new(attr.outputs["Fac"], mul.inputs[0])
        nt.links.new(mul.outputs[0], pv.inputs["Emission Strength"])
    # Cycles multiplies the Temperature socket by the temperature attribute; Brume's
    # T = scale * t + offset needs the attribute read separately and the socket linked.
    pv.inputs["Temperature Attribute"].default_value = ""
    bb = ext.get("blackbodyIntensity", 0.0) if "temperatureGrid" in ext else 0.0
    pv.inputs["Blackbody Intensity"].default_value = bb
    pv.inputs["Blackbody Tint"].default_value = list(ext.get("blackbodyTint", [1, 1, 1])) + [1.0]
    if bb > 0:
        attr = nt.nodes.new("ShaderNodeAttribute")
        attr.attribute_type = "GEOMETRY"
        attr.attribute_name = ext["temperatureGrid"]
        ma = nt.nodes.new("ShaderNodeMath")
        ma.operation = "MULTIPLY_ADD"
        ma.inputs[1].default_value = ext.get("temperatureScale", 1.0)
        ma.inputs[2].default_value = ext.get("temperatureOffset", 0.0)
        nt.links.new(attr.outputs["Fac"], ma.inputs[0])
        nt.links.new(ma.outputs[0], pv.inputs["Temperature"])
    volume = pv.outputs[0]
    if "phase" in ext:
        volume = phase_scattering(nt, pv, ext)
    nt.links.new(volume, out.inputs["Volume"])
    vol.materials.append(mat)
    return obj


# Brume's phase types as Cycles' Volume Scatter phases.
CYCLES_PHASES = {
    "henyey-greenstein": "HENYEY_GREENSTEIN",
    "draine": "DRAINE",
    "mie": "MIE",
    "rayleigh": "RAYLEIGH",
}


def phase_scattering(nt, pv, ext):
    """A medium with a `phase` object: the Principled Volume keeps its absorption and emission
    but no scattering (Color black, Absorption Color chosen so that its sigma_a stays
    `max(1 - color, 0) * (1 - sqrt(absorptionColor))` per unit density), and Volume Scatter
    nodes with that phase scatter `color * density`; a two-lobe phase is two Henyey-Greenstein
    Volume Scatter nodes splitting `color` by the weight. Returns the summed volume output."""
    color = list(ext.get("color", [0.5, 0.5, 0.5]))
    absorption = list(ext.get("absorptionColor", [0, 0, 0]))
    kept = [max(1.0 - c, 0.0) * max(1.0 - math.sqrt(a), 0.0) for c, a in zip(color, absorption)]
    pv.inputs["Color"].default_value = [0.0, 0.0, 0.0, 1.0]
    pv.inputs["Absorption Color"].default_value = [(1.0 - k) ** 2 for k in kept] + [1.0]
    # The scattering density: densityScale times the density grid.
    attr = nt.nodes.new("ShaderNodeAttribute")
    attr.attribute_type = "GEOMETRY"
    attr.attribute_name = ext.get("densityGrid", "density")
    density = nt.nodes.new("ShaderNodeMath")
    density.operation = "MULTIPLY"
    density.inputs[1].default_value = ext.get("densityScale", 1.0)
    nt.links.new(attr.outputs["Fac"], density.inputs[0])
    lobes = scatter_lobes(nt, ext["phase"], color, density.outputs[0])
    return add_shaders(nt, [pv.outputs[0]] + lobes)


def scatter_lobes(nt, phase, color, density):
    """Volume Scatter nodes with Brume's `phase` object scattering `color * density`
    (`density` a number or an output socket): one node of Cycles' phase of that name, or two
    Henyey-Greenstein nodes splitting `color` by the weight for a two-lobe phase. Returns
    their outputs."""
    kind = phase.get("type")

    def scatter(cycles_phase, share):
        sc = nt.nodes.new("ShaderNodeVolumeScatter")
        sc.phase = cycles_phase
        sc.inputs["Color"].default_value = [c * share for c in color] + [1.0]
        if isinstance(density, (int, float)):
            sc.inputs["Density"].default_value = density
        else:
            nt.links.new(density, sc.inputs["Density"])
        return sc

    if kind == "two-lobe":
        w = phase.get("weight", 0.5)
        a, b = scatter("HENYEY_GREENSTEIN", w), scatter("HENYEY_GREENSTEIN", 1.0 - w)
        a.inputs["Anisotropy"].default_value = phase.get("g1", 0.0)
        b.inputs["Anisotropy"].default_value = phase.get("g2", 0.0)
        lobes = [a.outputs[0], b.outputs[0]]
    elif kind in CYCLES_PHASES:
        sc = scatter(CYCLES_PHASES[kind], 1.0)
        # Each phase shows only its own sockets.
        values = {
            "henyey-greenstein": {"Anisotropy": phase.get("g", 0.0)},
            "draine": {"Anisotropy": phase.get("g", 0.0), "Alpha": phase.get("alpha", 1.0)},
            "mie": {"Diameter": phase.get("diameter", 20.0)},
            "rayleigh": {},
        }[kind]
        for socket, value in values.items():
            sc.inputs[socket].default_value = value
        lobes = [sc.outputs[0]]
    else:
        sys.exit(f"error: phase type {kind!r} has no Cycles counterpart")
    return lobes


def build_environment_map(nt, bg, env, base_dir):
    """`BRUME_environment.uri`: Texture Coordinate.Generated -> Mapping (Point, Euler XYZ
    `rotation`) -> Environment Texture (equirectangular, Linear) -> x `color` -> Background,
    whose Strength is `strength`. Brume's lookup is defined to be exactly this node chain
    (src/render/envmap.rs); the image is read as Non-Color data (linear radiance)."""
    coord = nt.nodes.new("ShaderNodeTexCoord")
    mapping = nt.nodes.new("ShaderNodeMapping")
    mapping.vector_type = "POINT"
    mapping.inputs["Rotation"].default_value = list(env.get("rotation", [0.0, 0.0, 0.0]))
    tex = nt.nodes.new("ShaderNodeTexEnvironment")
    tex.projection = "EQUIRECTANGULAR"
    tex.interpolation = "Linear"
    tex.image = bpy.data.images.load(os.path.join(base_dir, env["uri"]), check_existing=True)
    tex.image.colorspace_settings.name = "Non-Color"
    # color x texture, channel by channel (colours convert to vectors and back losslessly).
    mul = nt.nodes.new("ShaderNodeVectorMath")
    mul.operation = "MULTIPLY"
    mul.inputs[1].default_value = list(env.get("color", [1, 1, 1]))
    nt.links.new(coord.outputs["Generated"], mapping.inputs["Vector"])
    nt.links.new(mapping.outputs["Vector"], tex.inputs["Vector"])
    nt.links.new(tex.outputs["Color"], mul.inputs[0])
    nt.links.new(mul.outputs["Vector"], bg.inputs["Color"])


def play_all_animations(gltf):
    """Brume plays every animation of the file at once; Blender's importer makes one action
    per glTF animation, assigns the first and stashes the others on muted NLA tracks. Each
    animated object gets one action holding all of its channels from every animation (the
    keys as imported: LINEAR and STEP as they are, CUBICSPLINE as Bezier with automatic
    handles, not glTF's tangents), the NLA tracks go. Returns the names of the objects."""
    from bpy_extras import anim_utils

    animated = []
    for obj in bpy.context.scene.objects:
        ad = obj.animation_data
        if ad is None:
            continue
        sources = [(s.action, s.action_slot) for t in ad.nla_tracks for s in t.strips if s.action is not None]
        if ad.action is not None:
            sources.append((ad.action, ad.action_slot))
        curves = {}
        for action, slot in sources:
            bag = anim_utils.action_get_channelbag_for_slot(action, slot)
            for fc in bag.fcurves if bag is not None else []:
                curves[(fc.data_path, fc.array_index)] = fc
        for track in list(ad.nla_tracks):
            ad.nla_tracks.remove(track)
        if not curves:
            continue
        merged = bpy.data.actions.new(f"{obj.name}_brume")
        ad.action = merged
        for (path, index), fc in sorted(curves.items()):
            out = merged.fcurve_ensure_for_datablock(obj, path, index=index)
            n = len(fc.keyframe_points)
            co = [0.0] * (2 * n)
            fc.keyframe_points.foreach_get("co", co)
            ipo = [0] * n
            fc.keyframe_points.foreach_get("interpolation", ipo)
            out.keyframe_points.add(n)
            out.keyframe_points.foreach_set("co", co)
            out.keyframe_points.foreach_set("interpolation", ipo)
            for k, src in zip(out.keyframe_points, fc.keyframe_points):
                k.handle_left_type = src.handle_left_type
                k.handle_right_type = src.handle_right_type
            out.extrapolation = "CONSTANT"  # glTF holds the first and last keys
            out.update()
        animated.append(obj.name)
    if any(s.get("interpolation") == "CUBICSPLINE" for a in gltf.get("animations", []) for s in a.get("samplers", [])):
        print(
            "note: CUBICSPLINE animations are imported as Bezier curves with automatic handles "
            "(Blender's importer ignores glTF's tangents): the motion between keys differs from Brume's",
            file=sys.stderr,
        )
    return animated


def moving_nodes(gltf):
    """Indices of the nodes that an animation moves, directly or through a parent."""
    nodes = gltf.get("nodes", [])
    targets = {c["target"]["node"] for a in gltf.get("animations", []) for c in a.get("channels", []) if "node" in c.get("target", {})}
    parent = {c: i for i, n in enumerate(nodes) for c in n.get("children", [])}
    moving = set()
    for i in range(len(nodes)):
        j = i
        while j is not None:
            if j in targets:
                moving.add(i)
                break
            j = parent.get(j)
    return moving


def configure_motion(scene, args, render, frame):
    """The frame and the shutter (`BRUME_render.shutter`, frames around the frame): Blender's
    motion blur of that length, centred on the frame, starting or ending on it. Only the
    camera and media with a velocity grid blur (Brume renders everything else at the frame's
    instant): the other objects' own motion blur is off."""
    scene.frame_set(frame)
    shutter = render.get("shutter")
    opened = shutter is not None and shutter.get("close", 0.25) > shutter.get("open", -0.25)
    scene.render.use_motion_blur = opened
    for obj in scene.objects:
        if obj.type not in ("CAMERA", "VOLUME"):
            obj.cycles.use_motion_blur = False
    if not opened:
        return
    a, b = shutter.get("open", -0.25), shutter.get("close", 0.25)
    length = b - a
    if abs(a + b) <= 1e-6 * length:
        position = "CENTER"
    elif a == 0.0:
        position = "START"
    elif b == 0.0:
        position = "END"
    else:
        sys.exit(
            f"error: {args.scene}: /extensions/BRUME_render/shutter: {a}..{b} frames; Cycles' "
            "shutter is centred on the frame, starts on it or ends on it"
        )
    scene.render.motion_blur_shutter = length
    scene.render.motion_blur_position = position
    if position == "END" and any(o.type == "VOLUME" and o.cycles.use_motion_blur for o in scene.objects):
        # Cycles' volume_shader_motion_blur takes time (1 - shutter) + tau for End, tau in
        # [0, 1]: measured on the plume, its End render matches Brume's shutter 0.25..0.75
        # (+1.35 %) far better than -0.5..0 (+4.3 %).
        print(
            f"note: Cycles advects velocity-blurred volumes over frames {(1 - length) * length:g}.."
            f"{(2 - length) * length:g} after the frame when the shutter ends on it, not over "
            f"{-length:g}..0 as Brume does: those volumes render differently",
            file=sys.stderr,
        )


def configure_render(scene, args):
    scene.render.engine = "CYCLES"
    c = scene.cycles
    c.device = "CPU"
    c.samples = args.spp
    c.use_adaptive_sampling = False
    c.time_limit = 0
    c.use_denoising = False
    # Brume's depth counts scattering events, the first one included (1: single scattering);
    # Cycles counts bounces after the first (0: direct light at the first event only), so it
    # has nothing for Brume's 0 (emitters seen directly, no light scattered at all).
    if args.max_depth < 1:
        sys.exit(
            f"error: {args.scene}: depth {args.max_depth}: Cycles lights the first event at any "
            "bounce count, so it cannot render Brume's depth 0 (use a depth of at least 1)"
        )
    bounces = args.max_depth - 1
    c.max_bounces = bounces
    c.diffuse_bounces = bounces
    c.glossy_bounces = bounces
    c.transmission_bounces = bounces
    c.volume_bounces = bounces  # default 0: single scattering only
    # An index-matched boundary is a transparent bounce in Cycles and no event at all in
    # Brume: never the limit.
    c.transparent_max_bounces = 1024  # default 8
    c.sample_clamp_direct = 0.0
    c.sample_clamp_indirect = 0.0  # default 10
    c.light_sampling_threshold = 0.0  # default 0.01
    c.blur_glossy = 0.0  # "Filter Glossy", default 1
    c.caustics_reflective = True
    c.caustics_refractive = True
    c.use_light_tree = False
    c.use_guiding = False
    c.volume_biased = False  # null scattering, unbiased
    c.pixel_filter_type = "BOX"
    c.filter_width = 1.0  # one pixel: uniform jitter within the pixel, as Brume
    c.sampling_pattern = "TABULATED_SOBOL"  # no blue-noise correlation between pixels
    c.use_animated_seed = False
    scene.render.resolution_x = args.width
    scene.render.resolution_y = args.height
    scene.render.resolution_percentage = 100
    scene.render.pixel_aspect_x = 1
    scene.render.pixel_aspect_y = 1
    # Film > Transparent: the sky seen straight through is left out and alpha is coverage.
    scene.render.film_transparent = args.film == "transparent"
    scene.render.use_compositing = False
    scene.render.use_sequencer = False
    scene.render.threads_mode = "FIXED" if args.threads else "AUTO"
    if args.threads:
        scene.render.threads = args.threads
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    img = scene.render.image_settings
    if args.passes == "light":
        enable_light_passes(scene.view_layers[0])
        # Passes need a multilayer file: one part per pass, `ViewLayer.<pass>.R/G/B`.
        img.media_type = "MULTI_LAYER_IMAGE"
        img.file_format = "OPEN_EXR_MULTILAYER"
    else:
        img.file_format = "OPEN_EXR"
    img.color_mode = "RGBA"
    img.color_depth = "32"
    img.exr_codec = "ZIP"


def enable_light_passes(view_layer):
    """Cycles' light passes that Brume's `--passes light` splits the beauty into: Emission,
    Environment, Volume Direct/Indirect, and the surfaces' Diffuse, Glossy and Transmission
    Direct/Indirect with their Color passes (Cycles divides a surface's light passes by its
    colour; Brume's surface passes are the products, summed)."""
    view_layer.use_pass_emit = True
    view_layer.use_pass_environment = True
    view_layer.cycles.use_pass_volume_direct = True
    view_layer.cycles.use_pass_volume_indirect = True
    for kind in ("diffuse", "glossy", "transmission"):
        for part in ("direct", "indirect", "color"):
            setattr(view_layer, f"use_pass_{kind}_{part}", True)


def open_blend(args):
    """A .blend rendered as it is, with only the render settings of `configure_render` (the
    reference for tools/blender's exporter: tests/external/blender_roundtrip.rs)."""
    bpy.ops.wm.open_mainfile(filepath=os.path.abspath(args.scene))
    scene = bpy.context.scene
    if scene.camera is None:
        sys.exit(f"error: {args.scene}: the scene has no active camera")
    if args.max_depth is None:
        args.max_depth = DEFAULT_MAX_DEPTH
    if args.film is None:
        args.film = "transparent" if scene.render.film_transparent else "opaque"
    configure_render(scene, args)
    return scene


def build_scene(args):
    if args.scene.lower().endswith(".blend"):
        return open_blend(args)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    gltf_path = os.path.abspath(args.scene)
    with open(gltf_path) as f:
        gltf = json.load(f)
    render = gltf.get("extensions", {}).get("BRUME_render", {})
    if args.max_depth is None:
        # As `brume render`: the scene's own depth unless the command line gives one.
        args.max_depth = int(render.get("maxDepth", DEFAULT_MAX_DEPTH))
    if args.film is None:
        args.film = "transparent" if render.get("filmTransparent", False) else "opaque"
    base_dir = os.path.dirname(gltf_path)
    fps = float(render.get("fps", 24.0))
    frame = int(render.get("frame", 1))
    scene = bpy.context.scene
    # Brume's frame f is time f / fps. The importer keys time t at frame t * fps * fps_base,
    # and Blender's frame rate is fps / fps_base: fps_base is fps / rate while importing, then
    # rate / fps (1 for a whole rate either way).
    whole = min(max(round(fps), 1), 32767)
    scene.render.fps = whole
    scene.render.fps_base = fps / whole
    bpy.ops.import_scene.gltf(
        filepath=gltf_path,
        export_import_convert_lighting_mode="COMPAT",
        import_shading="NORMALS",
    )
    scene = bpy.context.scene
    scene.render.fps_base = whole / fps
    play_all_animations(gltf)
    scene.frame_set(frame)  # everything below is placed as at Brume's frame

    # Lights: punctual means radius 0; Blender's defaults are soft.
    for obj in scene.objects:
        if obj.type != "LIGHT":
            continue
        light = obj.data
        light.shadow_soft_size = 0.0
        if hasattr(light, "use_soft_falloff"):
            light.use_soft_falloff = False
        if light.type == "SUN":
            light.angle = 0.0
        light.use_shadow = True

    # Spot lights: glTF's falloff (Brume's `spot_falloff`) is a^2 with a linear in the cosine
    # between the outer and inner cone; Cycles' own spot blend is a smoothstep (3a^2 - 2a^3),
    # brighter in the penumbra. So the Cycles spot gets a hard edge at the outer cone and a
    # light shader multiplies its emission by a^2, from the direction the light is sampled
    # in (the shading normal of a point-like light points from the light to the receiver).
    gltf_lights = gltf.get("extensions", {}).get("KHR_lights_punctual", {}).get("lights", [])
    spots = {l.get("name"): l for l in gltf_lights if l.get("type") == "spot"}
    for obj in scene.objects:
        native = os.environ.get("BRUME_CYCLES_NATIVE_SPOT") == "1"  # to show the difference
        if obj.type == "LIGHT" and obj.data.type == "SPOT" and obj.data.name in spots and not native:
            cone = spots[obj.data.name].get("spot", {})
            outer = cone.get("outerConeAngle", math.pi / 4)
            inner = cone.get("innerConeAngle", 0.0)
            spot_falloff_shader(obj, math.cos(inner), math.cos(outer))

    # Camera: glTF yfov is vertical and the render's aspect decides the width (as Brume).
    cams = gltf.get("cameras", [])
    cam_objs = [o for o in scene.objects if o.type == "CAMERA"]
    if cam_objs:
        gltf_cam_nodes = [n for n in gltf["nodes"] if "camera" in n]
        target = cam_objs[0]
        if gltf_cam_nodes:
            for o in cam_objs:
                if o.name == gltf_cam_nodes[0].get("name"):
                    target = o
        scene.camera = target
        if gltf_cam_nodes:
            persp = cams[gltf_cam_nodes[0]["camera"]].get("perspective", {})
            target.data.sensor_fit = "VERTICAL"
            target.data.angle_y = persp.get("yfov", math.radians(40))
            target.data.clip_start = persp.get("znear", 0.05)
            target.data.clip_end = persp.get("zfar", 1e6)
            target.data.shift_x = target.data.shift_y = 0.0
    else:
        sys.exit("error: the scene has no camera (Brume's automatic camera is not mirrored)")

    # Materials: rebuilt by name as Brume's model.
    by_name = {m.get("name"): m for m in gltf.get("materials", [])}
    for mat in bpy.data.materials:
        gm = by_name.get(mat.name)
        if gm is not None:
            build_surface_material(mat, gm, gltf, base_dir)

    # Media.
    worlds = world_matrices(gltf)
    moving = moving_nodes(gltf)
    for i, node in enumerate(gltf.get("nodes", [])):
        ext = node.get("extensions", {}).get("BRUME_medium_vdb")
        if ext is not None and i in worlds:
            parent = None
            if i in moving:
                parent = bpy.data.objects.get(node.get("name", ""))
                if parent is None:
                    sys.exit(
                        f"error: {args.scene}: /nodes/{i}: an animation moves this medium, but "
                        "the glTF importer's object for the node cannot be found by its name "
                        "(give the node a unique name)"
                    )
            build_medium(node.get("name", f"medium{i}"), ext, base_dir, worlds[i], frame, parent)

    # Environment.
    world = bpy.data.worlds.new("brume_environment")
    scene.world = world
    world.use_nodes = True
    env = gltf.get("extensions", {}).get("BRUME_environment")
    bg = world.node_tree.nodes.get("Background") or world.node_tree.nodes.new("ShaderNodeBackground")
    if env is not None:
        bg.inputs["Color"].default_value = list(env.get("color", [1, 1, 1])) + [1.0]
        bg.inputs["Strength"].default_value = env.get("strength", 1.0)
        if env.get("uri"):
            build_environment_map(world.node_tree, bg, env, base_dir)
    else:
        bg.inputs["Strength"].default_value = 0.0
    configure_render(scene, args)
    configure_motion(scene, args, render, frame)
    return scene


def main(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("scene")
    p.add_argument("-o", "--output", required=True)
    p.add_argument("--spp", type=int, default=64)
    p.add_argument("--width", type=int, default=320)
    p.add_argument("--height", type=int, default=240)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--runs", type=int, default=1)
    p.add_argument("--threads", type=int, default=0)
    p.add_argument(
        "--max-depth",
        type=int,
        default=None,
        help="Brume's depth (default: the glTF's BRUME_render maxDepth, else 256, as Brume)",
    )
    p.add_argument(
        "--film",
        choices=["opaque", "transparent"],
        default=None,
        help="Brume's film (default: the glTF's BRUME_render filmTransparent, else opaque)",
    )
    p.add_argument(
        "--passes",
        choices=["beauty", "light"],
        default="beauty",
        help="light: also write Cycles' light passes (a multilayer EXR)",
    )
    p.add_argument("--save-blend", help="also save the built scene as a .blend")
    p.add_argument("--no-render", action="store_true", help="build (and save) the scene only")
    args = p.parse_args(argv)
    t0 = time.time()
    scene = build_scene(args)
    print(f"build_seconds {time.time() - t0:.3f}", flush=True)
    if args.save_blend:
        bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(args.save_blend))
    if args.no_render:
        return
    out = os.path.abspath(args.output)
    for k in range(args.runs):
        scene.cycles.seed = args.seed + k
        path = out if args.runs == 1 else f"{os.path.splitext(out)[0]}.run{k}.exr"
        scene.render.filepath = path
        t = time.time()
        bpy.ops.render.render(write_still=True)
        print(f"render_seconds {k} {time.time() - t:.3f} {path}", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:] if "--" not in sys.argv else sys.argv[sys.argv.index("--") + 1 :])
