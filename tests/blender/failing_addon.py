"""A glTF-exporter add-on whose node hook raises, as a buggy third-party add-on would: the
exporter only logs such an exception and writes the file anyway; with brume_gltf enabled the
export must fail instead (tests/external/blender_roundtrip.rs)."""

bl_info = {"name": "failing glTF hook (test)", "blender": (5, 0, 0), "category": "Import-Export"}


class glTF2ExportUserExtension:
    def gather_node_hook(self, gltf2_object, blender_object, export_settings):
        raise RuntimeError(f"deliberate failure on '{blender_object.name}'")


def register():
    pass


def unregister():
    pass
