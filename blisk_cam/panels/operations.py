"""The "Operations" panel (issue 24): the whole blisk as one job — the part, the operations in
order (add, remove, reorder, enable; each one's kind, tool and the options its kind declares),
the tool table, Generate All and Export Job. The blank, the stock resolution and the machine
are the Stock and Machine & NC panels' ones."""

from bpy.types import Panel, UIList

from .setup import _BliskCamPanel, _split


class BLISKCAM_UL_operations(UIList):
    """The operations in the order the job runs them."""

    def draw_item(self, _context, layout, _data, item, _icon, _active_data, _active_prop,
                  index=0, _flt_flag=0):
        row = layout.row(align=True)
        row.prop(item, "enabled", text="")
        sub = row.row(align=True)
        sub.active = item.enabled
        sub.label(text=f"{index + 1}.")
        sub.prop(item, "name", text="", emboss=False)
        sub.label(text=f"{item.kind} T{item.tool}")


class BLISKCAM_UL_job_tools(UIList):
    """The job's tool table."""

    def draw_item(self, _context, layout, _data, item, _icon, _active_data, _active_prop,
                  _index=0, _flt_flag=0):
        shape = {"ball": "ball", "bull": f"R{item.corner_radius:g} bull nose", "flat": "flat",
                 "taper": "taper"}[item.type]
        layout.label(text=f"T{item.number}  Ø{item.diameter:g} {shape}, {item.flutes} flutes")


def _draw_options(layout, op):
    from ..core.process.operation_kinds import OPERATION_KINDS

    kind = OPERATION_KINDS.get(op.kind)
    if kind is None:
        layout.label(text=f"Kind {op.kind!r} is not in this build", icon="ERROR")
        return
    rows = {o.key: o for o in op.options}
    col = layout.column(align=True)
    for key, (default, _help) in kind.options.items():
        row = rows.get(key)
        if row is None:  # declared after the operation was made: re-choose the kind
            col.label(text=f"{key}: choose the kind again to edit it", icon="INFO")
            continue
        shown = "—" if default is None else (f"{default:g}" if isinstance(default, float)
                                             else str(default))
        col.prop(row, "value", text=f"{key} ({shown})")


class BLISKCAM_PT_operations(_BliskCamPanel, Panel):
    """The blisk as one job: operations in order on the stock, a tool table, one program."""

    bl_idname = "BLISKCAM_PT_operations"
    bl_label = "Operations"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        s = context.scene.blisk_cam
        layout = self.layout
        col = _split(layout.column())
        col.prop(s, "job_part_source")
        if s.job_part_source == "DEMO":
            col.prop(s, "job_demo_resolution")
        else:
            col.prop(s, "job_part_file")
            col.prop(s, "job_hub_profile")
            col.prop(s, "blade_count")
        col.prop(s, "job_material")
        row = layout.row()
        row.template_list("BLISKCAM_UL_operations", "", s, "operations", s,
                          "operation_index", rows=4)
        side = row.column(align=True)
        side.operator_menu_enum("blisk_cam.operation_add", "kind", text="", icon="ADD")
        side.operator("blisk_cam.operation_remove", text="", icon="REMOVE")
        side.separator()
        side.operator("blisk_cam.operation_move", text="", icon="TRIA_UP").direction = "UP"
        side.operator("blisk_cam.operation_move", text="", icon="TRIA_DOWN").direction = "DOWN"
        if 0 <= s.operation_index < len(s.operations):
            op = s.operations[s.operation_index]
            box = _split(layout.box())
            box.prop(op, "kind")
            box.prop(op, "tool")
            if op.tool not in {t.number for t in s.job_tools}:
                box.label(text=f"T{op.tool} is not in the tool table", icon="ERROR")
            _draw_options(box, op)
            if op.result:
                for part in op.result.split("; "):
                    box.label(text=part, icon="INFO")
        col = layout.column(align=True)
        col.scale_y = 1.3
        col.operator("blisk_cam.generate_all", icon="PLAY")
        layout.operator("blisk_cam.export_job", icon="EXPORT")


class BLISKCAM_PT_tool_table(_BliskCamPanel, Panel):
    """The job's tools: T number, cutter, flutes, flute length, holder."""

    bl_idname = "BLISKCAM_PT_tool_table"
    bl_label = "Tool Table"
    bl_parent_id = "BLISKCAM_PT_operations"

    def draw(self, context):
        s = context.scene.blisk_cam
        layout = self.layout
        row = layout.row()
        row.template_list("BLISKCAM_UL_job_tools", "", s, "job_tools", s, "job_tool_index",
                          rows=3)
        side = row.column(align=True)
        side.operator("blisk_cam.tool_add", text="", icon="ADD")
        side.operator("blisk_cam.tool_remove", text="", icon="REMOVE")
        if 0 <= s.job_tool_index < len(s.job_tools):
            t = s.job_tools[s.job_tool_index]
            col = _split(layout.column())
            for name in ("number", "type", "diameter"):
                col.prop(t, name)
            if t.type == "bull":
                col.prop(t, "corner_radius")
            for name in ("flutes", "flute_length", "stick_out", "holder"):
                col.prop(t, name)
