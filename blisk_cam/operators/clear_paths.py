"""``blisk_cam.clear_paths``: remove the blade's output collection (paths, cone objects) and
its stored paths."""

import bpy

from .common import result_blade_name, settings_of


class BLISKCAM_OT_clear_paths(bpy.types.Operator):
    """Delete the generated tool path objects of the blade (the blade itself is kept)"""

    bl_idname = "blisk_cam.clear_paths"
    bl_label = "Clear Paths"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        if settings_of(context) is None:
            cls.poll_message_set("Blisk CAM settings are missing: enable the add-on")
            return False
        if result_blade_name(context, paths_only=False) is None:
            cls.poll_message_set("No generated paths to clear")
            return False
        return True

    def execute(self, context):
        from ..blender.path_objects import clear_path_objects, collection_name

        name = result_blade_name(context, paths_only=False)
        if name is None or not clear_path_objects(name):
            self.report({"ERROR"}, "No generated paths to clear")
            return {"CANCELLED"}
        settings = context.scene.blisk_cam
        if settings.stat_blade == name:
            settings.has_result = False
            settings.stat_blade = ""
        self.report({"INFO"}, f"Removed '{collection_name(name)}'")
        return {"FINISHED"}
