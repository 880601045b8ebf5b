"""Bakes a small Mantaflow smoke (or fire) simulation headless and saves a .blend that renders
its last frame as a Volume object with velocity motion blur (tests/external/cycles_blur.rs compares
Cycles' render of it with Brume's render of its export).

    python mantaflow_smoke.py OUT_DIR [--resolution 24] [--frames 16] [--velocity-scale 2]
        [--push X,Y,Z] [--fire]

- the bake: a gas domain (a 2 m cube, `--resolution` cells along it) with a smoke inflow
  sphere whose smoke rises by buoyancy (`--push` gives it an initial velocity as well),
  OpenVDB cache (`cache_type` All), frames 1 .. `--frames`, written to
  OUT_DIR/cache/data/fluid_data_####.vdb: each file holds `density` and Mantaflow's own
  `velocity` (staggered, half float, world units per second);
- OUT_DIR/smoke.blend: a Volume object reading that cache as a VDB sequence (frames 1 ..
  `--frames`) where the domain stood, velocity grid `velocity` per second at
  `--velocity-scale`, render space World, full precision, no clipping, a Principled Volume;
  motion blur on (shutter 0.5 frames, centred on the frame), 24 fps, the scene at the last
  frame; a camera, a sun and a dim constant world; 32 x 24 pixels. The simulation itself is
  removed from the .blend: only the cache is rendered.
- `--fire`: the inflow sphere, at the bottom of the domain, emits fuel that burns (flow type
  Fire + Smoke), so each file also holds `flame` and `temperature` (Mantaflow's heat, about
  0..3); only the cache is written (tests/external/cycles_compare.rs builds a glTF over it).

Blender as a Python module (bpy 5.0.1) registers Mantaflow's Python classes before their base
classes are linked, so its solver script fails at once ('LevelsetGrid' object has no attribute
'setConst'); `relink_mantaflow` creates one domain, which links them, and builds the `manta`
module again from the linked classes. The process then leaves with os._exit: Mantaflow's
cleanup of that first, failed solver aborts at interpreter exit.
"""
import argparse
import ctypes
import importlib.util
import math
import os
import sys
import time

import bpy
from mathutils import Euler


