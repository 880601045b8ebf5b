"""A Blender Volume object with a Principled Volume material as `BRUME_medium_vdb` fields
(docs/BRUME_medium_vdb.md), or a refusal naming what Brume cannot render. Volume Scatter nodes,
alone or added to a Principled Volume that absorbs and emits (what
`tools/cycles/brume_to_cycles.py`'s `phase_scattering` builds), give the `phase` object.

Cycles' Principled Volume (intern/cycles/kernel/svm/closure.h) with render space World maps one
to one onto the extension; `tools/cycles/brume_to_cycles.py` does the reverse. Facts used here:
- density = Density socket * the Density Attribute grid (when the file has that grid); a linked
  Density socket is still multiplied by that grid;
- temperature = Temperature socket * the Temperature Attribute grid, likewise;
- with render space Object (Blender's default) Cycles multiplies density and emission by
  1 / |M (1, 1, 1) / sqrt(3)|, M the object's world matrix (`object_volume_density` in
  intern/cycles/scene/object.cpp); Brume's coefficients are per world metre, so that factor is
  folded into densityScale, emissionStrength and blackbodyTint;
- with Blackbody Intensity 0 Cycles adds no blackbody emission at all;
- the velocity (intern/cycles/blender/volume.cpp) is the grid named Velocity Grid or
  `velocity`, scaled by Velocity Scale (and shutter / fps for a velocity per second), and
  only on objects whose own motion blur is on;
- a VDB sequence reads file number (frame - Start + 1, by the sequence mode) + Offset, the
  number being the digits just before the file's extension (BKE_volume_sequence_frame).
"""
import math
import os
import re

import bpy
from mathutils import Vector

from .nodes import Unsupported, affine, color, describe, source


class Refused(Exception):
    """This object cannot be rendered by Brume as it is; the message says why and what to do."""


def frame_digits(path):
    """(start, end) in `path` of its file name's frame number: the digits just before the
    extension (BLI_path_frame_get in Blender's source), or None without one."""
    name = os.path.basename(path)
    stem = name[: name.rfind(".")] if "." in name else name
    m = re.search(r"\d+$", stem)
    if m is None:
        return None
    base = len(path) - len(name)
    return base + m.start(), base + m.end()


def sequence_number(vol, frame):
    """The file number Blender reads for scene frame `frame` (BKE_volume_sequence_frame), or
    None when the sequence has no file there (Clip outside its frames, or no frames)."""
    n = vol.frame_duration
    if n == 0:
        return None
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
    return f + vol.frame_offset


def numbered(path, digits, number):
    """`path` with its frame number (`digits`, from frame_digits) replaced by `number`, padded
    as Blender pads it (BLI_path_frame: `%.*d`, so -5 on four digits is -0005)."""
    a, b = digits
    width = b - a
    text = f"{number:0{width}d}" if number >= 0 else f"-{-number:0{width}d}"
    return path[:a] + text + path[b:]


def frame_file(vol, frame):
    """The .vdb file Blender reads for `frame` (BKE_volume_sequence_frame and BLI_path_frame
    in Blender's source), or None when a Clip sequence has no file at that frame."""
    path = bpy.path.abspath(vol.filepath, library=vol.library)
    if not vol.is_sequence:
        return path
    digits = frame_digits(path)
    if digits is None:
        return path
    number = sequence_number(vol, frame)
    return None if number is None else numbered(path, digits, number)


class Sequence:
    """A VDB sequence as Brume reads one: `pattern` (an absolute path whose frame number is a
    run of `#`), file = frame + `offset`; `files` maps each frame of the shot to its file."""

    def __init__(self, pattern, offset, files):
        self.pattern = pattern
        self.offset = offset
        self.files = files


def shot_frames(scene, frame):
    """The frames a render of this scene can ask for: its frame range and `frame`."""
    return range(min(scene.frame_start, frame), max(scene.frame_end, frame) + 1)


MODE_NAMES = {"CLIP": "Clip", "EXTEND": "Extend", "REPEAT": "Repeat", "PING_PONG": "Ping-Pong"}


