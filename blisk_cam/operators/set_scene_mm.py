"""``blisk_cam.set_scene_mm``: switch the scene's units to millimetres with one click
(:mod:`blisk_cam.blender.units`)."""

import bpy


class BLISKCAM_OT_set_scene_mm(bpy.types.Operator):
    """Show lengths in millimetres: metric, unit scale 0.001, length unit millimetres (Blisk
    CAM reads 1 Blender unit as 1 mm either way; a blade in mm then reads true in the UI)"""

    bl_idname = "blisk_cam.set_scene_mm"
    bl_label = "Set Scene to Millimetres"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        from ..blender.units import is_scene_mm

        if context.scene is None:
            cls.poll_message_set("No scene")
            return False
        if is_scene_mm(context.scene):
            cls.poll_message_set("The scene already uses millimetres")
            return False
        return True

    def execute(self, context):
        from ..blender.units import set_scene_mm

        change = set_scene_mm(context.scene)
        if abs(change - 1.0) > 1e-6:
            self.report(
                {"WARNING"},
                f"Scene set to millimetres; objects made at the old unit scale are now read "
                f"{change:g} × smaller: re-import the blade mesh",
            )
        else:
            self.report({"INFO"}, "Scene set to millimetres (1 Blender unit = 1 mm)")
        return {"FINISHED"}
