"""The "Robot" panel: the polishing robot cell (robot, language, feed, force, output folder,
free-angle options), Export Robot Program and Show Robot, the figures of the last plan and the
legend of the pose colours."""

from bpy.types import Panel

from .setup import _BliskCamPanel, _split


class BLISKCAM_PT_robot(_BliskCamPanel, Panel):
    """Robot, controller language and polishing values; export and show the robot program."""

    bl_idname = "BLISKCAM_PT_robot"
    bl_label = "Robot"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        from ..blender.robot_objects import margin_legend
        from .paths import _wrap

        settings = context.scene.blisk_cam
        layout = _split(self.layout)
        col = layout.column()
        col.prop(settings, "robot")
        if settings.robot == "FILE":
            col.prop(settings, "robot_file")
        col.prop(settings, "robot_post")
        col.prop(settings, "robot_feed")
        col.prop(settings, "robot_force")
        col.prop(settings, "robot_out")
        col = layout.column(heading="Free Angle")
        col.prop(settings, "robot_samples")
        col.prop(settings, "robot_max_step")
        col.prop(settings, "robot_min_wrist")
        layout.prop(settings, "export_anyway")
        layout.operator("blisk_cam.export_robot", icon="EXPORT")
        layout.operator("blisk_cam.show_robot", icon="ARMATURE_DATA")
        box = self.layout.box()
        col = box.column(align=True)
        if settings.robot_summary:
            for line in _wrap(settings.robot_summary, 44):
                col.label(text=line)
        for line in _wrap(margin_legend(), 44):
            col.label(text=line)
