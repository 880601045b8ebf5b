"""The scene's World as `BRUME_environment` and its render settings as `BRUME_render`.

`BRUME_environment`: {"color": [r, g, b], "strength": s, "uri": "map.exr", "rotation": [rx, ry, rz]}
- constant radiance color * strength from the World's Background node (or the world colour when
  the World uses no nodes); a colour above 1 is moved into the strength (Brume's colours lie in
  [0, 1]);
- an equirectangular Environment Texture feeding the Background colour gives `uri` (the image
  file, relative to the glTF or copied beside it) with color [1, 1, 1], as Cycles replaces the
  colour by the texture;
- a Mapping node between Texture Coordinate.Generated and the texture gives `rotation`: its
  Euler XYZ rotation in radians, in Blender's Z-up world axes, as a Point mapping (a Texture
  mapping's inverse rotation is converted); location and scale are not expressible.
"""
import os

import bpy
from mathutils import Euler

from .nodes import Unsupported, affine, describe, source


def _strength(bg, warnings):
    try:
        a = affine(bg.inputs["Strength"])
    except Unsupported as e:
        warnings.append(f"world: Background 'Strength' is driven ({e}); its own value is used")
        return float(bg.inputs["Strength"].default_value)
    if a.grid is not None:
        warnings.append("world: Background 'Strength' reads an attribute; its own value is used")
        return float(bg.inputs["Strength"].default_value)
    return a.offset


def _texture(tex, warnings):
    """(image path, rotation) of an Environment Texture, or None with a warning."""
    if tex.projection != "EQUIRECTANGULAR":
        warnings.append(f"world: {describe(tex)} uses projection {tex.projection}; Brume reads equirectangular maps only; map ignored")
        return None
    img = tex.image
    if img is None:
        warnings.append(f"world: {describe(tex)} has no image; map ignored")
        return None
    if img.packed_file is not None or img.source != "FILE":
        warnings.append(f"world: image '{img.name}' is packed or not a single file; unpack it to export the map; map ignored")
        return None
    path = bpy.path.abspath(img.filepath, library=img.library)
    if not os.path.isfile(path):
        warnings.append(f"world: image file {path} does not exist; map ignored")
        return None
    if not path.lower().endswith(".exr"):
        warnings.append(f"world: {path} is not an OpenEXR file, which Brume expects for environment maps")
    rotation = [0.0, 0.0, 0.0]
    vec = source(tex.inputs["Vector"])
    if vec is None:
        return path, rotation
    node = vec.node
    if node.bl_idname == "ShaderNodeTexCoord" and vec.name == "Generated":
        return path, rotation
    if node.bl_idname != "ShaderNodeMapping":
        warnings.append(f"world: the map's Vector comes from {describe(node)}; only Texture Coordinate.Generated through a Mapping node is read; default mapping used")
        return path, rotation
    src = source(node.inputs["Vector"])
    if src is None or src.node.bl_idname != "ShaderNodeTexCoord" or src.name != "Generated":
        warnings.append(f"world: {describe(node)} is not fed by Texture Coordinate.Generated; default mapping used")
        return path, rotation
    for name, neutral in (("Location", 0.0), ("Scale", 1.0)):
        sock = node.inputs[name]
        if source(sock) is not None or any(abs(v - neutral) > 1e-9 for v in sock.default_value):
            warnings.append(f"world: {describe(node)} '{name}' is ignored (Brume reads the rotation only)")
    rot = node.inputs["Rotation"]
    if source(rot) is not None:
        warnings.append(f"world: {describe(node)} 'Rotation' is linked; zero rotation used")
        return path, rotation
    euler = Euler(rot.default_value, "XYZ")
    if node.vector_type == "TEXTURE":
        # Texture mapping applies the inverse transform: the same lookup as a Point mapping
        # by the inverse rotation.
        euler = euler.to_matrix().inverted().to_euler("XYZ")
    # Point, Vector and Normal rotate a direction alike (no location, unit scale).
    return path, [float(v) for v in euler]


