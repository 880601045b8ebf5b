"""Brume glTF volumes: adds Brume's extensions to Blender's own glTF 2.0 exporter.

- `BRUME_medium_vdb` for every Volume object whose material is a Principled Volume
  (docs/BRUME_medium_vdb.md), on a child node that restores the .vdb's Z-up axes;
- `BRUME_environment` from the World, `BRUME_render` from the render settings (resolution,
  samples, frame, frame rate, frame range, motion blur shutter);
- object and camera animations through the exporter's Scene mode, with key times at Blender's
  own frame times.
Mesh objects, cameras and lights go through the exporter unchanged (with warnings where Brume
renders them differently). What Brume cannot render is refused: the export fails with the list
of reasons instead of writing a file without the volumes.

Install: zip the `brume_gltf` folder and pick the zip in Edit > Preferences > Add-ons >
Install from Disk; or headless, put `tools/blender` on `sys.path` and call
`addon_utils.enable("brume_gltf", default_set=True)` (tools/blender/export_blend.py does).
"""
import math
import os
import shutil
import sys
import traceback
import urllib.parse

import bpy

bl_info = {
    "name": "Brume glTF volumes",
    "author": "Brume developers",
    "version": (1, 1, 0),
    "blender": (5, 0, 0),
    "location": "File > Export > glTF 2.0 (.glb/.gltf) > Brume",
    "description": "Exports Volume objects (OpenVDB), the world and render settings as Brume's glTF extensions",
    "category": "Import-Export",
}

MEDIUM = "BRUME_medium_vdb"
ENVIRONMENT = "BRUME_environment"
RENDER = "BRUME_render"

# Rotation of -90 degrees about X (x, y, z, w): glTF's Y-up from Blender's Z-up. The exporter
# writes a Volume object's node as C M C^-1 (C this rotation), right for meshes whose vertices
# it converts; the .vdb is not converted, so a child node carrying C restores
# world_from_medium = C M (grid transform), as the exporter itself does for cameras and lights.
Y_UP_FROM_Z_UP = [-math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5)]

# The messages of the last export that failed, for scripts (export_blend.py prints them).
last_errors = []


class BrumeExportError(Exception):
    pass


class BrumeGltfSettings(bpy.types.PropertyGroup):
    copy_vdb: bpy.props.BoolProperty(
        name="Copy .vdb files",
        description="Copy the .vdb files (and the environment map) beside the glTF file instead of "
        "referring to them by a relative path",
        default=False,
    )


def draw_export(context, layout):
    """The exporter calls this to draw the add-on's options in its file browser."""
    header, body = layout.panel("BRUME_gltf_export", default_closed=False)
    header.label(text="Brume")
    if body:
        body.prop(context.scene.brume_gltf, "copy_vdb")
        body.label(text="Forced: lighting mode Standard, current frame, cameras and lights included")
        body.label(text="Animations: Scene mode, sampled at every frame")


def _say(kind, msg):
    print(f"brume_gltf: {kind}: {msg}", file=sys.stderr, flush=True)


def _uri(path, gltf_dir):
    rel = os.path.relpath(path, gltf_dir)
    return urllib.parse.quote(rel.replace(os.sep, "/"), safe="/")


def _pattern_uri(pattern, gltf_dir):
    """`_uri` of a sequence pattern, its last run of `#` left as it is and every other
    character escaped as usual (a `#` elsewhere becomes %23, which Brume does not read as a
    frame number)."""
    rel = os.path.relpath(pattern, gltf_dir).replace(os.sep, "/")
    end = rel.rindex("#") + 1
    start = len(rel[:end].rstrip("#"))
    quote = lambda t: urllib.parse.quote(t, safe="/")  # noqa: E731
    return quote(rel[:start]) + rel[start:end] + quote(rel[end:])


