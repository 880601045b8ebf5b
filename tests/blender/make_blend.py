"""Builds the .blend files of tests/external/blender_roundtrip.rs with bpy (as a user would in Blender).

    python make_blend.py KIND out.blend --vdb-dir scenes/vdb [--seq-dir DIR]

KIND:
- `fire`: a Volume object reading fire.vdb, parented to a rotated and scaled empty, itself
  rotated and non-uniformly scaled, render space Object (Blender's default); a Principled Volume
  with density, colour, absorption, anisotropy, emission from the `flame` grid through a Math
  node, blackbody from the `temperature` grid through a Map Range node; a sun, a point light, a
  camera, a ground plane and a constant world. Lights are punctual (radius and angle 0) and the
  ground is a rough metal with single-scattering GGX: the one Principled BSDF set-up whose
  Cycles rendering is Brume's surface model exactly, so the comparison tests the volume.
- `sequence`: a Volume object on a VDB sequence (copies of example files named
  seq_0001.vdb .. seq_0003.vdb in --seq-dir) starting at frame 11, the scene's frames 12..13,
  saved at frame 12, and a World lit by an
  equirectangular map (sky.exr in --seq-dir) rotated by a Mapping node; a Noise Texture drives
  the Principled Volume's colour (a warning: the socket's own colour is exported).
- `sequence_extend`: the same sequence in mode Extend under frames 12..20, past its end.
- `motion`: a plume with a velocity grid under a keyed empty, a keyed camera aimed by a Track
  To constraint at a keyed target, 29.97 fps, motion blur on (`--position`).
- `procedural`: a Volume object with no file (what geometry nodes produce).
- `phases`: Volume objects on cloud.vdb whose materials scatter through Volume Scatter nodes
  (PHASE_VOLUMES: alone or added to a Principled Volume that only absorbs, each phase Brume
  renders, two Henyey-Greenstein nodes as a two-lobe phase), render space World; the phase
  objects and coefficients expected are written to the .blend's name with .json.
- `phase_refused`: one Volume object with a set-up the add-on refuses (`--case`, one of
  REFUSED_PHASES).
"""
import argparse
import json
import math
import os
import shutil
import struct
import sys

import bpy
from mathutils import Euler, Matrix


def principled(mat):
    nt = mat.node_tree
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    pv = nt.nodes.new("ShaderNodeVolumePrincipled")
    nt.links.new(pv.outputs[0], out.inputs["Volume"])
    return nt, pv


def volume_object(name, filepath):
    vol = bpy.data.volumes.new(name)
    vol.filepath = filepath
    obj = bpy.data.objects.new(name, vol)
    bpy.context.scene.collection.objects.link(obj)
    mat = bpy.data.materials.new(name + "_material")
    mat.use_nodes = True
    vol.materials.append(mat)
    return obj, mat