def sequence_source(vol, scene, current):
    """Where the Volume's frames come from, as Brume can say it: a single path (not a sequence,
    or the same file at every frame of the shot) or a `Sequence`, whose file numbers follow the
    frame one to one (Blender's rule inside the sequence's own frames, whatever its mode).
    Returns (source, warnings); raises Refused where Blender's files do not follow the frame
    over the shot (Clip, Extend, Repeat or Ping-Pong outside the sequence's frames)."""
    path = bpy.path.abspath(vol.filepath, library=vol.library)
    digits = frame_digits(path) if vol.is_sequence else None
    if digits is None:
        return path, []
    first_seq, last_seq = vol.frame_start, vol.frame_start + vol.frame_duration - 1
    mode = MODE_NAMES.get(vol.sequence_mode, vol.sequence_mode)
    if vol.frame_duration == 0:
        raise Refused("its VDB sequence has no frames (Frames is 0): Blender reads no file")
    if sequence_number(vol, current) is None:
        raise Refused(
            f"its VDB sequence has no file at frame {current} (sequence mode Clip, frames "
            f"{first_seq}..{last_seq})"
        )
    frames = shot_frames(scene, current)
    numbers = {f: sequence_number(vol, f) for f in frames}
    offset = vol.frame_offset - vol.frame_start + 1
    shot = f"the scene's frames {frames[0]}..{frames[-1]}"
    if len(set(numbers.values())) == 1:
        # One file for the whole shot (a one-frame shot, or Extend/Repeat of a one-file sequence).
        return numbered(path, digits, numbers[current]), []
    if all(n == f + offset for f, n in numbers.items()):
        if min(numbers.values()) < 0:
            raise Refused(
                f"its VDB sequence reads negative file numbers over {shot} (down to "
                f"{min(numbers.values())}): Brume pads the sign into the number's width and "
                "Blender does not, so the file names would differ; shift the sequence (Offset)"
            )
        a, b = digits
        pattern = path[:a] + "#" * (b - a) + path[b:]
        files = {f: numbered(path, digits, n) for f, n in numbers.items()}
        return Sequence(pattern, offset, files), []
    outside = [f for f in frames if not first_seq <= f <= last_seq]
    what = {
        "CLIP": "Blender shows no volume",
        "EXTEND": "Blender holds the first or last file",
        "REPEAT": "Blender starts the sequence over",
        "PING_PONG": "Blender plays the sequence backwards",
    }.get(vol.sequence_mode, "Blender's files do not follow the frame")
    raise Refused(
        f"its VDB sequence covers frames {first_seq}..{last_seq} (sequence mode {mode}) but "
        f"{shot} reach frame {outside[0]} beyond them, where {what}; Brume reads file number "
        f"frame + frameOffset at every frame. Set the scene's frame range (Output > Frame Range) "
        f"within {first_seq}..{last_seq}, or the sequence's Start and Frames to cover the shot"
    )


def object_space_factor(obj):
    """Cycles' density and emission factor for render space Object (1 for World)."""
    if obj.data.render.space != "OBJECT":
        return 1.0
    unit = Vector((1.0, 1.0, 1.0)).normalized()
    length = (obj.matrix_world.to_3x3() @ unit).length
    if length == 0.0:
        raise Refused("has a zero scale")
    return 1.0 / length


def volume_shaders(obj):
    """The object's material, its Principled Volume (or None) and its Volume Scatter nodes (at
    most two): the shaders the Volume output sums through Add Shader nodes (docs/blender.md).
    Anything else there is refused."""
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
    found = {"ShaderNodeVolumePrincipled": [], "ShaderNodeVolumeScatter": []}
    pending = [src]
    while pending:
        node = pending.pop(0).node
        if node.mute:
            raise Refused(f"material '{mat.name}': {describe(node)} in the Volume output is muted")
        if node.bl_idname == "ShaderNodeAddShader":
            # In input order, so that two scatter nodes keep the order they were added in.
            pending[:0] = [s for s in map(source, node.inputs) if s is not None]
        elif node.bl_idname in found:
            found[node.bl_idname].append(node)
        else:
            raise Refused(
                f"material '{mat.name}': {describe(node)} feeds the Volume output; Brume renders a "
                "Principled Volume, Volume Scatter nodes, or a Principled Volume plus Volume "
                "Scatter nodes summed by Add Shader nodes (no mixing or other volume shaders)"
            )
    pvs, scatters = found.values()
    if len(pvs) > 1:
        raise Refused(f"material '{mat.name}': {len(pvs)} Principled Volume nodes are summed; Brume renders one")
    if len(scatters) > 2:
        raise Refused(
            f"material '{mat.name}': {len(scatters)} Volume Scatter nodes are summed; Brume's phase "
            "functions take one, or two Henyey-Greenstein ones as a two-lobe phase"
        )
    return mat, (pvs[0] if pvs else None), scatters