def relink_mantaflow():
    """Rebuilds the `manta` module once Mantaflow's class registry has linked base classes."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_cube_add()
    obj = bpy.context.active_object
    mod = obj.modifiers.new("fluid", "FLUID")
    mod.fluid_type = "DOMAIN"  # Pb::setup: registers the base classes, then the script fails
    bpy.context.view_layer.update()
    lib = ctypes.PyDLL(importlib.util.find_spec("bpy").origin)
    init = lib.PyInit_manta_main
    init.restype = ctypes.py_object
    sys.modules["manta"] = init()
    obj.modifiers.remove(mod)
    bpy.data.objects.remove(obj)


def bake(cache, resolution, frames, push, fire=False):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_cube_add(size=2.0, location=(0.0, 0.0, 1.0))
    domain = bpy.context.active_object
    domain.name = "domain"
    settings = domain.modifiers.new("fluid", "FLUID")
    settings.fluid_type = "DOMAIN"
    d = settings.domain_settings
    d.domain_type = "GAS"
    d.resolution_max = resolution
    d.cache_type = "ALL"
    d.cache_data_format = "OPENVDB"
    d.cache_directory = cache
    d.cache_frame_start = 1
    d.cache_frame_end = frames
    where = (0.0, 0.0, 0.3) if fire else (-0.4, 0.0, 0.4)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.25, location=where)
    source = bpy.context.active_object
    flow = source.modifiers.new("fluid", "FLUID")
    flow.fluid_type = "FLOW"
    f = flow.flow_settings
    f.flow_type = "BOTH" if fire else "SMOKE"
    f.flow_behavior = "INFLOW"
    f.use_initial_velocity = any(push)
    f.velocity_coord = push
    t = time.time()
    with bpy.context.temp_override(active_object=domain, object=domain, scene=scene):
        result = bpy.ops.fluid.bake_all()
    if result != {"FINISHED"}:
        sys.exit(f"error: {cache}: the Mantaflow bake did not finish ({result})")
    print(f"bake_seconds {time.time() - t:.2f}", flush=True)
    return domain.matrix_world.to_translation() - domain.dimensions / 2.0


def render_scene(out_dir, cache, frames, corner, velocity_scale):
    """The .blend that renders the cache's last frame (the simulation objects are removed)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    first = os.path.join(cache, "data", "fluid_data_0001.vdb")
    if not os.path.isfile(first):
        sys.exit(f"error: {first}: the bake wrote no OpenVDB cache")
    last = os.path.join(cache, "data", f"fluid_data_{frames:04d}.vdb")
    probe = bpy.data.volumes.new("probe")
    probe.filepath = last
    probe.grids.load()
    names = {g.name: g.data_type for g in probe.grids}
    bpy.data.volumes.remove(probe)
    if names.get("velocity") != "VECTOR_FLOAT" or "density" not in names:
        sys.exit(f"error: {last}: expected grids density and velocity (vector), found {names}")
    vol = bpy.data.volumes.new("smoke")
    vol.filepath = first
    vol.is_sequence = True
    vol.frame_start = 1
    vol.frame_duration = frames
    vol.sequence_mode = "CLIP"
    scene.frame_start, scene.frame_end = 1, frames
    scene.frame_set(frames)
    vol.velocity_grid = "velocity"
    vol.velocity_unit = "SECOND"
    vol.velocity_scale = velocity_scale
    vol.render.space = "WORLD"
    vol.render.precision = "FULL"
    vol.render.clipping = 0.0
    obj = bpy.data.objects.new("smoke", vol)
    scene.collection.objects.link(obj)
    obj.location = corner  # the cache's grids start at the domain's lower corner
    mat = bpy.data.materials.new("smoke")
    mat.use_nodes = True
    nt = mat.node_tree
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    pv = nt.nodes.new("ShaderNodeVolumePrincipled")
    nt.links.new(pv.outputs[0], out.inputs["Volume"])
    pv.inputs["Density"].default_value = 8.0
    pv.inputs["Density Attribute"].default_value = "density"
    pv.inputs["Color"].default_value = (0.9, 0.9, 0.9, 1.0)
    mat.cycles.volume_interpolation = "LINEAR"
    vol.materials.append(mat)

    sun = bpy.data.lights.new("sun", "SUN")
    sun.energy = 3.0
    sun.angle = 0.0
    sun_obj = bpy.data.objects.new("sun", sun)
    scene.collection.objects.link(sun_obj)
    sun_obj.rotation_euler = Euler((math.radians(40.0), math.radians(15.0), math.radians(30.0)))
    cam = bpy.data.cameras.new("camera")
    cam.lens = 50.0
    cam_obj = bpy.data.objects.new("camera", cam)
    scene.collection.objects.link(cam_obj)
    cam_obj.location = (0.0, -4.5, 1.0)
    cam_obj.rotation_euler = Euler((math.radians(90.0), 0.0, 0.0))
    scene.camera = cam_obj
    world = bpy.data.worlds.new("world")
    world.use_nodes = True
    bg = world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.4, 0.5, 0.6, 1.0)
    bg.inputs["Strength"].default_value = 0.05
    scene.world = world

    r = scene.render
    r.fps, r.fps_base = 24, 1.0
    r.use_motion_blur = True
    r.motion_blur_shutter = 0.5
    r.motion_blur_position = "CENTER"
    r.resolution_x, r.resolution_y, r.resolution_percentage = 32, 24, 100
    scene.cycles.samples = 64
    path = os.path.join(out_dir, "smoke.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    print(f"saved {path} (frame {scene.frame_current}, velocity scale {velocity_scale})", flush=True)


def main(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("out_dir")
    p.add_argument("--resolution", type=int, default=24)
    p.add_argument("--frames", type=int, default=16)
    p.add_argument("--velocity-scale", type=float, default=2.0)
    p.add_argument("--push", default="0,0,0", help="the inflow's initial velocity x,y,z (m/s)")
    p.add_argument("--fire", action="store_true", help="a burning inflow; the cache only")
    args = p.parse_args(argv)
    out_dir = os.path.abspath(args.out_dir)
    os.makedirs(out_dir, exist_ok=True)
    cache = os.path.join(out_dir, "cache")
    relink_mantaflow()
    push = tuple(float(c) for c in args.push.split(","))
    corner = bake(cache, args.resolution, args.frames, push, args.fire)
    if not args.fire:
        render_scene(out_dir, cache, args.frames, corner, args.velocity_scale)


if __name__ == "__main__":
    code = 0
    try:
        main(sys.argv[1:] if "--" not in sys.argv else sys.argv[sys.argv.index("--") + 1 :])
    except SystemExit as e:
        if isinstance(e.code, str):
            print(e.code, file=sys.stderr)
            code = 1
        else:
            code = e.code or 0
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)