def environment_fields(world):
    """(fields, image path or None, warnings); fields None when the scene has no World."""
    warnings = []
    if world is None:
        return None, None, warnings
    tree = world.node_tree if world.use_nodes else None
    if tree is None:
        return {"color": [float(c) for c in world.color[:3]], "strength": 1.0}, None, warnings
    out = tree.get_output_node("CYCLES")
    surf = source(out.inputs["Surface"]) if out is not None else None
    if surf is None:
        return {"color": [0.0, 0.0, 0.0], "strength": 0.0}, None, warnings
    bg = surf.node
    if bg.bl_idname != "ShaderNodeBackground":
        warnings.append(f"world: the World Output's Surface comes from {describe(bg)}; Brume reads a Background node; environment left black")
        return {"color": [0.0, 0.0, 0.0], "strength": 0.0}, None, warnings
    strength = _strength(bg, warnings)
    image = None
    col = source(bg.inputs["Color"])
    fields = {}
    if col is None:
        color = [float(c) for c in bg.inputs["Color"].default_value[:3]]
    elif col.node.bl_idname == "ShaderNodeTexEnvironment" and col.name == "Color":
        color = [1.0, 1.0, 1.0]
        got = _texture(col.node, warnings)
        if got is None:
            color = [float(c) for c in bg.inputs["Color"].default_value[:3]]
        else:
            image, rotation = got
            if any(rotation):
                fields["rotation"] = rotation
    else:
        warnings.append(f"world: the Background colour comes from {describe(col.node)}; Brume reads a constant or an Environment Texture; the socket's own colour is used")
        color = [float(c) for c in bg.inputs["Color"].default_value[:3]]
    peak = max(color)
    if peak > 1.0:
        color = [c / peak for c in color]
        strength *= peak
    color = [max(c, 0.0) for c in color]
    fields["color"] = color
    fields["strength"] = max(strength, 0.0)
    return fields, image, warnings


def render_fields(scene, frame):
    """`BRUME_render`: the output resolution, the Cycles sample count, the frame (`frame`, the
    scene's frame when the export started), the frame rate, the shot's frame range, a
    transparent film (Film > Transparent) and, with motion blur on, the shutter. Returns
    (fields, warnings)."""
    warnings = []
    r = scene.render
    fields = {
        "width": max(1, r.resolution_x * r.resolution_percentage // 100),
        "height": max(1, r.resolution_y * r.resolution_percentage // 100),
    }
    cycles = getattr(scene, "cycles", None)
    if cycles is not None:
        fields["spp"] = int(cycles.samples)
    fields["frame"] = int(frame)
    fields["fps"] = r.fps / r.fps_base
    fields["frameRange"] = [int(scene.frame_start), int(scene.frame_end)]
    if r.film_transparent:
        fields["filmTransparent"] = True
    if r.use_motion_blur:
        fields["shutter"], notes = shutter(scene)
        warnings.extend(notes)
    return fields, warnings


def shutter(scene):
    """Blender's shutter in frames around the frame: `motion_blur_shutter` long, centred on the
    frame (Center on Frame), starting on it (Start on Frame) or ending on it (End on Frame).
    Returns ({"open", "close"}, warnings)."""
    r = scene.render
    length = float(r.motion_blur_shutter)
    position = r.motion_blur_position
    open_ = {"START": 0.0, "END": -length}.get(position, -0.5 * length)
    warnings = []
    curve = r.motion_blur_shutter_curve.curves[0].points
    heights = [p.location[1] for p in curve]
    if max(heights) - min(heights) > 1e-6:
        warnings.append(
            "render: the Shutter Curve is not flat; Brume opens the shutter fully for its whole "
            "length (the curve is ignored)"
        )
    rolling = getattr(getattr(scene, "cycles", None), "rolling_shutter_type", "NONE")
    if rolling != "NONE":
        warnings.append("render: Rolling Shutter is ignored (Brume's shutter is global)")
    return {"open": open_, "close": open_ + length}, warnings
