"""Brume glTF volumes: adds Brume's extensions to Blender's own glTF 2.0 exporter.

- `BRUME_medium_vdb` for every Volume object whose material is a Principled Volume
  (docs/BRUME_medium_vdb.md), on a child node that restores the .vdb's Z-up axes;
- `BRUME_environment` from the World, `BRUME_render` from the render settings.
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
    "version": (1, 0, 0),
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


def _say(kind, msg):
    print(f"brume_gltf: {kind}: {msg}", file=sys.stderr, flush=True)


def _uri(path, gltf_dir):
    rel = os.path.relpath(path, gltf_dir)
    return urllib.parse.quote(rel.replace(os.sep, "/"), safe="/")


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
            gltf2_plan.extensions[RENDER] = self.Extension(RENDER, render_fields(scene), required=False)
            for obj in scene.objects:
                if obj.type == "LIGHT" and obj.data.type == "AREA" and obj.visible_get():
                    self._warn(f"area light '{obj.name}' is not exported (glTF and Brume have punctual lights only)", export_settings)
        except Exception as e:  # noqa: BLE001
            self._error(f"scene: internal error {e!r}\n{traceback.format_exc()}")

    # Objects.

    def _volume(self, node, obj, export_settings):
        from io_scene_gltf2.io.com import gltf2_io

        from .medium import Refused, medium_fields

        depsgraph = bpy.context.evaluated_depsgraph_get()
        try:
            fields, path, warnings = medium_fields(obj, bpy.context.scene.frame_current, depsgraph)
        except Refused as e:
            self._error(f"Volume '{obj.name}' {e}")
            return
        for w in warnings:
            self._warn(f"Volume '{obj.name}': {w}", export_settings)
        ext = {"uri": self._place(path)}
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


def glTF2_post_export_callback(export_settings):
    """Called by the exporter after gathering and before writing the file: fail the export
    when anything was refused or a hook raised, then copy the external files."""
    state = export_settings.get("brume_gltf")
    if state is None:
        return
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
