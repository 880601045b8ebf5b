"""A Blender Volume object with a Principled Volume material as `BRUME_medium_vdb` fields
(docs/BRUME_medium_vdb.md), or a refusal naming what Brume cannot render.

Cycles' Principled Volume (intern/cycles/kernel/svm/closure.h) with render space World maps one
to one onto the extension; `tools/cycles/brume_to_cycles.py` does the reverse. Facts used here:
- density = Density socket * the Density Attribute grid (when the file has that grid); a linked
  Density socket is still multiplied by that grid;
- temperature = Temperature socket * the Temperature Attribute grid, likewise;
- with render space Object (Blender's default) Cycles multiplies density and emission by
  1 / |M (1, 1, 1) / sqrt(3)|, M the object's world matrix (`object_volume_density` in
  intern/cycles/scene/object.cpp); Brume's coefficients are per world metre, so that factor is
  folded into densityScale, emissionStrength and blackbodyTint;
- with Blackbody Intensity 0 Cycles adds no blackbody emission at all.
"""
import math
import os
import re

import bpy
from mathutils import Vector

from .nodes import Unsupported, affine, color, describe, source


class Refused(Exception):
    """This object cannot be rendered by Brume as it is; the message says why and what to do."""


def frame_file(vol, frame):
    """The .vdb file Blender reads for `frame` (BKE_volume_sequence_frame and BLI_path_frame
    in Blender's source), or None when a Clip sequence has no file at that frame."""
    path = bpy.path.abspath(vol.filepath, library=vol.library)
    if not vol.is_sequence:
        return path
    head, name = os.path.split(path)
    digits = list(re.finditer(r"\d+", name))
    if not digits:
        return path
    if vol.frame_duration == 0:
        return None
    n = vol.frame_duration
    f = frame - vol.frame_start + 1
    mode = vol.sequence_mode
    if mode == "CLIP":
        if f < 1 or f > n:
            return None
    elif mode == "EXTEND":
        f = min(max(f, 1), n)
    elif mode == "REPEAT":
        f %= n
        if f == 0:
            f = n
    elif mode == "PING_PONG":
        period = 2 * n - 2
        if period > 0:
            f %= period
            if f == 0:
                f = period
            if f > n:
                f = 2 * n - f
        else:
            f = 1
    f += vol.frame_offset
    m = digits[-1]
    width = len(m.group(0))
    number = f"{f:0{width}d}" if f >= 0 else f"-{-f:0{width}d}"
    return os.path.join(head, name[: m.start()] + number + name[m.end():])


def object_space_factor(obj):
    """Cycles' density and emission factor for render space Object (1 for World)."""
    if obj.data.render.space != "OBJECT":
        return 1.0
    unit = Vector((1.0, 1.0, 1.0)).normalized()
    length = (obj.matrix_world.to_3x3() @ unit).length
    if length == 0.0:
        raise Refused("has a zero scale")
    return 1.0 / length


def principled_volume(obj):
    """The object's material and its Principled Volume node."""
    mats = [s.material for s in obj.material_slots if s.material is not None]
    if not mats:
        raise Refused("has no material: give it a Principled Volume material")
    mat = mats[0]
    if not mat.node_tree:
        raise Refused(f"material '{mat.name}' uses no nodes: Brume needs a Principled Volume")
    out = mat.node_tree.get_output_node("CYCLES")
    if out is None:
        raise Refused(f"material '{mat.name}' has no active Material Output")
    src = source(out.inputs["Volume"])
    if src is None:
        raise Refused(f"material '{mat.name}' has nothing in the Volume output: Brume needs a Principled Volume there")
    if src.node.bl_idname != "ShaderNodeVolumePrincipled":
        raise Refused(
            f"material '{mat.name}': the Volume output comes from {describe(src.node)}; Brume "
            "renders a Principled Volume linked straight to the output (no mixing or other volume shaders)"
        )
    return mat, src.node


