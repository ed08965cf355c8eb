"""The input panels: "Setup" (blade, axis, fit cones), "Region" (cones), "Tool" and
"Tolerances" — the scene settings (``scene.blisk_cam``)."""

from bpy.types import Panel

CATEGORY = "Blisk CAM"


class _BliskCamPanel:
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = CATEGORY

    @classmethod
    def poll(cls, context):
        return getattr(context.scene, "blisk_cam", None) is not None


def _split(layout):
    layout.use_property_split = True
    layout.use_property_decorate = False
    return layout


class BLISKCAM_PT_setup(_BliskCamPanel, Panel):
    """Blade, axis and cone fitting."""

    bl_idname = "BLISKCAM_PT_setup"
    bl_label = "Setup"

    def draw(self, context):
        settings = context.scene.blisk_cam
        layout = _split(self.layout)
        col = layout.column()
        col.prop(settings, "blade")
        active = getattr(context, "active_object", None)
        if settings.blade is None and active is not None:
            col.label(text=f"Using the active object '{active.name}'", icon="INFO")
        col.prop(settings, "axis_object")
        if settings.axis_object is None:
            col.label(text="Axis: the blade's world Z through its origin", icon="INFO")
        layout.operator("blisk_cam.fit_cones", icon="MESH_CONE")
        if settings.fit_residual1 >= 0.0 and settings.fit_residual2 >= 0.0:
            layout.label(
                text=f"Fit residual: hub {settings.fit_residual1:.4f} mm, "
                f"tip {settings.fit_residual2:.4f} mm"
            )


class BLISKCAM_PT_region(_BliskCamPanel, Panel):
    """The two cones that bound the machined region."""

    bl_idname = "BLISKCAM_PT_region"
    bl_label = "Region"

    def draw(self, context):
        settings = context.scene.blisk_cam
        layout = _split(self.layout)
        col = layout.column(heading="Cones (r1 z1 r2 z2, mm)")
        col.prop(settings, "cone1")
        col.prop(settings, "cone2")
        layout.prop(settings, "show_gizmos")


class BLISKCAM_PT_tool(_BliskCamPanel, Panel):
    """Cutter, orientation and linking."""

    bl_idname = "BLISKCAM_PT_tool"
    bl_label = "Tool"

    def draw(self, context):
        settings = context.scene.blisk_cam
        layout = _split(self.layout)
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


class BLISKCAM_PT_tolerances(_BliskCamPanel, Panel):
    """Cusp and chord tolerances, verification."""

    bl_idname = "BLISKCAM_PT_tolerances"
    bl_label = "Tolerances"

    def draw(self, context):
        settings = context.scene.blisk_cam
        layout = _split(self.layout)
        col = layout.column(heading="Tolerances (mm)")
        col.prop(settings, "cusp")
        col.prop(settings, "chord")
        col = layout.column(heading="Check")
        col.prop(settings, "verify")
        sub = col.column()
        sub.active = settings.verify
        sub.prop(settings, "verify_map")