class glTF2ExportUserExtension:
    """Instantiated by Blender's glTF exporter at each export; its hooks are called by name."""

    def __init__(self):
        from io_scene_gltf2.io.com.gltf2_io_extensions import Extension

        self.Extension = Extension
        self.errors = []
        self.warnings = []
        self.copies = {}  # source path -> destination path
        self.copy = False
        self.gltf_dir = ""
        self.frame = None  # the scene frame when the export started

    def _frame(self):
        return bpy.context.scene.frame_current if self.frame is None else self.frame

    def _warn(self, msg, export_settings):
        self.warnings.append(msg)
        _say("warning", msg)
        export_settings["log"].warning("Brume: " + msg, popup=True)

    def _error(self, msg):
        self.errors.append(msg)

    def _place(self, path):
        """The URI of an external file: copied beside the glTF (at the end of a successful
        export) or relative to it."""
        if not self.copy:
            try:
                return _uri(path, self.gltf_dir)
            except ValueError:  # another drive on Windows: no relative path exists
                raise BrumeExportError(f"{path} has no path relative to {self.gltf_dir}: use the copy option")
        if path not in self.copies:
            taken = set(self.copies.values())
            stem, ext = os.path.splitext(os.path.basename(path))
            dst, k = os.path.join(self.gltf_dir, stem + ext), 1
            while dst in taken:
                dst, k = os.path.join(self.gltf_dir, f"{stem}_{k}{ext}"), k + 1
            self.copies[path] = dst
        return _uri(self.copies[path], self.gltf_dir)

    def _place_sequence(self, seq):
        """The URI of a VDB sequence, its frame number a run of `#` (kept unescaped: Brume
        reads the run from the URI as written): relative to the glTF, or, with the copy option,
        the shot's files copied beside it under their own names (a suffix `_k` on the name when
        another file already took one of them)."""
        if not self.copy:
            try:
                return _pattern_uri(seq.pattern, self.gltf_dir)
            except ValueError:
                raise BrumeExportError(f"{seq.pattern} has no path relative to {self.gltf_dir}: use the copy option")
        existing = {f: p for f, p in seq.files.items() if os.path.isfile(p)}
        taken = {dst: src for src, dst in self.copies.items()}
        name = os.path.basename(seq.pattern)
        stem, ext = os.path.splitext(name)
        k = 0
        while True:
            base = name if k == 0 else f"{stem}_{k}{ext}"
            end = base.rindex("#") + 1
            run = len(base[:end].rstrip("#"))
            width = end - run
            dsts = {}
            for f, src in existing.items():
                number = f + seq.offset
                dsts[src] = os.path.join(self.gltf_dir, base[:run] + f"{number:0{width}d}" + base[run + width:])
            if all(taken.get(d, s) == s for s, d in dsts.items()):
                break
            k += 1
        self.copies.update(dsts)
        return _pattern_uri(os.path.join(self.gltf_dir, base), self.gltf_dir)

    # Hooks (names and arguments fixed by the exporter).

    def pre_export_hook(self, export_settings):
        # First, so that the post-export callback sees this export even if the rest raises.
        export_settings["brume_gltf"] = self
        try:
            self._prepare(export_settings)
        except Exception as e:  # noqa: BLE001
            self._error(f"export settings: internal error {e!r}\n{traceback.format_exc()}")

    def _prepare(self, export_settings):
        self.gltf_dir = os.path.abspath(export_settings["gltf_filedirectory"])
        scene = bpy.context.scene
        # The exporter steps through the frame range to sample animations and leaves the scene
        # at its last frame: the scene's own frame is the one exported.
        self.frame = scene.frame_current
        self.copy = bool(getattr(scene, "brume_gltf", None) and scene.brume_gltf.copy_vdb)
        mode = export_settings.get("gltf_lighting_mode")
        if mode != "COMPAT":
            # SPEC writes a Sun of strength 3 as 2049 lux; Brume reads COMPAT units.
            export_settings["gltf_lighting_mode"] = "COMPAT"
            self._warn(f"lighting mode {mode} replaced by COMPAT (Standard), the units Brume reads", export_settings)
        # The exporter's own defaults leave cameras and lights out: a Brume scene needs them.
        for key, what in (("gltf_cameras", "Cameras"), ("gltf_lights", "Punctual Lights")):
            if not export_settings.get(key):
                export_settings[key] = True
                self._warn(f"'Include > {what}' was off in the exporter options: turned on for Brume", export_settings)
        if not export_settings.get("gltf_yup", True):
            self._warn("'+Y Up' is off: the scene stays Z-up, but Brume (like glTF) takes +Y as up", export_settings)
        # The exporter jumps to frame 0 otherwise: VDB sequences and transforms of the current frame.
        export_settings["gltf_current_frame"] = True
        self._animation_settings(export_settings, scene)
        # Other add-ons' hook failures are only logged by the exporter: record them too.
        log = export_settings["log"]
        original = log.error

        pending = []  # the exporter logs "Extension hook X fails on M", then the exception

        def error(message, popup=False, _original=original):
            text = str(message)
            if text.startswith("Extension hook"):
                self._error(f"{text} (another add-on; the exporter would write the file without its output)")
                pending[:] = [len(self.errors) - 1]
            elif pending:
                self.errors[pending.pop()] += f": {text}"
            return _original(message, popup)

        log.error = error

    def _animation_settings(self, export_settings, scene):
        """Animations as Brume plays them: every glTF animation of the file at once, key time t
        at frame t * fps. The exporter's Scene mode bakes what Blender renders (constraints,
        drivers, NLA, parents) at every frame of the scene's range, at the scene's own times;
        Actions mode writes each action as a clip of its own (two on one object make two
        animations of the same node) and may slide keys in time."""
        if not export_settings.get("gltf_animations"):
            moving = [
                o.name
                for o in scene.objects
                if o.constraints
                or (o.animation_data is not None and (o.animation_data.action or o.animation_data.nla_tracks or o.animation_data.drivers))
            ]
            if moving:
                self._warn(
                    f"'Animation' is off in the exporter options: {', '.join(sorted(moving)[:5])}"
                    f"{' and others' if len(moving) > 5 else ''} are exported at the current frame only "
                    "(no motion, no camera motion blur)",
                    export_settings,
                )
            return
        forced = (
            ("gltf_animation_mode", "SCENE", "Animation Mode"),
            ("gltf_force_sampling", True, "Always Sample Animations"),
            ("gltf_frame_step", 1, "Sampling Rate"),
            ("gltf_anim_slide_to_zero", False, "Set All glTF Animation Starting at 0"),
            ("gltf_export_anim_pointer", False, "Export Animation Pointer"),
        )
        for key, value, label in forced:
            if export_settings.get(key, value) != value:
                self._warn(
                    f"'{label}' was {export_settings[key]!r} in the exporter options: set to {value!r} for Brume, "
                    "which plays every animation of the file at once, sampled at each frame at the scene's own times",
                    export_settings,
                )
            export_settings[key] = value
        # What the exporter itself sets for modes other than Actions.
        export_settings["gltf_trs_w_animation_pointer"] = False
        export_settings["gltf_merge_animation"] = "NLA_TRACK"
        export_settings["gltf_export_anim_single_armature"] = False
        export_settings.setdefault("gltf_anim_scene_split_object", True)

    def gather_gltf_hook(self, active_scene_idx, scenes, animations, export_settings):
        """Key times at Blender's own frame times. The exporter writes frame f at
        f / (fps * fps_base) seconds, where Blender's frame f comes at f * fps_base / fps
        (fps_base is 1.001 at 23.98, 29.97 and 59.94 fps): every key time is multiplied by
        fps_base^2, so that Brume's frame f (time f / fps, fps = render fps / fps_base) is
        Blender's."""
        try:
            base = bpy.context.scene.render.fps_base
            if base != 1.0 and animations:
                _retime(animations, base * base)
        except Exception as e:  # noqa: BLE001
            self._error(f"animations: internal error {e!r}\n{traceback.format_exc()}")

    def gather_node_hook(self, gltf2_object, blender_object, export_settings):
        try:
            kind = blender_object.type
            if kind == "VOLUME":
                self._volume(gltf2_object, blender_object, export_settings)
            elif kind == "LIGHT":
                self._light(blender_object, export_settings)
            elif kind == "MESH":
                self._mesh(blender_object)
        except BrumeExportError as e:
            self._error(f"{blender_object.type.title()} '{blender_object.name}': {e}")
        except Exception as e:  # noqa: BLE001 - the export must fail, not drop the volume
            self._error(f"{blender_object.type.title()} '{blender_object.name}': internal error {e!r}\n{traceback.format_exc()}")

    def gather_gltf_extensions_hook(self, gltf2_plan, export_settings):
        try:
            from .environment import environment_fields, render_fields

            scene = bpy.context.scene
            if gltf2_plan.extensions is None:
                gltf2_plan.extensions = {}
            fields, image, warnings = environment_fields(scene.world)
            for w in warnings:
                self._warn(w, export_settings)
            if fields is not None:
                if image is not None:
                    try:
                        fields["uri"] = self._place(image)
                    except BrumeExportError as e:
                        self._warn(f"world: {e}; map left out", export_settings)
                gltf2_plan.extensions[ENVIRONMENT] = self.Extension(ENVIRONMENT, fields, required=False)
            render, warnings = render_fields(scene, self._frame())
            for w in warnings:
                self._warn(w, export_settings)
            gltf2_plan.extensions[RENDER] = self.Extension(RENDER, render, required=False)
            for obj in scene.objects:
                if obj.type == "LIGHT" and obj.data.type == "AREA" and obj.visible_get():
                    self._warn(f"area light '{obj.name}' is not exported (glTF and Brume have punctual lights only)", export_settings)
        except Exception as e:  # noqa: BLE001
            self._error(f"scene: internal error {e!r}\n{traceback.format_exc()}")

    # Objects.

    def _volume(self, node, obj, export_settings):
        from io_scene_gltf2.io.com import gltf2_io

        from .medium import Refused, Sequence, medium_fields

        depsgraph = bpy.context.evaluated_depsgraph_get()
        try:
            fields, source, warnings = medium_fields(obj, bpy.context.scene, self._frame(), depsgraph)
        except Refused as e:
            self._error(f"Volume '{obj.name}' {e}")
            return
        for w in warnings:
            self._warn(f"Volume '{obj.name}': {w}", export_settings)
        if isinstance(source, Sequence):
            ext = {"uri": self._place_sequence(source)}
        else:
            ext = {"uri": self._place(source)}
        ext.update(fields)
        child = gltf2_io.Node(
            camera=None,
            children=[],
            extensions={MEDIUM: self.Extension(MEDIUM, ext, required=False)},
            extras=None,
            matrix=None,
            mesh=None,
            name=f"{obj.name}_medium",
            rotation=Y_UP_FROM_Z_UP if export_settings["gltf_yup"] else None,
            scale=None,
            skin=None,
            translation=None,
            weights=None,
        )
        if node.children is None:
            node.children = []
        node.children.append(child)

    def _light(self, obj, export_settings):
        light = obj.data
        name = f"{light.type.title()} light '{obj.name}'"
        if light.type in ("POINT", "SPOT") and light.shadow_soft_size > 0.0:
            self._warn(f"{name}: radius {light.shadow_soft_size:g} m is rendered as a point (Brume's lights are punctual)", export_settings)
        if light.type == "SUN" and light.angle > 0.0:
            self._warn(f"{name}: angle {math.degrees(light.angle):g} deg is rendered as a point-like sun", export_settings)
        if light.type == "SPOT" and light.spot_blend > 0.0:
            self._warn(f"{name}: Blender's spot blend is a smoothstep, glTF's cone falloff is not; the penumbra differs", export_settings)
        if getattr(light, "use_nodes", False) and light.node_tree is not None:
            self._warn(f"{name}: light nodes are ignored", export_settings)

    def _mesh(self, obj):
        for slot in obj.material_slots:
            mat = slot.material
            if mat is None or not mat.node_tree:
                continue
            out = mat.node_tree.get_output_node("CYCLES")
            if out is not None and out.inputs["Volume"].is_linked:
                self._error(
                    f"Mesh '{obj.name}': material '{mat.name}' has a volume shader; Brume renders "
                    "volumes from .vdb files (Volume objects) or KHR_materials_volume, not mesh volume "
                    "shaders: convert the volume to a .vdb or unlink the Volume output"
                )


