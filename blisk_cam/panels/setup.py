"""The "Setup", "Tool" and "Display" panels: the scene settings (``scene.blisk_cam``)."""

from bpy.types import Panel

CATEGORY = "Blisk CAM"


class _BliskCamPanel:
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = CATEGORY

    @classmethod
    def poll(cls, context):
        return getattr(context.scene, "blisk_cam", None) is not None


class BLISKCAM_PT_setup(_BliskCamPanel, Panel):
    """Blade, axis, cones and tolerances."""

    bl_idname = "BLISKCAM_PT_setup"
    bl_label = "Setup"

    def draw(self, context):
        settings = context.scene.blisk_cam
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False

        col = layout.column()
        col.prop(settings, "blade")
        col.prop(settings, "axis_object")

        col = layout.column(heading="Cones (r1 z1 r2 z2, mm)")
        col.prop(settings, "cone1")
        col.prop(settings, "cone2")

        col = layout.column(heading="Tolerances (mm)")
        col.prop(settings, "cusp")
        col.prop(settings, "chord")


class BLISKCAM_PT_tool(_BliskCamPanel, Panel):
    """Cutter, orientation and linking."""

    bl_idname = "BLISKCAM_PT_tool"
    bl_label = "Tool"

    def draw(self, context):
        settings = context.scene.blisk_cam
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False

        col = layout.column()
        col.prop(settings, "tool_type")
        col.prop(settings, "tool_radius")
        sub = col.column()
        sub.active = settings.tool_type in {"BULL", "TAPER"}
        sub.prop(settings, "corner_radius")

        col = layout.column()
        col.prop(settings, "lead")
        col.prop(settings, "tilt")
        col.prop(settings, "link_mode")


class BLISKCAM_PT_display(_BliskCamPanel, Panel):
    """Display options and statistics input."""

    bl_idname = "BLISKCAM_PT_display"
    bl_label = "Display"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        settings = context.scene.blisk_cam
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False

        col = layout.column()
        col.prop(settings, "pose_count")
        col.prop(settings, "curve_bevel")
        col.prop(settings, "color_mode")
        col.prop(settings, "feed")
