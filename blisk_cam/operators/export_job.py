"""``blisk_cam.export_job``: the Operations panel's job written as the job file that
``python -m blisk_cam process JOB.toml --out DIR`` reads (``core.process.job_toml``), checked
by the core's reader first (a job the command would refuse is not written), written atomically,
and never over an existing file unless Replace Existing is ticked."""

from __future__ import annotations

import os

import bpy
from bpy.props import BoolProperty, StringProperty
from bpy_extras.io_utils import ExportHelper

from ..core.errors import BliskCamError
from .common import report_exception

__all__ = ["BLISKCAM_OT_export_job"]


class BLISKCAM_OT_export_job(bpy.types.Operator, ExportHelper):
    """Write the operations, the tool table, the part, stock and machine as a job file (TOML)
    for `blisk_cam process`"""

    bl_idname = "blisk_cam.export_job"
    bl_label = "Export Job"
    bl_options = {"REGISTER"}

    filename_ext = ".toml"
    filter_glob: StringProperty(default="*.toml", options={"HIDDEN"})
    overwrite: BoolProperty(name="Replace Existing", default=False,
                            description="Replace the file when it exists")

    @classmethod
    def poll(cls, context):
        s = getattr(context.scene, "blisk_cam", None)
        if s is None or not len(s.operations):
            cls.poll_message_set("Add an operation first")
            return False
        return True

    def execute(self, context):
        from ..core.files import write_atomic
        from ..core.process.job import job_from_data
        from ..core.process.job_toml import job_toml
        from .job_scene import job_data

        try:
            filename = bpy.path.abspath(self.filepath)
            if not filename or os.path.isdir(filename):
                raise BliskCamError("Export Job: give a file name (JOB.toml)")
            if os.path.exists(filename) and not self.overwrite:
                raise BliskCamError(f"{filename} exists: tick Replace Existing to replace it, or "
                                    "choose another name")
            data = job_data(context.scene)
            job_from_data(data, filename)  # what `process` would refuse is not written
            write_atomic(filename, job_toml(data, "Blisk CAM job (Operations panel); run it "
                                                  "with: python -m blisk_cam process JOB.toml "
                                                  "--out DIR"))
        except Exception as exc:
            return report_exception(self, exc)
        self.report({"INFO"}, f"Job written to {filename}")
        return {"FINISHED"}
