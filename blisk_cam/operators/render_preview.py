"""``blisk_cam.render_preview``: a still PNG of the blade and its paths (``render.py``)."""

import bpy
from bpy.props import (
    BoolProperty,
    EnumProperty,
    FloatVectorProperty,
    IntVectorProperty,
    StringProperty,
)

from ..core.errors import BliskCamError
from ..properties import PREVIEW_ENGINES
from .common import (
    blade_axis,
    read_blade,
    report_exception,
    resolve_blade,
    result_blade_name,
    settings_of,
)


def _framed_objects(context, frame):
    """(objects the camera frames, path curves to thicken for the render): the blade (its
    paths lie on it; a curve only offers its loose bounding box), or every visible object."""
    from ..blender.path_objects import find_output_collection, output_objects

    if frame == "PATHS":
        blade = resolve_blade(context)
        name = result_blade_name(context)
        objs = output_objects(find_output_collection(name)) if name else {}
        curves = [objs[k] for k in ("cc", "tip") if objs.get(k) is not None]
        if blade is not None and blade.type == "MESH" and not blade.hide_render:
            return [blade], curves
        shown = [ob for ob in curves if not ob.hide_render]
        if shown:
            return shown, curves
    from ..blender.render import default_objects

    scene = context.scene
    curves = [ob for ob in scene.objects if ob.type == "CURVE"]
    return default_objects(scene), curves


def _pressure_side_view(context):
    """Direction toward a camera facing the blade's pressure (concave) side, or None (no
    blade, or sides that cannot be told apart: the fixed default view is used)."""
    from ..core.display import pressure_side_view

    blade = resolve_blade(context)
    if blade is None or blade.type != "MESH":
        return None
    try:
        V, F = read_blade(context, blade)
        return tuple(float(x) for x in pressure_side_view(V, F, blade_axis(settings_of(context),
                                                                          blade)))
    except BliskCamError:
        return None


def _result_legends(context, name, tol):
    """Legends of what else the picture shows in colour: the collision status of the pose
    markers (when the checked poses render) with the count of each, and the verify map's
    colours (when it renders); names and colours from ``core.display``."""
    from ..blender import path_objects as output
    from ..blender import render
    from ..blender.render_styles import pose_status_counts
    from ..core.display import COLLISION_STATUS_NAMES, COLLISION_STATUS_RGBA, verify_legend

    objs = output.output_objects(output.find_output_collection(name)) if name else {}
    out = []
    poses = objs.get("poses")
    counts = None
    if poses is not None and not poses.hide_render and poses.visible_get():
        counts = pose_status_counts(poses)
    if counts is not None:
        out.append(render.Legend("pose collision status:", entries=tuple(
            (f"{label} {int(n)}" + (" (unmarked)" if k == 0 else ""), rgba)
            for k, (label, rgba, n) in enumerate(zip(COLLISION_STATUS_NAMES,
                                                     COLLISION_STATUS_RGBA, counts,
                                                     strict=True)))))
    ver = objs.get("verify")
    if ver is not None and not ver.hide_render and ver.visible_get():
        out.append(render.Legend("material left:", entries=tuple(
            verify_legend(float(tol["cusp"]), float(tol["chord"])))))
    return out


def _annotation(context):
    """(title line, [:class:`render.Legend`]) of the current result: the blade, the tool
    ("Ø12 ball"), the tolerances and the pass count from the stored paths JSON (else the
    settings), what the path colours mean in the current colour mode, and the legends of the
    collision statuses and the verify map when they show."""
    import json

    import numpy as np

    from ..blender import path_objects as output
    from ..blender import render

    settings = context.scene.blisk_cam
    name = result_blade_name(context)
    data = {}
    if name:
        text = output.stored_paths_json(name)
        if text:
            try:
                data = json.loads(text)
            except ValueError:
                data = {}
    blade = name or (settings.blade.name if settings.blade is not None else "")
    tool = data.get("tool") or {"type": settings.tool_type.lower(),
                                "radius": float(settings.tool_radius),
                                "corner_radius": float(settings.corner_radius)}
    tol = data.get("tolerances") or {"cusp": float(settings.cusp), "chord": float(settings.chord)}
    parts = [blade, render.tool_label(tool),
             f"cusp {float(tol['cusp']):g} mm, chord {float(tol['chord']):g} mm"]
    n = (data.get("stats") or {}).get("passes")
    if n:
        parts.append(f"{int(n)} passes")
    title = "   ·   ".join(p for p in parts if p)
    mode = settings.color_mode
    t = (np.arange(output.COLOR_BINS) + 0.5) / output.COLOR_BINS
    ramp = tuple((*rgb, 1.0) for rgb in output._ramp(t))
    if mode == "MORPH":
        legend = render.Legend("path colour: pass ratio s (cone 1 → cone 2)", ramp,
                               "0 hub", "1 tip")
    elif mode == "CUSP":
        legend = render.Legend("path colour: measured cusp between passes", ramp, "0",
                               f"{float(tol['cusp']):g} mm")
    else:
        legend = render.Legend("path colour: tool path (CC points)", (output.SOLID_RGBA,))
    return title, [legend, *_result_legends(context, name, tol)]


