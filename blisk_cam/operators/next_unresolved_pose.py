"""``blisk_cam.next_unresolved_pose``: put the 3D cursor on the next pose that still collides
(:func:`blisk_cam.core.collision.report.next_unresolved`, after the one the cursor is on; the
cursor's Z turns along the tool axis) and, with a window, centre the 3D views on it."""

from __future__ import annotations

import bpy

from .common import report_exception, result_blade_name, stored_path


def _unresolved_count(blade_name):
    from ..blender.collision_objects import collision_summary

    s = collision_summary(blade_name) if blade_name else None
    return int(s.get("unresolved") or 0) if s else 0


class BLISKCAM_OT_next_unresolved_pose(bpy.types.Operator):
    """Move the 3D cursor (and the view) to the next pose whose collision is unresolved"""

    bl_idname = "blisk_cam.next_unresolved_pose"
    bl_label = "Next Unresolved Pose"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        name = result_blade_name(context)
        if name is None:
            cls.poll_message_set("No generated paths: press Generate Paths, then Check "
                                 "Collisions")
            return False
        if _unresolved_count(name) == 0:
            cls.poll_message_set("No unresolved collision (or the paths are not checked)")
            return False
        return True

    def execute(self, context):
        from mathutils import Vector

        from ..blender.objects import mm_per_blender_unit
        from ..core.collision.report import next_unresolved
        from ..core.errors import BliskCamError

        try:
            name = result_blade_name(context)
            path = stored_path(name)
            f = mm_per_blender_unit(context.scene)
            cursor = context.scene.cursor
            found = next_unresolved(path, [c * f for c in cursor.location])
            if found is None:
                raise BliskCamError(f"no unresolved collision in the paths of '{name}'")
        except Exception as exc:
            return report_exception(self, exc)
        tip, axis, row, k, n = found
        cursor.location = Vector(tip / f)
        cursor.rotation_mode = "QUATERNION"
        cursor.rotation_quaternion = Vector(axis).to_track_quat("Z", "Y")
        screen = getattr(context, "screen", None)
        if context.window is not None and screen is not None:
            for area in screen.areas:
                if area.type == "VIEW_3D":
                    r3d = area.spaces.active.region_3d
                    if r3d is not None:
                        r3d.view_location = cursor.location
                    area.tag_redraw()
        self.report({"INFO"}, f"Unresolved pose {k + 1} of {n} (program row {row})")
        return {"FINISHED"}
