"""The input panels: "Setup" (blade, axis, fit cones), "Region" (cones), "Tool" and
"Tolerances" — the scene settings (``scene.blisk_cam``)."""

from bpy.types import Panel

from ..core.options import (
    AxisOptions,
    CutterOptions,
    GougeOptions,
    LinkingOptions,
    ToleranceOptions,
    fields,
)

CATEGORY = "Blisk CAM"


class _BliskCamPanel:
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = CATEGORY

    @classmethod
    def poll(cls, context):
        return getattr(context.scene, "blisk_cam", None) is not None


def _is_shown(settings, stage, spec) -> bool:
    """Whether the option's ``show_if`` condition holds for the current settings."""
    if spec.show_if is None:
        return True
    other, values = spec.show_if
    other_spec = dict((n, sp) for n, sp, _ in fields(stage))[other]
    current = getattr(settings, other_spec.prop_name(other))
    if other_spec.choices is not None and not isinstance(current, bool):
        return current in {other_spec.choice(v).blender_id for v in values}
    return current in values


def draw_stage(layout, settings, stage, heading=None):
    """One row per Blender-declared option of ``stage`` (:mod:`blisk_cam.core.options`), in
    declaration order; a row whose ``show_if`` does not hold is greyed out. Returns the
    column (hand-made rows of the stage can follow)."""
    col = layout.column(heading=heading) if heading else layout.column()
    for name, spec, _ in fields(stage):
        if not spec.blender:
            continue
        row = col.column()
        row.active = _is_shown(settings, stage, spec)
        row.prop(settings, spec.prop_name(name))
    return col


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
        from ..blender.units import scene_units_problem

        problem = scene_units_problem(context.scene)
        if problem:  # e.g. an STL in a metre scene shows Rotor 37 as 82 m wide
            box = layout.box()
            box.label(text=problem, icon="ERROR")
            box.operator("blisk_cam.set_scene_mm", icon="DRIVER_DISTANCE")
        col = layout.column()
        col.prop(settings, "blade")
        active = getattr(context, "active_object", None)
        if settings.blade is None and active is not None:
            col.label(text=f"Using the active object '{active.name}'", icon="INFO")
        col.prop(settings, "axis_object")
        if settings.axis_object is None:
            col.label(text="Axis: the blade's world Z through its origin", icon="INFO")
        layout.prop(settings, "fit_generatrix")
        layout.operator("blisk_cam.fit_cones", icon="MESH_CONE")
        if settings.fit_residual1 >= 0.0 and settings.fit_residual2 >= 0.0:
            layout.label(
                text=f"Fit residual: hub {settings.fit_residual1:.4f} mm, "
                f"tip {settings.fit_residual2:.4f} mm"
            )


def _profile_points(text: str) -> int:
    """Number of points of a stored profile JSON (0: none or unreadable; the operators
    report what is wrong)."""
    if not text:
        return 0
    import json

    try:
        return len(json.loads(text))
    except (TypeError, ValueError):
        return 0


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
        for k in (1, 2):
            points = _profile_points(getattr(settings, f"profile{k}"))
            if points:
                layout.label(text=f"Cone {k} is a profile of {points} points (editing the "
                             "numbers replaces it)", icon="CURVE_PATH")
        row = layout.row(heading="Gizmos")
        row.prop(settings, "show_gizmos", text="Show")
        sub = row.row()
        sub.active = settings.show_gizmos
        sub.prop(settings, "live_preview")


class BLISKCAM_PT_tool(_BliskCamPanel, Panel):
    """Cutter, tool axis (orientation) and linking."""

    bl_idname = "BLISKCAM_PT_tool"
    bl_label = "Tool"

    def draw(self, context):
        settings = context.scene.blisk_cam
        layout = _split(self.layout)
        draw_stage(layout, settings, CutterOptions)
        col = draw_stage(layout, settings, AxisOptions, heading="Tool Axis")
        mode = settings.axis_mode
        angles = mode in {"LOCAL", "RADIAL"}
        sub = col.column()
        sub.active = angles
        sub.prop(settings, "vary_lead_tilt")
        tip = sub.column()
        tip.active = angles and settings.vary_lead_tilt
        tip.prop(settings, "lead_tip")
        if mode != "RADIAL":
            tip.prop(settings, "tilt_tip")
        if mode in {"TOWARD_POINT", "FROM_POINT"}:
            col.prop(settings, "axis_point")
        sub = draw_stage(col, settings, GougeOptions)
        sub.active = mode == "LOCAL"
        draw_stage(layout, settings, LinkingOptions, heading="Linking")


class BLISKCAM_PT_tolerances(_BliskCamPanel, Panel):
    """Cusp and chord tolerances, verification."""

    bl_idname = "BLISKCAM_PT_tolerances"
    bl_label = "Tolerances"

    def draw(self, context):
        settings = context.scene.blisk_cam
        layout = _split(self.layout)
        draw_stage(layout, settings, ToleranceOptions, heading="Tolerances (mm)")
        col = layout.column(heading="Check")
        col.prop(settings, "verify")
        sub = col.column()
        sub.active = settings.verify
        sub.prop(settings, "verify_map")