def medium_fields(obj, scene, frame, depsgraph):
    """(fields without `uri`, origin, warnings) for a Volume object at scene frame `frame`:
    `origin` is the absolute .vdb path, or a `Sequence` for a VDB sequence whose files
    follow the frame (docs/blender.md)."""
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
    origin, notes = sequence_source(vol, scene, frame)
    warnings.extend(notes)
    path = frame_file(vol, frame)
    if not os.path.isfile(path):
        raise Refused(f"its .vdb file {path} does not exist")
    fields = {}
    if isinstance(origin, Sequence):
        if origin.offset != 0:
            fields["frameOffset"] = origin.offset
        missing = [f for f, p in origin.files.items() if not os.path.isfile(p)]
        if missing:
            warnings.append(
                f"its VDB sequence has no file at {len(missing)} of the scene's frames (frame "
                f"{missing[0]}: {origin.files[missing[0]]}); Brume refuses to render those frames"
            )
    vol.grids.load()  # lazily loaded otherwise: the grid list would be empty
    evaluated = obj.evaluated_get(depsgraph).data
    evaluated.grids.load()
    if not evaluated.grids.is_loaded:
        raise Refused(f"Blender cannot read {path}: {evaluated.grids.error_message}")
    grids = {g.name: g for g in evaluated.grids}

    mat, pv, scatters = volume_shaders(obj)
    f = object_space_factor(obj)
    if pv is not None:
        fields.update(principled_fields(mat, pv, grids, path, f, warnings))
    if scatters:
        scattering_fields(fields, mat, pv, scatters, grids, path, f)
    fields.update(velocity_fields(obj, grids, path, scene, warnings))

    if source(mat.node_tree.get_output_node("CYCLES").inputs["Surface"]) is not None:
        warnings.append(f"material '{mat.name}': the Surface output is ignored on a Volume object")
    if mat.cycles.volume_interpolation != "LINEAR":
        warnings.append(f"material '{mat.name}': volume interpolation {mat.cycles.volume_interpolation} (Brume interpolates linearly)")
    for k, v in fields.items():
        for x in v if isinstance(v, list) else [v]:
            if isinstance(x, float) and not math.isfinite(x):
                raise Refused(f"material '{mat.name}': {k} is not finite ({v})")
    return fields, origin, warnings


def principled_fields(mat, pv, grids, path, f, warnings):
    """The fields a Principled Volume `pv` of material `mat` gives: density grid and scale,
    colours, anisotropy, emission and blackbody (`f`: `object_space_factor`). What Brume cannot
    express outside the density is a warning in `warnings`."""
    fields = {}
    where = f"material '{mat.name}', {describe(pv)}"
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
    return fields


def scatter_phase(node, where):
    """The `phase` object of Volume Scatter `node` (its sockets constants)."""
    kind = node.phase

    def constant(name):
        try:
            a = affine(node.inputs[name])
        except Unsupported as e:
            raise Refused(f"{where}: '{name}': {e}; Brume's phase parameters are constants")
        if a.grid is not None:
            raise Refused(f"{where}: '{name}' reads grid '{a.grid}'; Brume's phase parameters are constants")
        return a.offset

    def mean_cosine():
        g = constant("Anisotropy")
        if not -1.0 < g < 1.0:
            raise Refused(f"{where}: 'Anisotropy' {g} must lie strictly between -1 and 1")
        return g

    if kind == "HENYEY_GREENSTEIN":
        return {"type": "henyey-greenstein", "g": mean_cosine()}
    if kind == "DRAINE":
        g, alpha = mean_cosine(), constant("Alpha")
        if not -1.0 <= alpha <= 1e4:
            raise Refused(f"{where}: 'Alpha' {alpha} lies outside [-1, 10000], Brume's range for Draine's alpha")
        return {"type": "draine", "g": g, "alpha": alpha}
    if kind == "MIE":
        d = constant("Diameter")
        if not 0.0 < d <= 50.0:
            raise Refused(f"{where}: 'Diameter' {d} lies outside (0, 50] micrometres, where Brume's Mie fit holds")
        return {"type": "mie", "diameter": d}
    if kind == "RAYLEIGH":
        return {"type": "rayleigh"}
    label = node.bl_rna.properties["phase"].enum_items[kind].name
    raise Refused(
        f"{where}: phase {label} has no Brume counterpart; Brume renders Henyey-Greenstein, "
        "Draine, Mie and Rayleigh (and two Henyey-Greenstein nodes as a two-lobe phase)"
    )