def fire_scene(vdb_dir):
    scene = bpy.context.scene
    rig = bpy.data.objects.new("rig", None)
    scene.collection.objects.link(rig)
    rig.location = (0.15, -0.1, 1.25)
    rig.rotation_euler = Euler((0.0, 0.0, math.radians(30.0)))
    rig.scale = (1.2, 1.2, 1.2)

    obj, mat = volume_object("fire", os.path.join(vdb_dir, "fire.vdb"))
    obj.parent = rig
    obj.location = (0.05, 0.0, 0.02)
    obj.rotation_euler = Euler((math.radians(90.0), math.radians(10.0), math.radians(-20.0)))
    obj.scale = (0.7, 0.8, 0.75)
    vol = obj.data
    assert vol.render.space == "OBJECT"  # Blender's default, on purpose
    vol.render.precision = "FULL"  # Cycles' default HALF quantises the grid; Brume reads floats
    vol.render.clipping = 0.0
    mat.cycles.volume_interpolation = "LINEAR"

    nt, pv = principled(mat)
    pv.inputs["Density"].default_value = 2.5
    pv.inputs["Density Attribute"].default_value = "density"
    pv.inputs["Color"].default_value = (0.7, 0.6, 0.5, 1.0)
    pv.inputs["Absorption Color"].default_value = (0.2, 0.3, 0.1, 1.0)
    pv.inputs["Anisotropy"].default_value = 0.3
    flame = nt.nodes.new("ShaderNodeAttribute")
    flame.attribute_name = "flame"
    mul = nt.nodes.new("ShaderNodeMath")
    mul.operation = "MULTIPLY"
    mul.inputs[0].default_value = 3.0
    nt.links.new(flame.outputs["Fac"], mul.inputs[1])
    nt.links.new(mul.outputs[0], pv.inputs["Emission Strength"])
    pv.inputs["Emission Color"].default_value = (1.0, 0.5, 0.2, 1.0)
    pv.inputs["Blackbody Intensity"].default_value = 0.8
    pv.inputs["Blackbody Tint"].default_value = (1.0, 0.9, 0.8, 1.0)
    temp = nt.nodes.new("ShaderNodeAttribute")
    temp.attribute_name = "temperature"
    rng = nt.nodes.new("ShaderNodeMapRange")
    rng.clamp = False
    rng.inputs["From Min"].default_value = 0.0
    rng.inputs["From Max"].default_value = 1.0
    rng.inputs["To Min"].default_value = 0.0
    rng.inputs["To Max"].default_value = 1400.0
    nt.links.new(temp.outputs["Fac"], rng.inputs["Value"])
    nt.links.new(rng.outputs["Result"], pv.inputs["Temperature"])
    pv.inputs["Temperature Attribute"].default_value = ""  # else Cycles multiplies by the grid again

    sun = bpy.data.lights.new("sun", "SUN")
    sun.energy = 2.0
    sun.angle = 0.0
    sun_obj = bpy.data.objects.new("sun", sun)
    scene.collection.objects.link(sun_obj)
    sun_obj.rotation_euler = Euler((math.radians(40.0), math.radians(15.0), math.radians(30.0)))
    lamp = bpy.data.lights.new("lamp", "POINT")
    lamp.energy = 300.0
    lamp.shadow_soft_size = 0.0
    lamp.color = (0.8, 0.9, 1.0)
    lamp_obj = bpy.data.objects.new("lamp", lamp)
    scene.collection.objects.link(lamp_obj)
    lamp_obj.location = (-2.5, -2.0, 3.0)

    mesh = bpy.data.meshes.new("ground")
    s = 6.0
    mesh.from_pydata([(-s, -s, 0), (s, -s, 0), (s, s, 0), (-s, s, 0)], [], [(0, 1, 2, 3)])
    ground = bpy.data.objects.new("ground", mesh)
    scene.collection.objects.link(ground)
    gm = bpy.data.materials.new("ground")
    gm.use_nodes = True
    bsdf = gm.node_tree.nodes["Principled BSDF"]
    bsdf.distribution = "GGX"
    bsdf.inputs["Base Color"].default_value = (0.5, 0.5, 0.5, 1.0)
    bsdf.inputs["Metallic"].default_value = 1.0
    bsdf.inputs["Roughness"].default_value = 1.0
    mesh.materials.append(gm)

    cam = bpy.data.cameras.new("camera")
    cam.lens = 35.0
    cam_obj = bpy.data.objects.new("camera", cam)
    scene.collection.objects.link(cam_obj)
    cam_obj.matrix_world = Matrix.LocRotScale(
        (0.0, -7.0, 1.6), Euler((math.radians(86.0), 0.0, 0.0)), None
    )
    scene.camera = cam_obj

    world = bpy.data.worlds.new("world")
    world.use_nodes = True
    bg = world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.4, 0.5, 0.6, 1.0)
    bg.inputs["Strength"].default_value = 0.05
    scene.world = world
    scene.render.resolution_x = 32
    scene.render.resolution_y = 24
    scene.render.resolution_percentage = 100
    scene.cycles.samples = 64


