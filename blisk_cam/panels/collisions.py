"""The "Collisions" panel: the collision options (drawn from their one declaration, core
``CollisionOptions``), the holder and obstacles, Check Collisions, the counts and the worst
clearance of the last check (the stored summary), Next Unresolved Pose."""

from bpy.types import Panel

from ..core.collision.options import CollisionOptions
from .setup import _BliskCamPanel, _split, draw_stage


class BLISKCAM_PT_collisions(_BliskCamPanel, Panel):
    """Collision check of holder, shank and flute against the blade, its neighbours and
    obstacles."""

    bl_idname = "BLISKCAM_PT_collisions"
    bl_label = "Collisions"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        from ..blender.collision_objects import collision_summary
        from ..operators.common import result_blade_name

        settings = context.scene.blisk_cam
        layout = _split(self.layout)
        col = draw_stage(layout, settings, CollisionOptions)
        col.prop(settings, "holder")
        col.prop(settings, "obstacles")
        row = layout.column(align=True)
        row.scale_y = 1.3
        row.operator("blisk_cam.check_collisions", icon="MOD_PHYSICS")
        name = result_blade_name(context)
        summary = collision_summary(name) if name else None
        if summary is None:
            layout.label(text="Paths not checked yet")
            return
        box = layout.box()
        col = box.column(align=True)
        col.label(text=f"Checked poses: {summary.get('checked_poses', 0)} "
                  f"({summary.get('mode', '?')})")
        col.label(text=f"Colliding before: {summary.get('colliding_before', 0)}")
        col.label(text=f"Corrected: {summary.get('corrected', 0)}")
        unresolved = int(summary.get("unresolved") or 0)
        col.label(text=f"Unresolved: {unresolved}", icon="ERROR" if unresolved else "CHECKMARK")
        worst = summary.get("min_clearance")
        if worst is not None:
            col.label(text=f"Worst clearance: {worst:.3f} mm "
                      f"(safety {summary.get('safety', 0):g} mm)")
        text = summary.get("assembly_text")
        if text:
            col.label(text=text[:60])
        ranges = summary.get("unresolved_ranges") or []
        for r in ranges[:4]:  # the unresolved poses as ranges, with the reason
            col.label(text=f"Pass {r['pass']} poses {r['from']}–{r['to']}: {r['why']}"[:80],
                      icon="DOT")
        if len(ranges) > 4:
            col.label(text=f"… and {len(ranges) - 4} more range(s)")
        if summary.get("tool_hint"):
            col.label(text=summary["tool_hint"][:90], icon="INFO")
        if unresolved:
            layout.operator("blisk_cam.next_unresolved_pose", icon="CURSOR")
