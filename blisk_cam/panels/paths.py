"""The output panels: "Paths" (generate, clear, export, statistics) with its "Display"
sub-panel, and "Preview" (render)."""

from bpy.types import Panel

from .setup import _BliskCamPanel, _split


def _duration(minutes: float) -> str:
    seconds = int(round(minutes * 60.0))
    h, rest = divmod(seconds, 3600)
    m, s = divmod(rest, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m}:{s:02d}"


class BLISKCAM_PT_paths(_BliskCamPanel, Panel):
    """Generate, clear and export the tool paths; statistics of the last result."""

    bl_idname = "BLISKCAM_PT_paths"
    bl_label = "Paths"

    def draw(self, context):
        from ..operators.common import blade_problem, cones_problem
        from ..operators.generate_paths import verify_pending

        settings = context.scene.blisk_cam
        layout = self.layout
        col = layout.column(align=True)
        col.scale_y = 1.3
        col.operator("blisk_cam.generate_paths", icon="PLAY")
        problem = blade_problem(context) or cones_problem(settings)
        if problem:
            box = layout.box()
            for k, line in enumerate(_wrap(problem, 40)):
                box.label(text=line, icon="ERROR" if k == 0 else "BLANK1")
        row = layout.row(align=True)
        row.operator("blisk_cam.clear_paths", icon="TRASH")
        row.operator("blisk_cam.export_paths", icon="EXPORT")

        if not settings.has_result:
            layout.label(text="No paths generated yet")
            return
        box = layout.box()
        col = box.column(align=True)
        col.label(text=f"Blade: {settings.stat_blade}")
        col.label(text=f"{settings.stat_passes} passes, {settings.stat_curves} curves")
        col.label(text=f"{settings.stat_poses} poses, {settings.stat_length:.1f} mm")
        if settings.stat_link_length or settings.stat_rapid_length:
            col.label(text=f"Links {settings.stat_link_length:.1f} mm, "
                      f"rapids {settings.stat_rapid_length:.1f} mm")
        feed_length = settings.stat_length + settings.stat_link_length
        minutes = feed_length / max(settings.feed, 1e-9)
        col.label(text=f"Machining time {_duration(minutes)} at {settings.feed:g} mm/min")
        if settings.stat_warnings:
            col.label(text=f"{settings.stat_warnings} warning(s): see the Info log",
                      icon="ERROR")
        col.label(text=f"Cusp (generator): {settings.stat_cusp:.4f} mm")
        if verify_pending(context.scene.name):
            col.label(text="Verifying… (ESC skips it)", icon="TIME")
        elif settings.stat_verified:
            if settings.stat_verdict:
                col.label(text=f"Verify: {settings.stat_verdict}",
                          icon="CHECKMARK" if settings.stat_verdict == "PASS" else "ERROR")
            col.label(text=f"Measured max material left: {settings.stat_material_left:.4f} mm")
            col.label(text=f"Measured max gouge: {settings.stat_gouge:.4f} mm")
        else:
            col.label(text="Not verified (turn on Tolerances › Verify)")
        _split(box).prop(settings, "feed")  # the NC program's cutting feed (Machine & NC)


def _wrap(text, width):
    words, lines, line = text.split(), [], ""
    for w in words:
        if line and len(line) + 1 + len(w) > width:
            lines.append(line)
            line = w
        else:
            line = f"{line} {w}" if line else w
    return [*lines, line] if line else lines


class BLISKCAM_PT_display(_BliskCamPanel, Panel):
    """Display options of the path objects."""

    bl_idname = "BLISKCAM_PT_display"
    bl_label = "Display"
    bl_parent_id = "BLISKCAM_PT_paths"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        settings = context.scene.blisk_cam
        layout = _split(self.layout)
        col = layout.column()
        col.prop(settings, "pose_count")
        col.prop(settings, "curve_bevel")
        col.prop(settings, "color_mode")


class BLISKCAM_PT_preview(_BliskCamPanel, Panel):
    """Render a still preview of the blade and its paths."""

    bl_idname = "BLISKCAM_PT_preview"
    bl_label = "Preview"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        settings = context.scene.blisk_cam
        layout = _split(self.layout)
        layout.prop(settings, "preview_path")
        layout.prop(settings, "preview_engine")
        op = layout.operator("blisk_cam.render_preview", icon="RENDER_STILL")
        op.filepath = settings.preview_path
        op.engine = settings.preview_engine


class BLISKCAM_PT_machine(_BliskCamPanel, Panel):
    """Machine, post and NC options; Export NC."""

    bl_idname = "BLISKCAM_PT_machine"
    bl_label = "Machine & NC"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        from ..core.post.blocks import NcOptions
        from .setup import draw_stage

        settings = context.scene.blisk_cam
        layout = _split(self.layout)
        col = layout.column()
        col.prop(settings, "machine")
        if settings.machine == "FILE":
            col.prop(settings, "machine_file")
        col.prop(settings, "post")
        col.prop(settings, "use_part_origin")
        sub = col.column()
        sub.active = settings.use_part_origin
        sub.prop(settings, "part_origin", text="")
        col = draw_stage(layout, settings, NcOptions, heading="Program")
        # the one Blade Count of the scene (also in the Collisions panel): the program is
        # repeated for every blade; 0 (not set): the one blade
        col.prop(settings, "blade_count")
        layout.prop(settings, "export_anyway")
        layout.operator("blisk_cam.export_nc", icon="EXPORT")
        row = layout.row(align=True)
        row.operator("blisk_cam.animate_program", text="Animate (Part)",
                     icon="PLAY").view = "PART"
        row.operator("blisk_cam.animate_program", text="Animate (Machine)",
                     icon="ORIENTATION_GIMBAL").view = "MACHINE"