class BLISKCAM_OT_render_preview(bpy.types.Operator):
    """Render a still preview (PNG) of the blade and its tool paths, camera auto-framed"""

    bl_idname = "blisk_cam.render_preview"
    bl_label = "Render Preview"
    bl_options = {"REGISTER", "UNDO"}

    filepath: StringProperty(
        name="File", description="PNG to write (default: the Preview File setting)",
        default="", subtype="FILE_PATH",
    )
    engine: EnumProperty(name="Engine", items=PREVIEW_ENGINES, default="AUTO")
    resolution: IntVectorProperty(name="Resolution", size=2, default=(1280, 720), min=16,
                                  max=8192)
    frame: EnumProperty(
        name="Frame",
        items=(("PATHS", "Blade and Paths", "Frame the blade and its path curves"),
               ("SCENE", "Scene", "Frame every visible object")),
        default="PATHS",
    )
    view: FloatVectorProperty(
        name="View", description="Direction from the subject toward the camera (world)",
        size=3, default=(1.0, -0.8, 0.55),
    )
    keep_camera: BoolProperty(
        name="Keep Camera", description="Leave the preview camera as the scene camera",
        default=False,
    )
    annotate: BoolProperty(
        name="Title and Legend",
        description="Draw a title line (blade, tool, tolerances), a colour legend and a scale "
        "bar into the picture",
        default=True,
    )
    neighbours: EnumProperty(
        name="Neighbours",
        items=(("CUT", "Cut Away", "Only the parts of the neighbour blades that do not hide "
                "the blade; the cut part as a thin outline"),
               ("HIDDEN", "Hidden", "No neighbour blades in the picture"),
               ("FULL", "Full", "The neighbour blades as in the viewport")),
        default="CUT",
    )
    holder: EnumProperty(
        name="Tool Assembly",
        items=(("OUTLINE", "Outline", "The tool assembly at the worst pose as thin lines"),
               ("HIDDEN", "Hidden", "No tool assembly in the picture"),
               ("FULL", "Full", "The tool assembly as in the viewport")),
        default="OUTLINE",
    )
    cones: EnumProperty(
        name="Cones",
        items=(("OUTLINE", "Outline", "Only the borders of cone 1 and cone 2, thin"),
               ("HIDDEN", "Hidden", "No cones in the picture"),
               ("FULL", "Full", "The cone objects as in the viewport")),
        default="OUTLINE",
    )

    @classmethod
    def poll(cls, context):
        if settings_of(context) is None:
            cls.poll_message_set("Blisk CAM settings are missing: enable the add-on")
            return False
        return True

    def execute(self, context):
        from ..blender import render

        settings = context.scene.blisk_cam
        try:
            raw = self.filepath or settings.preview_path
            if not raw:
                raise BliskCamError("No preview file name: set Preview File")
            path = bpy.path.abspath(raw)
            if path.startswith("//"):
                raise BliskCamError(
                    f"'{raw}' is relative to the .blend file, which is not saved: save the "
                    ".blend first or give an absolute path"
                )
            objects, curves = _framed_objects(context, self.frame)
            if not objects:
                raise BliskCamError("Nothing to render: no visible blade or path object")
            view = tuple(self.view)
            if not self.properties.is_property_set("view"):
                view = _pressure_side_view(context) or view
            title = legend = None
            if self.annotate:
                title, legend = _annotation(context)
            result = render.render_preview(
                path, engine=self.engine, resolution=tuple(self.resolution), objects=objects,
                scene=context.scene, view=view, keep_camera=self.keep_camera,
                cones=self.cones.lower(), title=title, legend=legend, scale_bar=self.annotate,
                neighbours=self.neighbours.lower(), assembly=self.holder.lower(),
                poses="status", paths=curves,
            )
        except Exception as exc:
            return report_exception(self, exc)
        label = {"BLENDER_WORKBENCH": "Workbench", "CYCLES": "Cycles CPU"}.get(
            result.engine, result.engine)
        self.report({"INFO"}, f"Preview {result.path} ({label}, {result.seconds:.1f} s)")
        return {"FINISHED"}