def medium_fields(obj, frame, depsgraph):
    """(fields without `uri`, absolute .vdb path, warnings) for a Volume object."""
    warnings = []
    vol = obj.data
    if vol.packed_file is not None:
        raise Refused("its .vdb is packed into the .blend: unpack it (File > External Data > Unpack Resources)")
    # An empty path comes back from a saved .blend as a relative folder ("//../../").
    if not vol.filepath or os.path.isdir(bpy.path.abspath(vol.filepath, library=vol.library)):
        raise Refused(
            "is a procedural volume (no .vdb file): Brume renders volumes read from OpenVDB files; "
            "bake the grids to a .vdb (e.g. with a simulation or bake node) and load that file"
        )
    if any(m.show_render for m in obj.modifiers):
        names = ", ".join(f"'{m.name}' ({m.type})" for m in obj.modifiers if m.show_render)
        raise Refused(
            f"has modifiers {names}: Brume reads the .vdb file as it is; bake the result to a .vdb "
            "(e.g. with a simulation cache) and load that, or disable the modifiers for render"
        )
    path = frame_file(vol, frame)
    if path is None:
        raise Refused(
            f"its VDB sequence has no file at frame {frame} (sequence mode Clip, frames "
            f"{vol.frame_start}..{vol.frame_start + vol.frame_duration - 1})"
        )
    if not os.path.isfile(path):
        raise Refused(f"its .vdb file {path} does not exist")
    vol.grids.load()  # lazily loaded otherwise: the grid list would be empty
    evaluated = obj.evaluated_get(depsgraph).data
    evaluated.grids.load()
    if not evaluated.grids.is_loaded:
        raise Refused(f"Blender cannot read {path}: {evaluated.grids.error_message}")
    grids = {g.name: g for g in evaluated.grids}

    mat, pv = principled_volume(obj)
    where = f"material '{mat.name}', {describe(pv)}"
    f = object_space_factor(obj)
    ins = pv.inputs

    def affine_of(name):
        try:
            a = affine(ins[name])
        except Unsupported as e:
            raise Refused(f"{where}: '{name}': {e}; Brume reads a constant or scale * grid + offset")
        for n in a.notes:
            warnings.append(f"{where}: '{name}': {n}")
        if a.grid is not None and a.grid not in grids:
            raise Refused(f"{where}: '{name}' reads attribute '{a.grid}', not a grid of {path} (grids: {', '.join(grids)})")
        return a

    def grid_attribute(name):
        a = ins[name].default_value
        return a if a in grids else None

    def rgb(name, what="Brume reads a constant colour"):
        try:
            c = color(ins[name], what)
        except Unsupported as e:
            raise Refused(f"{where}: {e}")
        if min(c) < 0.0 or max(c) > 1.0:
            raise Refused(f"{where}: '{name}' {c} lies outside [0, 1], which Brume does not accept")
        return c

    def soft(read, fallback, consequence):
        """What Brume cannot express outside the density is a warning, not a refusal."""
        try:
            return read()
        except Refused as e:
            warnings.append(f"{e}; {consequence}")
            return fallback()

    def own_rgb(name):
        return [min(max(float(c), 0.0), 1.0) for c in ins[name].default_value[:3]]

    fields = {}
    # Density: Density socket times the Density Attribute grid. Without it there is nothing
    # to render, so what cannot be read here is a refusal.
    d = affine_of("Density")
    attr = grid_attribute("Density Attribute")
    if d.grid is None:
        if attr is None:
            raise Refused(
                f"{where}: 'Density Attribute' '{ins['Density Attribute'].default_value}' is not a grid of "
                f"{path} (grids: {', '.join(grids)}): Brume needs a density grid"
            )
        fields["densityGrid"], scale = attr, d.offset
    else:
        if attr is not None:
            raise Refused(f"{where}: 'Density' reads grid '{d.grid}' and 'Density Attribute' multiplies it by grid '{attr}': clear one of them")
        if d.offset != 0.0:
            raise Refused(f"{where}: 'Density' = {d.scale} * {d.grid} + {d.offset}: Brume has no density offset")
        fields["densityGrid"], scale = d.grid, d.scale
    if scale < 0.0:
        raise Refused(f"{where}: negative density scale {scale}")
    fields["densityScale"] = scale * f

    for name, key in (("Color", "color"), ("Absorption Color", "absorptionColor")):
        fields[key] = soft(lambda: rgb(name), lambda: own_rgb(name), "the socket's own colour, clamped to [0, 1], is used")
    if grid_attribute("Color Attribute") is not None:
        warnings.append(f"{where}: 'Color Attribute' grid '{ins['Color Attribute'].default_value}' is ignored (Brume has no colour grid)")

    def anisotropy():
        g = affine_of("Anisotropy")
        if g.grid is not None:
            raise Refused(f"{where}: 'Anisotropy' reads a grid; Brume's anisotropy is a constant")
        if not -1.0 < g.offset < 1.0:
            raise Refused(f"{where}: 'Anisotropy' {g.offset} must lie strictly between -1 and 1")
        return g.offset

    fields["anisotropy"] = soft(
        anisotropy,
        lambda: min(max(float(ins["Anisotropy"].default_value), -0.999), 0.999),
        "the socket's own value, within (-1, 1), is used",
    )

    def emission():
        """Emission Strength (constant or scale * grid) times Emission Color."""
        e = affine_of("Emission Strength")
        if e.grid is not None and e.offset != 0.0:
            raise Refused(f"{where}: 'Emission Strength' = {e.scale} * {e.grid} + {e.offset}: Brume has no emission offset")
        strength = e.scale if e.grid is not None else e.offset
        try:
            ecol = color(ins["Emission Color"], "Brume reads a constant emission colour")
        except Unsupported as err:
            raise Refused(f"{where}: {err}")
        peak = max(ecol)
        if min(ecol) < 0.0:
            raise Refused(f"{where}: negative 'Emission Color' {ecol}")
        if peak > 1.0:  # Brume's colours lie in [0, 1]: move the excess into the strength
            ecol = [c / peak for c in ecol]
            strength *= peak
        if strength < 0.0:
            raise Refused(f"{where}: negative emission strength {strength}")
        out = {}
        if strength > 0.0 and peak > 0.0:
            if e.grid is not None:
                out["emissionGrid"] = e.grid
            out["emissionStrength"] = strength * f
            out["emissionColor"] = ecol
        return out

    fields.update(soft(emission, dict, "no emission exported"))

    def blackbody():
        """Temperature socket times the Temperature Attribute grid."""
        b = affine_of("Blackbody Intensity")
        if b.grid is not None:
            raise Refused(f"{where}: 'Blackbody Intensity' reads a grid; Brume's is a constant")
        intensity = b.offset
        if intensity < 0.0:
            raise Refused(f"{where}: negative 'Blackbody Intensity' {intensity}")
        if intensity == 0.0:
            return {}  # Cycles adds no blackbody emission at all then
        t = affine_of("Temperature")
        attr = grid_attribute("Temperature Attribute")
        if t.grid is None:
            if attr is None:
                raise Refused(
                    f"{where}: blackbody at a constant temperature {t.offset} K ('Temperature Attribute' "
                    f"'{ins['Temperature Attribute'].default_value}' is not a grid of {path}): Brume needs a temperature grid"
                )
            grid, tscale, toffset = attr, t.offset, 0.0
        else:
            if attr is not None:
                raise Refused(f"{where}: 'Temperature' reads grid '{t.grid}' and 'Temperature Attribute' multiplies it by grid '{attr}': clear one of them")
            grid, tscale, toffset = t.grid, t.scale, t.offset
        if tscale < 0.0:
            raise Refused(f"{where}: negative temperature scale {tscale}")
        tint = rgb("Blackbody Tint")
        if max(tint) * f <= 1.0:
            tint = [c * f for c in tint]
        else:
            # The tint would leave [0, 1]: scale the intensity instead. Exact for the T^4 term;
            # the constant term (1 - I) * 5.67e-14 / pi W m^-3 sr^-1 changes by |1 - f| times
            # that, far below anything visible.
            intensity *= f
        return {
            "temperatureGrid": grid,
            "blackbodyIntensity": intensity,
            "blackbodyTint": tint,
            "temperatureScale": tscale,
            "temperatureOffset": toffset,
        }

    fields.update(soft(blackbody, dict, "no blackbody emission exported"))

    if source(mat.node_tree.get_output_node("CYCLES").inputs["Surface"]) is not None:
        warnings.append(f"material '{mat.name}': the Surface output is ignored on a Volume object")
    if mat.cycles.volume_interpolation != "LINEAR":
        warnings.append(f"material '{mat.name}': volume interpolation {mat.cycles.volume_interpolation} (Brume interpolates linearly)")
    for k, v in fields.items():
        for x in v if isinstance(v, list) else [v]:
            if isinstance(x, float) and not math.isfinite(x):
                raise Refused(f"{where}: {k} is not finite ({v})")
    return fields, path, warnings