def _retime(animations, k):
    """Multiplies every key time of `animations` (the exporter's gathered objects) by `k`, and
    divides cubic-spline tangents by it (they are derivatives in time). Accessors shared
    between samplers are changed once."""
    import array

    from io_scene_gltf2.io.exp.binary_data import BinaryData

    def scaled(accessor, factor, tangents=False):
        data = array.array("f", accessor.buffer_view.data)
        if not tangents:
            data = array.array("f", (x * factor for x in data))
        else:
            width = len(data) // accessor.count  # components per element
            for i in range(0, len(data), 3 * width):
                for j in range(width):
                    data[i + j] *= factor  # in-tangent
                    data[i + 2 * width + j] *= factor  # out-tangent
        accessor.buffer_view = BinaryData(data.tobytes(), accessor.buffer_view.bufferViewTarget)
        if not tangents:
            accessor.min = [min(data)] if len(data) else accessor.min
            accessor.max = [max(data)] if len(data) else accessor.max

    done = set()
    for animation in animations:
        for sampler in animation.samplers:
            if id(sampler.input) not in done:
                done.add(id(sampler.input))
                scaled(sampler.input, k)
            if sampler.interpolation == "CUBICSPLINE" and id(sampler.output) not in done:
                done.add(id(sampler.output))
                scaled(sampler.output, 1.0 / k, tangents=True)


