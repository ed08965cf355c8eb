"""The "Per-Blade Paths" panel: a whole-blisk scan planned blade by blade (the scan, the one
Blade Count of the scene, the neighbours checked per side; the path options are those of the
panels above), Per-Blade Paths, Load Results of a batch run, and what became of every blade
(shown, or failed with its reason)."""

from bpy.types import Panel

from .setup import _BliskCamPanel, _split

#: failed blades listed by reason in the panel (the rest counted)
MAX_FAILED_SHOWN = 6


class BLISKCAM_PT_per_blade(_BliskCamPanel, Panel):
    """Every blade of a whole-blisk scan gets its own path from its own faces."""

    bl_idname = "BLISKCAM_PT_per_blade"
    bl_label = "Per-Blade Paths"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        from ..blender.per_blade_objects import per_blade_summary

        settings = context.scene.blisk_cam
        layout = _split(self.layout)
        col = layout.column()
        col.prop(settings, "per_blade_scan")
        col.prop(settings, "blade_count", text="Blade Count (0: found)")
        col.prop(settings, "neighbours", text="Neighbours per Side")
        col.prop(settings, "verify")
        layout.label(text="Tool, tolerances, lead/tilt: the panels above", icon="INFO")
        row = layout.column(align=True)
        row.scale_y = 1.3
        row.operator("blisk_cam.per_blade_paths", icon="MOD_ARRAY")
        col = layout.column(align=True)
        col.prop(settings, "per_blade_folder")
        col.operator("blisk_cam.load_blade_results", icon="FILE_FOLDER")
        summary = per_blade_summary()
        if summary is None:
            return
        box = layout.box()
        col = box.column(align=True)
        shown = summary.get("shown", [])
        col.label(text=f"{summary.get('source', '?')}: {len(shown)} of "
                  f"{summary.get('blade_count', '?')} blades with paths",
                  icon="CHECKMARK" if not summary.get("failed") else "ERROR")
        failed = summary.get("failed", [])
        for _, reason in failed[:MAX_FAILED_SHOWN]:
            col.label(text=reason[:90], icon="DOT")
        if len(failed) > MAX_FAILED_SHOWN:
            col.label(text=f"… and {len(failed) - MAX_FAILED_SHOWN} more failed blade(s)")
