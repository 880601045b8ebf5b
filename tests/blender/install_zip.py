"""Installs tools/blender/brume_gltf as a user would through Edit > Preferences > Add-ons >
Install from Disk (a zip of the folder, `preferences.addon_install` + `addon_enable`, what the
UI runs), then exports a .blend with the exporter's own default options (GLB, lighting mode
SPEC, no cameras or lights), as File > Export > glTF 2.0 would. Run with HOME set to a scratch
folder: the add-on is installed into the user's Blender configuration.

    python install_zip.py scene.blend out.glb
"""
import os
import sys
import tempfile
import zipfile

import bpy

blend, out = sys.argv[1], sys.argv[2]
src = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tools", "blender", "brume_gltf")
bpy.ops.wm.open_mainfile(filepath=os.path.abspath(blend))
# The zip is only read by the install (which copies the add-on into the configuration).
with tempfile.TemporaryDirectory() as tmp:
    zip_path = os.path.join(tmp, "brume_gltf.zip")
    with zipfile.ZipFile(zip_path, "w") as z:
        for name in sorted(os.listdir(src)):
            if name.endswith(".py"):
                z.write(os.path.join(src, name), f"brume_gltf/{name}")
    bpy.ops.preferences.addon_install(filepath=zip_path)
bpy.ops.preferences.addon_enable(module="brume_gltf")
assert "brume_gltf" in bpy.context.preferences.addons
print("installed", sys.modules["brume_gltf"].__file__)
bpy.ops.export_scene.gltf(filepath=os.path.abspath(out))
