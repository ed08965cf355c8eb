"""Editing the Operations panel's lists (issue 24): ``blisk_cam.operation_add``,
``blisk_cam.operation_remove``, ``blisk_cam.operation_move`` (up/down), ``blisk_cam.tool_add``
and ``blisk_cam.tool_remove``. Each is one undo step; the results of a run are not touched (the
next Generate All replaces them)."""

from __future__ import annotations

import bpy
from bpy.props import EnumProperty, StringProperty

__all__ = ["BLISKCAM_OT_operation_add", "BLISKCAM_OT_operation_move",
           "BLISKCAM_OT_operation_remove", "BLISKCAM_OT_tool_add", "BLISKCAM_OT_tool_remove"]


class _SelectedRow:
    """Mixin of the operators acting on the selected row of one of the settings' lists:
    ``rows`` names the collection, ``selected`` its index property."""

    rows = "operations"
    selected = "operation_index"

    @classmethod
    def poll(cls, context):
        s = getattr(context.scene, "blisk_cam", None)
        return s is not None and 0 <= getattr(s, cls.selected) < len(getattr(s, cls.rows))

    def remove_selected(self, context):
        s = context.scene.blisk_cam
        rows = getattr(s, self.rows)
        rows.remove(getattr(s, self.selected))
        setattr(s, self.selected, max(0, min(getattr(s, self.selected), len(rows) - 1)))
        return {"FINISHED"}


def _kinds(_self, _context):
    from ..properties import kind_items

    return kind_items(_self, _context)


class BLISKCAM_OT_operation_add(bpy.types.Operator):
    """Add an operation after the selected one (its tool: the selected tool of the table)"""

    bl_idname = "blisk_cam.operation_add"
    bl_label = "Add Operation"
    bl_options = {"REGISTER", "UNDO"}

    kind: EnumProperty(name="Kind", items=_kinds)
    name: StringProperty(name="Name", default="")

    def execute(self, context):
        from ..properties import sync_operation_options

        s = context.scene.blisk_cam
        op = s.operations.add()
        op.uid = s.job_next_uid
        s.job_next_uid += 1
        op.name = self.name or f"{self.kind.replace('_', ' ')} {len(s.operations)}"
        op.kind = self.kind
        sync_operation_options(op)
        if s.job_tools and 0 <= s.job_tool_index < len(s.job_tools):
            op.tool = s.job_tools[s.job_tool_index].number
        target = min(s.operation_index + 1, len(s.operations) - 1) if len(s.operations) > 1 \
            else 0
        s.operations.move(len(s.operations) - 1, target)
        s.operation_index = target
        return {"FINISHED"}


class BLISKCAM_OT_operation_remove(_SelectedRow, bpy.types.Operator):
    """Remove the selected operation"""

    bl_idname = "blisk_cam.operation_remove"
    bl_label = "Remove Operation"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        return self.remove_selected(context)


class BLISKCAM_OT_operation_move(_SelectedRow, bpy.types.Operator):
    """Move the selected operation up or down (the order the job runs them in)"""

    bl_idname = "blisk_cam.operation_move"
    bl_label = "Move Operation"
    bl_options = {"REGISTER", "UNDO"}

    direction: EnumProperty(items=[("UP", "Up", "Earlier in the job"),
                                   ("DOWN", "Down", "Later in the job")])

    def execute(self, context):
        s = context.scene.blisk_cam
        k = s.operation_index
        j = k - 1 if self.direction == "UP" else k + 1
        if not 0 <= j < len(s.operations):
            return {"CANCELLED"}
        s.operations.move(k, j)
        s.operation_index = j
        return {"FINISHED"}


class BLISKCAM_OT_tool_add(bpy.types.Operator):
    """Add a tool to the job's tool table (the next free T number)"""

    bl_idname = "blisk_cam.tool_add"
    bl_label = "Add Tool"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        s = context.scene.blisk_cam
        used = {t.number for t in s.job_tools}
        t = s.job_tools.add()
        t.number = next(n for n in range(1, len(used) + 2) if n not in used)
        s.job_tool_index = len(s.job_tools) - 1
        return {"FINISHED"}


class BLISKCAM_OT_tool_remove(_SelectedRow, bpy.types.Operator):
    """Remove the selected tool from the tool table"""

    bl_idname = "blisk_cam.tool_remove"
    bl_label = "Remove Tool"
    bl_options = {"REGISTER", "UNDO"}

    rows = "job_tools"
    selected = "job_tool_index"

    def execute(self, context):
        return self.remove_selected(context)