def sequence_scene(vdb_dir, seq_dir, extend=False):
    os.makedirs(seq_dir, exist_ok=True)
    for k, src in enumerate(["cloud.vdb", "smoke.vdb", "plume.vdb"], start=1):
        shutil.copyfile(os.path.join(vdb_dir, src), os.path.join(seq_dir, f"seq_{k:04d}.vdb"))
    obj, mat = volume_object("sequence", os.path.join(seq_dir, "seq_0001.vdb"))
    vol = obj.data
    vol.is_sequence = True
    vol.frame_start = 11  # file k at frame 10 + k: frameOffset -10
    vol.frame_duration = 3
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 12, 13
    if extend:
        # Past the sequence's frames 11..13 Extend holds seq_0003.vdb: no frameOffset says that.
        vol.sequence_mode = "EXTEND"
        scene.frame_end = 20
    nt, pv = principled(mat)
    pv.inputs["Density"].default_value = 1.5
    # A texture on the colour, which Brume cannot express: a warning, not a refusal.
    noise = nt.nodes.new("ShaderNodeTexNoise")
    nt.links.new(noise.outputs["Color"], pv.inputs["Color"])
    scene.frame_set(12)
    # An equirectangular map through Texture Coordinate.Generated -> Mapping (rotation).
    sky = bpy.data.images.new("sky", 8, 4, float_buffer=True)
    sky.filepath_raw = os.path.join(seq_dir, "sky.exr")
    sky.file_format = "OPEN_EXR"
    sky.save()
    world = bpy.data.worlds.new("world")
    world.use_nodes = True
    nt = world.node_tree
    tex = nt.nodes.new("ShaderNodeTexEnvironment")
    tex.image = sky
    mapping = nt.nodes.new("ShaderNodeMapping")
    mapping.inputs["Rotation"].default_value = (0.1, 0.2, 0.3)
    coords = nt.nodes.new("ShaderNodeTexCoord")
    nt.links.new(coords.outputs["Generated"], mapping.inputs["Vector"])
    nt.links.new(mapping.outputs["Vector"], tex.inputs["Vector"])
    nt.links.new(tex.outputs["Color"], nt.nodes["Background"].inputs["Color"])
    nt.nodes["Background"].inputs["Strength"].default_value = 0.7
    bpy.context.scene.world = world


def motion_scene(vdb_dir, position):
    """A moving shot: 29.97 fps (fps 30, base 1.001), frames 1..12, saved at frame 5, motion
    blur on (shutter 0.5 frames, at `position`: CENTER, START, END, or OFF for no blur). The plume (plume_vel.vdb, with its staggered
    `velocity` grid per second, Velocity Scale 8) hangs under an empty whose location and
    rotation are keyed (Bezier); the camera's location is keyed and a Track To constraint aims
    it at a keyed target, which only a baked (Scene mode) export reproduces."""
    scene = bpy.context.scene
    scene.render.fps = 30
    scene.render.fps_base = 1.001
    scene.frame_start, scene.frame_end = 1, 12
    scene.render.use_motion_blur = position != "OFF"
    scene.render.motion_blur_shutter = 0.5
    if position != "OFF":
        scene.render.motion_blur_position = position

    rig = bpy.data.objects.new("rig", None)
    scene.collection.objects.link(rig)
    for frame, loc, angle in ((1, (0.0, 0.0, 1.0), 0.0), (12, (0.8, 0.3, 1.4), 40.0)):
        rig.location = loc
        rig.rotation_euler = Euler((0.0, 0.0, math.radians(angle)))
        rig.keyframe_insert("location", frame=frame)
        rig.keyframe_insert("rotation_euler", frame=frame)
    obj, mat = volume_object("plume", os.path.join(vdb_dir, "plume_vel.vdb"))
    obj.parent = rig
    obj.location = (0.1, 0.0, 0.2)
    obj.scale = (0.8, 0.8, 0.8)
    vol = obj.data
    vol.render.space = "WORLD"
    vol.render.precision = "FULL"
    vol.render.clipping = 0.0
    vol.grids.load()  # Blender checks the name against the file's grids
    vol.velocity_grid = "velocity"
    vol.velocity_unit = "SECOND"
    vol.velocity_scale = 8.0
    nt, pv = principled(mat)
    pv.inputs["Density"].default_value = 20.0
    pv.inputs["Color"].default_value = (0.9, 0.9, 0.9, 1.0)

    target = bpy.data.objects.new("target", None)
    scene.collection.objects.link(target)
    for frame, loc in ((1, (0.0, 0.0, 1.0)), (12, (0.5, 0.5, 1.5))):
        target.location = loc
        target.keyframe_insert("location", frame=frame)
    cam = bpy.data.cameras.new("camera")
    cam.lens = 40.0
    cam_obj = bpy.data.objects.new("camera", cam)
    scene.collection.objects.link(cam_obj)
    for frame, loc in ((1, (0.0, -8.0, 1.5)), (12, (2.0, -7.0, 2.5))):
        cam_obj.location = loc
        cam_obj.keyframe_insert("location", frame=frame)
    track = cam_obj.constraints.new("TRACK_TO")
    track.target = target
    track.track_axis = "TRACK_NEGATIVE_Z"
    track.up_axis = "UP_Y"
    scene.camera = cam_obj
    sun = bpy.data.lights.new("sun", "SUN")
    sun.energy = 3.0
    sun.angle = 0.0
    sun_obj = bpy.data.objects.new("sun", sun)
    scene.collection.objects.link(sun_obj)
    sun_obj.rotation_euler = Euler((math.radians(40.0), math.radians(15.0), math.radians(30.0)))
    scene.frame_set(5)


