"""Prints, as one JSON object, the world matrices Blender evaluates for a .blend's camera and
Volume objects at the given frames (tests/external/blender_roundtrip.rs compares them with
Brume's reading of the exported animations). The scene's own frame is restored at the end.

    python dump_motion.py scene.blend FRAME...

Output: {"FRAME": {"camera": rows, "volumes": {name: rows}}}, rows a 4x4 row-major matrix in
Blender's Z-up world.
"""
import json
import sys

import bpy


def rows(m):
    return [list(r) for r in m]


def main(argv):
    bpy.ops.wm.open_mainfile(filepath=argv[0])
    scene = bpy.context.scene
    saved = scene.frame_current
    out = {}
    for frame in (int(f) for f in argv[1:]):
        scene.frame_set(frame)
        out[str(frame)] = {
            "camera": rows(scene.camera.matrix_world),
            "volumes": {o.name: rows(o.matrix_world) for o in scene.objects if o.type == "VOLUME"},
        }
    scene.frame_set(saved)
    print(json.dumps(out))


if __name__ == "__main__":
    main(sys.argv[1:])