def scatter_coefficients(node, where, grid, grids, path):
    """(per-channel sigma_s per unit of `grid`, the Density's scale) of Volume Scatter `node`,
    whose Density must read `grid` (None: any grid of the file) times a constant; returns the
    grid too."""
    try:
        a = affine(node.inputs["Density"])
        c = color(node.inputs["Color"], "Brume reads a constant scattering colour")
    except Unsupported as e:
        raise Refused(f"{where}: {e}")
    if a.grid is None:
        raise Refused(
            f"{where}: 'Density' is the constant {a.offset}; Brume needs it to read the density "
            "grid (an Attribute node, times a constant)"
        )
    if a.grid not in grids:
        raise Refused(f"{where}: 'Density' reads attribute '{a.grid}', not a grid of {path} (grids: {', '.join(grids)})")
    if grid is not None and a.grid != grid:
        raise Refused(f"{where}: 'Density' reads grid '{a.grid}' but the medium's density is grid '{grid}'; Brume has one density grid")
    if a.offset != 0.0:
        raise Refused(f"{where}: 'Density' = {a.scale} * {a.grid} + {a.offset}: Brume has no density offset")
    if a.scale < 0.0 or min(c) < 0.0:
        raise Refused(f"{where}: negative density scale {a.scale} or 'Color' {c}")
    return [x * a.scale for x in c], a.scale, a.grid


def scattering_fields(fields, mat, pv, scatters, grids, path, f):
    """Volume Scatter nodes (`scatters`, beside the Principled Volume `pv` or alone) as the
    `phase` object, with `densityScale`, `color` and `absorptionColor` giving their scattering
    plus `pv`'s absorption; updates `fields` (`pv`'s own, or empty). `pv` must not scatter: its
    Henyey-Greenstein lobe would be another one."""
    if pv is not None and max(fields["color"]) > 0.0:
        raise Refused(
            f"material '{mat.name}', {describe(pv)}: 'Color' {fields['color']} scatters beside the "
            "Volume Scatter nodes, a lobe Brume's phase cannot add; make it black (the Volume "
            "Scatter nodes scatter, the Principled Volume absorbs and emits)"
        )
    grid = fields.get("densityGrid")
    lobes, scales = [], []
    for node in scatters:
        where = f"material '{mat.name}', {describe(node)}"
        sigma_s, scale, grid = scatter_coefficients(node, where, grid, grids, path)
        lobes.append(([x * f for x in sigma_s], scatter_phase(node, where)))
        scales.append(scale * f)
    # Per unit of the density grid: scattering s and the Principled Volume's absorption a.
    s = [sum(lobe[0][k] for lobe in lobes) for k in range(3)]
    a = [0.0, 0.0, 0.0]
    if pv is not None:
        kept = [1.0 - math.sqrt(max(c, 0.0)) for c in fields["absorptionColor"]]
        a = [max(k, 0.0) * fields["densityScale"] for k in kept]
        scales.append(fields["densityScale"])
    # Brume's densityScale D: the largest Density, raised where colour and absorption would
    # not fit in [0, 1] (sigma_s = color D, sigma_a = (1 - color)(1 - sqrt(absorptionColor)) D).
    d = max(scales)
    if any(s[k] + a[k] > d * (1.0 + 1e-6) for k in range(3)):
        d = max(s[k] + a[k] for k in range(3))
    col, absorption = [0.0] * 3, [0.0] * 3
    for k in range(3):
        col[k] = min(s[k] / d, 1.0) if d > 0.0 else 0.0
        rest = 1.0 - col[k]
        x = min(a[k] / (d * rest), 1.0) if d > 0.0 and rest > 1e-7 else 1.0
        absorption[k] = (1.0 - x) ** 2 if x < 1.0 - 1e-12 else 0.0
    fields.update({"densityGrid": grid, "densityScale": d, "color": col, "absorptionColor": absorption})
    fields.pop("anisotropy", None)
    if len(lobes) == 1:
        fields["phase"] = lobes[0][1]
        return
    (s1, p1), (s2, p2) = lobes
    if p1["type"] != "henyey-greenstein" or p2["type"] != "henyey-greenstein":
        raise Refused(
            f"material '{mat.name}': two Volume Scatter nodes of phases {p1['type']} and "
            f"{p2['type']}; Brume blends two Henyey-Greenstein lobes only (a two-lobe phase)"
        )
    weights = [s1[k] / (s1[k] + s2[k]) for k in range(3) if s1[k] + s2[k] > 0.0]
    if weights and max(weights) - min(weights) > 1e-5:
        raise Refused(
            f"material '{mat.name}': the two Volume Scatter nodes' colour times density are not "
            "proportional, so the lobes' weight would differ per channel; Brume's two-lobe phase "
            "has one weight (scale one colour from the other)"
        )
    w = sum(weights) / len(weights) if weights else 0.5
    fields["phase"] = {"type": "two-lobe", "g1": p1["g"], "g2": p2["g"], "weight": w}


