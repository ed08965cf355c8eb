"""``blisk_cam.export_nc``: the last generated paths → an NC program for the machine and
post of the "Machine & NC" panel (``core.nc.export_nc``: inverse kinematics within the
limits, rotary linearization, every blade, written atomically)."""

import bpy
from bpy.props import EnumProperty, StringProperty
from bpy_extras.io_utils import ExportHelper

from ..core.errors import BliskCamError
from ..core.post import POSTS
from .common import report_exception, result_blade_name, settings_of, stage_values


def nc_machine(settings):
    """The machine preset name or the absolute TOML path of the settings."""
    if settings.machine != "FILE":
        return settings.machine
    if not settings.machine_file:
        raise BliskCamError("Machine is 'TOML File' but no machine file is given: choose one "
                            "in the Machine & NC panel")
    return bpy.path.abspath(settings.machine_file)


def unresolved_collisions(path) -> int:
    """Poses of ``path`` reported as unresolved collisions (0 when not checked)."""
    summary = getattr(path, "collision", None) or {}
    return int(summary.get("unresolved", 0) or 0)


class BLISKCAM_OT_export_nc(bpy.types.Operator, ExportHelper):
    """Post the generated tool paths as an NC program for the chosen machine and controller"""

    bl_idname = "blisk_cam.export_nc"
    bl_label = "Export NC"
    bl_options = {"REGISTER"}

    filename_ext = ".nc"
    filter_glob: StringProperty(default="*.nc;*.ngc;*.mpf;*.h;*.apt;*.cls", options={"HIDDEN"})
    post: EnumProperty(
        name="Post", default="PANEL",
        items=[("PANEL", "As in the Panel", "The post chosen in the Machine & NC panel")]
        + [(p, p, f"NC program for {p}") for p in POSTS])
    machine: StringProperty(name="Machine", default="",
                            description="Preset name or TOML file (empty: as in the panel)")

    @classmethod
    def poll(cls, context):
        if settings_of(context) is None:
            cls.poll_message_set("Blisk CAM settings are missing: enable the add-on")
            return False
        if result_blade_name(context) is None:
            cls.poll_message_set("No generated paths: press Generate Paths first")
            return False
        return True

    def execute(self, context):
        from ..core.nc import export_nc
        from ..core.paths_io import path_from_dict
        from ..core.post.blocks import NcOptions
        from ..output import stored_paths_json

        settings = settings_of(context)
        try:
            import json

            name = result_blade_name(context)
            text = stored_paths_json(name) if name else None
            if text is None:
                raise BliskCamError("No generated paths: press Generate Paths first")
            path = path_from_dict(json.loads(text))
            n = unresolved_collisions(path)
            if n and not settings.export_anyway:
                raise BliskCamError(
                    f"{n} pose(s) are unresolved collisions: the program could crash the "
                    "machine. Correct them (Check Collisions, avoid) or tick Export Anyway")
            if not self.filepath:
                raise BliskCamError("No file name given for the NC program")
            filename = bpy.path.abspath(self.filepath)
            if filename.startswith("//"):
                raise BliskCamError(f"'{self.filepath}' is relative to the .blend file, which "
                                    "is not saved: save the .blend first or give an absolute "
                                    "path")
            post = settings.post if self.post == "PANEL" else self.post
            machine = self.machine or nc_machine(settings)
            options = NcOptions(**stage_values(settings, NcOptions), blade_name=name)
            report = export_nc(path, machine, post, options, filename)
            if report.interpolation is not None:  # the blocks, coloured by measured error
                from ..core.interpolation import block_segments
                from ..output import write_block_error_object

                write_block_error_object(context.scene, name, *block_segments(
                    report.interpolation))
        except Exception as exc:
            return report_exception(self, exc)
        self.report({"INFO"}, report.summary())
        return {"FINISHED"}
