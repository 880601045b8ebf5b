"""Export a .blend to a Brume glTF scene headless, with the `brume_gltf` add-on (this folder).

Usage (a Python with bpy 5.0.1, e.g. tools/cycles/.venv/bin/python; `brume import-blend` runs
this):

    python export_blend.py scene.blend -o scene.gltf [--copy-vdb] [--frame N] [--addon DIR]...

- the add-on is enabled with `addon_utils.enable` (a bare import is not seen by the exporter);
- `--frame N` sets the scene frame first (VDB sequences, animated transforms), otherwise the
  frame saved in the .blend is used;
- animations are exported in the exporter's Scene mode (every animated object sampled at
  every frame of the scene's range), which the add-on also forces;
- `--addon DIR` enables another exporter add-on as well (a package folder or a .py module);
- the glTF (with its .bin) or .glb is written under a temporary name in the output folder and
  renamed at the end, so a failed export leaves no output; exit status 1 with the reasons on
  stderr (lines `error: ...`) when the export fails.
"""
import argparse
import json
import os
import sys


def fail(msg):
    print(f"error: {msg}", file=sys.stderr, flush=True)
    sys.exit(1)


def enable_addon(path):
    import addon_utils

    path = os.path.abspath(path)
    folder, name = os.path.split(path.rstrip(os.sep))
    name = os.path.splitext(name)[0]
    if folder not in sys.path:
        sys.path.insert(0, folder)
    errors = []
    mod = addon_utils.enable(name, default_set=True, handle_error=lambda e: errors.append(repr(e)))
    if mod is None:
        fail(f"cannot enable the add-on {path}: {'; '.join(errors) or 'unknown reason'}")
    return mod


def main(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("blend")
    p.add_argument("-o", "--output", required=True, help=".gltf (with a .bin beside it) or .glb")
    p.add_argument("--copy-vdb", action="store_true", help="copy the .vdb files beside the output")
    p.add_argument("--frame", type=int, help="scene frame to export (default: the saved one)")
    p.add_argument("--addon", action="append", default=[], help="another add-on to enable")
    args = p.parse_args(argv)

    blend = os.path.abspath(args.blend)
    if not os.path.isfile(blend):
        fail(f"{blend}: no such .blend file")
    out = os.path.abspath(args.output)
    stem, ext = os.path.splitext(out)
    if ext.lower() not in (".gltf", ".glb"):
        fail(f"{out}: the output must end in .gltf or .glb")
    out_dir = os.path.dirname(out)
    if not os.path.isdir(out_dir):
        fail(f"{out_dir}: the output folder does not exist")

    import bpy

    try:
        bpy.ops.wm.open_mainfile(filepath=blend)
    except RuntimeError as e:
        fail(f"{blend}: Blender cannot open it: {e}")
    here = os.path.dirname(os.path.abspath(__file__))
    brume = enable_addon(os.path.join(here, "brume_gltf"))
    for extra in args.addon:
        enable_addon(extra)
    scene = bpy.context.scene
    if args.frame is not None:
        scene.frame_set(args.frame)
    scene.brume_gltf.copy_vdb = args.copy_vdb

    tmp_stem = f"{stem}.brume-tmp{os.getpid()}"
    tmp = tmp_stem + ext
    gltf = ext.lower() == ".gltf"
    try:
        bpy.ops.export_scene.gltf(
            filepath=tmp,
            export_format="GLTF_SEPARATE" if gltf else "GLB",
            export_yup=True,
            export_import_convert_lighting_mode="COMPAT",
            export_current_frame=True,
            export_animations=True,
            export_animation_mode="SCENE",
            export_cameras=True,
            export_lights=True,
            export_extras=False,
        )
    except Exception as e:  # noqa: BLE001
        for f in (tmp, tmp_stem + ".bin"):
            if os.path.exists(f):
                os.remove(f)
        if brume.last_errors:
            for msg in brume.last_errors:
                print(f"error: {msg}", file=sys.stderr)
            fail(f"{blend}: the export was refused ({len(brume.last_errors)} problem(s) above); nothing written")
        fail(f"{blend}: the glTF exporter failed: {str(e).strip().splitlines()[-1]}")
    if not os.path.isfile(tmp):
        fail(f"{blend}: the glTF exporter wrote nothing")
    if gltf:
        # The .bin was written as <tmp>.bin: rename it and point the glTF at the final name.
        with open(tmp) as f:
            doc = json.load(f)
        tmp_bin = os.path.basename(tmp_stem) + ".bin"
        final_bin = os.path.basename(stem) + ".bin"
        for buf in doc.get("buffers", []):
            if buf.get("uri") == tmp_bin:
                buf["uri"] = final_bin
                os.replace(tmp_stem + ".bin", stem + ".bin")
        with open(tmp, "w") as f:
            json.dump(doc, f, indent=1)
    os.replace(tmp, out)
    media = 0
    if gltf:
        media = sum(1 for n in doc.get("nodes", []) if "BRUME_medium_vdb" in n.get("extensions", {}))
    print(f"exported {out} ({media} medium node(s), frame {scene.frame_current})", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:] if "--" not in sys.argv else sys.argv[sys.argv.index("--") + 1 :])