def glTF2_post_export_callback(export_settings):
    """Called by the exporter after gathering and before writing the file: fail the export
    when anything was refused or a hook raised, then copy the external files."""
    state = export_settings.get("brume_gltf")
    if state is None:
        return
    scene = bpy.context.scene
    if state.frame is not None and scene.frame_current != state.frame:
        scene.frame_set(state.frame)  # sampling the animations left the scene on another frame
    last_errors.clear()
    if state.errors:
        last_errors.extend(state.errors)
        for e in state.errors:
            _say("error", e)
        raise BrumeExportError(
            "the scene cannot be exported for Brume (nothing written):\n - " + "\n - ".join(state.errors)
        )
    for src, dst in state.copies.items():
        if os.path.exists(dst) and os.path.samefile(src, dst):
            continue
        os.makedirs(os.path.dirname(dst), exist_ok=True)
        tmp = f"{dst}.tmp{os.getpid()}"
        shutil.copyfile(src, tmp)
        os.replace(tmp, dst)


def register():
    bpy.utils.register_class(BrumeGltfSettings)
    bpy.types.Scene.brume_gltf = bpy.props.PointerProperty(type=BrumeGltfSettings)


def unregister():
    del bpy.types.Scene.brume_gltf
    bpy.utils.unregister_class(BrumeGltfSettings)