def scatter(nt, phase, color, density, **sockets):
    """A Volume Scatter node of `phase` scattering `color` * `density` * the density grid."""
    sc = nt.nodes.new("ShaderNodeVolumeScatter")
    sc.phase = phase
    sc.inputs["Color"].default_value = tuple(color) + (1.0,)
    attr = nt.nodes.new("ShaderNodeAttribute")
    attr.attribute_name = "density"
    mul = nt.nodes.new("ShaderNodeMath")
    mul.operation = "MULTIPLY"
    mul.inputs[1].default_value = density
    nt.links.new(attr.outputs["Fac"], mul.inputs[0])
    nt.links.new(mul.outputs[0], sc.inputs["Density"])
    for name, value in sockets.items():
        sc.inputs[name].default_value = value
    return sc


def summed(nt, shaders):
    """`shaders` summed by Add Shader nodes into the material's Volume output."""
    acc = shaders[0].outputs[0]
    for sh in shaders[1:]:
        add = nt.nodes.new("ShaderNodeAddShader")
        nt.links.new(acc, add.inputs[0])
        nt.links.new(sh.outputs[0], add.inputs[1])
        acc = add.outputs[0]
    nt.links.new(acc, nt.nodes["Material Output"].inputs["Volume"])


# name: (Principled Volume Density and Absorption Color or None, [(phase, colour, density,
# sockets)]).
PHASE_VOLUMES = {
    "hg_alone": (None, [("HENYEY_GREENSTEIN", (0.8, 0.7, 0.6), 3.0, {"Anisotropy": 0.4})]),
    "draine_pv": ((3.0, (0.5, 0.6, 0.7)), [("DRAINE", (0.9, 0.9, 0.9), 3.0, {"Anisotropy": 0.6, "Alpha": 1.5})]),
    "mie_alone": (None, [("MIE", (1.0, 1.0, 1.0), 2.0, {"Diameter": 15.0})]),
    "rayleigh_pv": ((4.0, (0.9, 0.8, 0.95)), [("RAYLEIGH", (0.5, 0.6, 0.7), 4.0, {})]),
    "two_lobe_pv": ((2.0, (0.7, 0.7, 0.7)), [
        ("HENYEY_GREENSTEIN", (0.54, 0.48, 0.42), 2.0, {"Anisotropy": 0.8}),
        ("HENYEY_GREENSTEIN", (0.36, 0.32, 0.28), 2.0, {"Anisotropy": -0.3}),
    ]),
}


def phase_volume(vdb_dir, name, principled_part, lobes):
    obj, mat = volume_object(name, os.path.join(vdb_dir, "cloud.vdb"))
    obj.data.render.space = "WORLD"
    nt = mat.node_tree
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    nt.nodes.new("ShaderNodeOutputMaterial")
    shaders = []
    if principled_part is not None:
        pv = nt.nodes.new("ShaderNodeVolumePrincipled")
        pv.inputs["Density"].default_value = principled_part[0]
        pv.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
        pv.inputs["Absorption Color"].default_value = tuple(principled_part[1]) + (1.0,)
        shaders.append(pv)
    shaders += [scatter(nt, phase, c, d, **sockets) for phase, c, d, sockets in lobes]
    summed(nt, shaders)
    return obj, mat, shaders


def expected_phase(lobes):
    """The `phase` object Brume's add-on should export for `lobes`, and sigma_s per unit of
    the density grid (Cycles: colour times density, summed)."""
    f32 = lambda x: struct.unpack("f", struct.pack("f", x))[0]
    s = [sum(f32(c[k]) * f32(d) for _, c, d, _ in lobes) for k in range(3)]
    if len(lobes) == 2:
        (_, c1, d1, s1), (_, c2, d2, s2) = lobes
        w = f32(c1[0]) * d1 / (f32(c1[0]) * d1 + f32(c2[0]) * d2)
        return {"type": "two-lobe", "g1": f32(s1["Anisotropy"]), "g2": f32(s2["Anisotropy"]), "weight": w}, s
    phase, _, _, sockets = lobes[0]
    kind = {"HENYEY_GREENSTEIN": "henyey-greenstein", "DRAINE": "draine", "MIE": "mie", "RAYLEIGH": "rayleigh"}[phase]
    keys = {"Anisotropy": "g", "Alpha": "alpha", "Diameter": "diameter"}
    return dict({"type": kind}, **{keys[k]: f32(v) for k, v in sockets.items()}), s


