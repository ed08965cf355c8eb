"""``blisk_cam.export_nc``: the last generated paths → an NC program for the machine and
post of the "Machine & NC" panel (``core.post.export.export_nc``: inverse kinematics within the
limits, rotary linearization, every blade, written atomically)."""

import bpy
from bpy.props import EnumProperty, StringProperty
from bpy_extras.io_utils import ExportHelper

from ..blender.settings import nc_options
from ..core.errors import BliskCamError
from ..core.post.export import POSTS
from .common import (
    output_filename,
    poll_generated_paths,
    read_blade,
    report_exception,
    result_blade_name,
    settings_of,
    stored_path,
)


def nc_machine(settings):
    """The machine preset name or the absolute TOML path of the settings."""
    if settings.machine != "FILE":
        return settings.machine
    if not settings.machine_file:
        raise BliskCamError("Machine is 'TOML File' but no machine file is given: choose one "
                            "in the Machine & NC panel")
    return bpy.path.abspath(settings.machine_file)


def loaded_machine(settings, name=None):
    """The core Machine of the settings (``name``: a preset or TOML instead of the panel's),
    with the panel's Part Origin when it is set."""
    from dataclasses import replace

    import numpy as np

    from ..core.machine.description import load_machine

    machine = load_machine(name or nc_machine(settings))
    if settings.use_part_origin:
        machine = replace(machine, part_origin=np.array([float(x) for x in
                                                         settings.part_origin]))
    return machine


def _part_mesh(context, name, options):
    """The blade's mesh for constant-error interpolation (it budgets the planned path's own
    deviation from the part, issue 28); None otherwise or when the blade is gone (the path's
    chord tolerance is budgeted then)."""
    if options.interpolation != "constant-error":
        return None
    blade = bpy.data.objects.get(name) if name else None
    if blade is None or blade.type != "MESH":
        return None
    from ..core.geometry.mesh import TriMesh

    V, F = read_blade(context, blade)
    return TriMesh.from_arrays(V, F)


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
        return poll_generated_paths(cls, context)

    def execute(self, context):
        from ..core.post.export import export_nc

        settings = settings_of(context)
        try:
            name = result_blade_name(context)
            path = stored_path(name)
            filename = output_filename(self.filepath, "NC program")
            post = settings.post if self.post == "PANEL" else self.post
            machine = loaded_machine(settings, self.machine or None)
            # the collision gate of every export (core/post/gate.py) refuses unresolved
            # collisions unless Export Anyway is ticked, and then marks them in the header
            options = nc_options(settings, blade_name=name,
                                 allow_collisions=bool(settings.export_anyway))
            report = export_nc(path, machine, post, options, filename,
                               part=_part_mesh(context, name, options))
            if report.interpolation is not None:  # the blocks, coloured by measured error
                from ..blender.collision_objects import write_block_error_object
                from ..core.machine.interpolation import block_segments

                write_block_error_object(context.scene, name, *block_segments(
                    report.interpolation))
        except Exception as exc:
            return report_exception(self, exc)
        if report.gate.warning:
            self.report({"WARNING"}, report.gate.warning)
        self.report({"INFO"}, report.summary())
        return {"FINISHED"}