# Cycles' standard name of a volume's velocity grid (`Attribute::standard_name`): a grid so
# named is the velocity whatever `Volume.velocity_grid` says (intern/cycles/blender/volume.cpp).
VELOCITY = "velocity"


def velocity_fields(obj, grids, path, scene, warnings):
    """`velocityGrid`, `velocityUnit`, `velocityScale`: the grid Cycles reads as the volume's
    velocity (`Volume.velocity_grid`, or a grid named `velocity`), with Blender's unit and
    scale, where Cycles would blur the object. What Brume cannot follow is left out with a
    warning (the volume is then rendered without velocity blur)."""
    vol = obj.data
    blurs = scene.render.use_motion_blur
    cycles = getattr(obj, "cycles", None)
    if cycles is not None and not cycles.use_motion_blur:
        # Cycles adds no velocity attribute to an object whose own motion blur is off.
        if blurs and (vol.velocity_grid in grids or VELOCITY in grids):
            warnings.append("Object Properties > Motion Blur is off: exported without velocity blur")
        return {}
    names = [n for n in (vol.velocity_grid, VELOCITY) if n and n in grids]
    if not names:
        split = [n for n in (vol.velocity_x_grid, vol.velocity_y_grid, vol.velocity_z_grid) if n and n in grids]
        if split and blurs:
            warnings.append(
                f"its velocity is split into grids {', '.join(split)}; Brume reads one vector grid, "
                "so no velocity blur is exported (merge them into one vector grid)"
            )
        return {}
    name = names[0]
    if len(set(names)) > 1:
        warnings.append(
            f"Velocity Grid is '{name}' but {path} also has a grid named '{VELOCITY}', which Cycles "
            f"reads as the velocity too; '{name}' is exported"
        )
    kind = grids[name].data_type
    if kind not in ("VECTOR_FLOAT", "VECTOR_DOUBLE"):
        warnings.append(
            f"velocity grid '{name}' holds {kind.lower().replace('_', ' ')} values, not float "
            "vectors; no velocity blur exported"
        )
        return {}
    scale = float(vol.velocity_scale)
    if not (math.isfinite(scale) and scale >= 0.0):
        warnings.append(f"Velocity Scale {scale} is not a finite number >= 0; no velocity blur exported")
        return {}
    if blurs and scene.render.motion_blur_position == "END":
        length = scene.render.motion_blur_shutter
        warnings.append(
            f"with the shutter ending on the frame Cycles advects the density over frames "
            f"{(1 - length) * length:g}..{(2 - length) * length:g} after it, not over the shutter "
            f"({-length:g}..0) where it blurs moving objects; Brume blurs the velocity over the "
            "shutter, so this volume renders differently in Cycles"
        )
    return {
        "velocityGrid": name,
        "velocityUnit": "second" if vol.velocity_unit == "SECOND" else "frame",
        "velocityScale": scale,
    }