def phases_scene(vdb_dir, out):
    """The volumes of PHASE_VOLUMES; writes `out`.json beside the .blend: for each, the phase
    object expected and the coefficients per unit of density grid, as Cycles renders them
    (sigma_a: the Principled Volume's, `(1 - sqrt(absorptionColor)) * density` with its colour
    black)."""
    expect = {}
    for name, (principled_part, lobes) in PHASE_VOLUMES.items():
        phase_volume(vdb_dir, name, principled_part, lobes)
        phase, sigma_s = expected_phase(lobes)
        sigma_a = [0.0] * 3
        if principled_part is not None:
            d, ac = principled_part
            sigma_a = [(1.0 - math.sqrt(c)) * d for c in ac]
        expect[name] = {"phase": phase, "sigma_s": sigma_s, "sigma_a": sigma_a}
    with open(os.path.splitext(out)[0] + ".json", "w") as f:
        json.dump(expect, f, indent=1)


# What the add-on refuses, by --case.
REFUSED_PHASES = ["fournier_forand", "grid_anisotropy", "scattering_principled", "mix_shader"]


def phase_refused_scene(vdb_dir, case):
    if case == "fournier_forand":
        phase_volume(vdb_dir, case, None, [("FOURNIER_FORAND", (0.8, 0.8, 0.8), 3.0, {})])
    elif case == "grid_anisotropy":
        _, mat, (sc,) = phase_volume(vdb_dir, case, None, [("HENYEY_GREENSTEIN", (0.8, 0.8, 0.8), 3.0, {})])
        attr = mat.node_tree.nodes.new("ShaderNodeAttribute")
        attr.attribute_name = "density"
        mat.node_tree.links.new(attr.outputs["Fac"], sc.inputs["Anisotropy"])
    elif case == "scattering_principled":
        _, _, (pv, _) = phase_volume(vdb_dir, case, (3.0, (1.0, 1.0, 1.0)), [("RAYLEIGH", (0.8, 0.8, 0.8), 3.0, {})])
        pv.inputs["Color"].default_value = (0.5, 0.5, 0.5, 1.0)
    else:
        _, mat, (a, b) = phase_volume(vdb_dir, case, None, [
            ("RAYLEIGH", (0.8, 0.8, 0.8), 3.0, {}), ("MIE", (0.8, 0.8, 0.8), 3.0, {"Diameter": 10.0})])
        nt = mat.node_tree
        mix = nt.nodes.new("ShaderNodeMixShader")
        nt.links.new(a.outputs[0], mix.inputs[1])
        nt.links.new(b.outputs[0], mix.inputs[2])
        nt.links.new(mix.outputs[0], nt.nodes["Material Output"].inputs["Volume"])


def procedural_scene():
    """A Volume object whose grids come from geometry nodes (a Volume Cube), no file."""
    obj, mat = volume_object("procedural", "")
    principled(mat)
    ng = bpy.data.node_groups.new("cube", "GeometryNodeTree")
    ng.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    out = ng.nodes.new("NodeGroupOutput")
    cube = ng.nodes.new("GeometryNodeVolumeCube")
    ng.links.new(cube.outputs["Volume"], out.inputs[0])
    mod = obj.modifiers.new("cube", "NODES")
    mod.node_group = ng


def main(argv):
    p = argparse.ArgumentParser()
    p.add_argument("kind", choices=["fire", "sequence", "sequence_extend", "motion", "procedural", "phases", "phase_refused"])
    p.add_argument("out")
    p.add_argument("--vdb-dir", required=True)
    p.add_argument("--seq-dir")
    p.add_argument("--position", default="CENTER", choices=["CENTER", "START", "END", "OFF"],
                   help="motion: the shutter's position on the frame, or OFF (no motion blur)")
    p.add_argument("--case", choices=REFUSED_PHASES, help="phase_refused: the set-up refused")
    args = p.parse_args(argv)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    vdb_dir = os.path.abspath(args.vdb_dir)
    if args.kind == "fire":
        fire_scene(vdb_dir)
    elif args.kind in ("sequence", "sequence_extend"):
        sequence_scene(vdb_dir, os.path.abspath(args.seq_dir), extend=args.kind == "sequence_extend")
    elif args.kind == "motion":
        motion_scene(vdb_dir, args.position)
    elif args.kind == "phases":
        phases_scene(vdb_dir, os.path.abspath(args.out))
    elif args.kind == "phase_refused":
        phase_refused_scene(vdb_dir, args.case)
    else:
        procedural_scene()
    bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(args.out))


if __name__ == "__main__":
    main(sys.argv[1:])
