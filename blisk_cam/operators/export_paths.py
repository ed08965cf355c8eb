"""``blisk_cam.export_paths``: write the last generated paths as the paths JSON."""

import os

import bpy
from bpy.props import StringProperty
from bpy_extras.io_utils import ExportHelper

from ..core.errors import BliskCamError
from ..core.files import write_atomic
from .common import output_filename, poll_generated_paths, report_exception, result_blade_name


def write_text_atomically(text: str, filename: str) -> str:
    """Write ``text`` to a temporary file beside ``filename`` and rename it into place (a
    failure never leaves a half-written file). Returns the absolute file name."""
    filename = os.path.abspath(filename)
    try:
        write_atomic(filename, text)
    except OSError as exc:
        raise BliskCamError(f"cannot write {filename}: {exc.strerror or exc}") from None
    return filename


class BLISKCAM_OT_export_paths(bpy.types.Operator, ExportHelper):
    """Write the generated tool paths as a paths JSON file (mm)"""

    bl_idname = "blisk_cam.export_paths"
    bl_label = "Export Paths JSON"
    bl_options = {"REGISTER"}

    filename_ext = ".json"
    filter_glob: StringProperty(default="*.json", options={"HIDDEN"})

    @classmethod
    def poll(cls, context):
        return poll_generated_paths(cls, context)

    def execute(self, context):
        from ..blender.path_objects import stored_paths_json

        try:
            name = result_blade_name(context)
            text = stored_paths_json(name) if name else None
            if text is None:
                raise BliskCamError("No generated paths: press Generate Paths first")
            written = write_text_atomically(text, output_filename(self.filepath,
                                                                  "paths JSON"))
        except Exception as exc:
            return report_exception(self, exc)
        self.report({"INFO"}, f"Wrote {written}")
        return {"FINISHED"}
