"""The "Stock" panel: the part and the blank of the stock simulation (issue 22), its
resolution and gouge tolerance, Simulate, the last result's summary and the colour legend."""

from bpy.types import Panel

from .setup import _BliskCamPanel, _split


class BLISKCAM_PT_stock(_BliskCamPanel, Panel):
    """Material-removal simulation of the generated program on the blisk's stock."""

    bl_idname = "BLISKCAM_PT_stock"
    bl_label = "Stock"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        from ..blender.stock_objects import stock_summary
        from ..operators.simulate_stock import crash_line, summary_line

        settings = context.scene.blisk_cam
        layout = _split(self.layout)
        col = layout.column()
        col.prop(settings, "stock_part_source")
        if settings.stock_part_source == "MESH":
            col.prop(settings, "stock_part")
        else:
            col.prop(settings, "stock_hub_profile")
        col.prop(settings, "blade_count")
        col.prop(settings, "stock_blank")
        blank = settings.stock_blank
        col.prop(settings, {"ALLOWANCE": "stock_allowance", "ENVELOPE": "stock_margin",
                            "PROFILE": "stock_profile",
                            "MESH": "stock_blank_object"}[blank])
        col.prop(settings, "stock_resolution")
        col.prop(settings, "stock_gouge_tolerance")
        row = layout.column(align=True)
        row.scale_y = 1.3
        row.operator("blisk_cam.simulate_stock", icon="MOD_BOOLEAN")
        summary = stock_summary(context.scene)
        if summary is None:
            layout.label(text="Not simulated yet")
            return
        box = layout.box()
        col = box.column(align=True)
        for part in summary_line(summary).split("; "):
            col.label(text=part)
        crashes = crash_line(summary)
        if crashes:
            col.label(text=crashes[:90], icon="ERROR")
        legend = box.column(align=True)
        tol = summary["deviation_mm"]["gouge_tolerance"]
        legend.label(text=f"Blue: gouge deeper than {tol:.3f} mm", icon="COLOR_BLUE")
        legend.label(text=f"Green: within ±{tol:.3f} mm", icon="COLOR_GREEN")
        legend.label(text=f"Red: material left over {tol:.3f} mm", icon="COLOR_RED")
        legend.label(text="Grey: not judged (below the stock's resolution) or buried",
                     icon="RADIOBUT_OFF")
        legend.label(text="Viewport: Solid shading, Color Attribute (or Material Preview)",
                     icon="INFO")
