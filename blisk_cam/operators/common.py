"""What the operators share: which blade, why an operator cannot run (poll messages), scene
settings → core request, exceptions → reports.

No geometry here: the settings are turned into the plain core objects (``Axis``, ``Cone``,
``PathRequest``) and the mesh into arrays; ``core`` does the rest.
"""

from __future__ import annotations

import json
import traceback

from ..blender.objects import InputError, object_axis, object_to_arrays
from ..blender.settings import (
    settings_cones,
)
from ..core.errors import BliskCamError
from ..core.part.profiles import morph_between

__all__ = [
    "INTERNAL_ERROR",
    "settings_of",
    "resolve_blade",
    "blade_problem",
    "cones_problem",
    "blade_axis",
    "read_blade",
    "result_blade_name",
    "report_exception",
    "generated_paths_problem",
    "poll_generated_paths",
    "output_filename",
    "obstacle_arrays",
    "stored_path",
]

#: prefix of the report of an unexpected exception (a bug, not bad input); the CLI maps it
#: to exit status 3
INTERNAL_ERROR = "Internal error"


def settings_of(context):
    """``context.scene.blisk_cam`` or None (add-on not registered, no scene)."""
    scene = getattr(context, "scene", None)
    return getattr(scene, "blisk_cam", None) if scene is not None else None


def resolve_blade(context):
    """The blade setting, or the active object while the setting is empty (or None)."""
    settings = settings_of(context)
    blade = settings.blade if settings is not None else None
    if blade is None:
        blade = getattr(context, "active_object", None)
    return blade


def blade_problem(context) -> str | None:
    """Why no blade can be read, in words the user can act on (None: fine). Cheap (poll)."""
    if settings_of(context) is None:
        return "Blisk CAM settings are missing: enable the Blisk CAM add-on"
    blade = resolve_blade(context)
    if blade is None:
        return "No blade: choose the blade mesh in the Setup panel (or make it active)"
    if blade.type != "MESH":
        return (
            f"'{blade.name}' is a {blade.type.lower()} object, not a mesh: choose the blade "
            "mesh in the Setup panel"
        )
    if len(blade.data.polygons) == 0 and len(blade.modifiers) == 0:
        return (
            f"'{blade.name}' has no faces ({len(blade.data.vertices)} vertices): the blade "
            "must be a surface mesh with triangles or quads"
        )
    return None


def cones_problem(settings) -> str | None:
    """Why the cones cannot be used for paths (None: fine). Cheap (poll)."""
    try:
        c1, c2 = settings_cones(settings)
        missing = [str(k) for k, c in ((1, c1), (2, c2)) if c is None]
        if missing:
            return (
                f"Cone {' and '.join(missing)} not set: press Fit Cones (Setup) or enter "
                "r1 z1 r2 z2 in mm (Region)"
            )
        morph_between(c1, c2)
    except BliskCamError as exc:
        return str(exc)
    return None


def blade_axis(settings, blade):
    """The blisk axis (core ``Axis``, mm): the axis Empty's local Z through its origin, or
    the blade's world Z through the blade's origin."""
    source = settings.axis_object if settings.axis_object is not None else blade
    return object_axis(source)


def read_blade(context, blade):
    """The blade's evaluated mesh as arrays (V (n, 3) mm world, F (m, 3) int64)."""
    if blade is None:
        raise InputError("No blade: choose the blade mesh in the Setup panel")
    return object_to_arrays(blade, context.evaluated_depsgraph_get())


def result_blade_name(context, *, paths_only: bool = True) -> str | None:
    """Name of the blade whose generated paths the export/clear operators act on: the
    current blade if it has paths, else the blade of the last result; None without paths.
    With ``paths_only=False`` an output collection holding only the fitted cones counts."""
    from ..blender.path_objects import find_output_collection, has_paths

    settings = settings_of(context)
    if settings is None:
        return None

    def ok(name):
        return has_paths(name) if paths_only else find_output_collection(name) is not None

    blade = resolve_blade(context)
    if blade is not None and ok(blade.name):
        return blade.name
    if settings.stat_blade and ok(settings.stat_blade):
        return settings.stat_blade
    return None


def generated_paths_problem(context) -> str | None:
    """Why an operator acting on the generated paths cannot run (the add-on or the paths are
    missing), or None."""
    if settings_of(context) is None:
        return "Blisk CAM settings are missing: enable the add-on"
    if result_blade_name(context) is None:
        return "No generated paths: press Generate Paths first"
    return None


def poll_generated_paths(cls, context) -> bool:
    """The poll of the operators that act on the generated paths (export, NC, animation):
    False with the reason set when the add-on or the paths are missing."""
    problem = generated_paths_problem(context)
    if problem:
        cls.poll_message_set(problem)
        return False
    return True


def output_filename(filepath: str, what: str) -> str:
    """The absolute file name of an operator's ``filepath`` (``//`` = beside the .blend);
    BliskCamError when none is given or it is relative to a .blend never saved."""
    import bpy

    if not filepath:
        raise BliskCamError(f"No file name given for the {what}")
    filename = bpy.path.abspath(filepath)
    if filename.startswith("//"):
        raise BliskCamError(f"'{filepath}' is relative to the .blend file, which is not saved: "
                            "save the .blend first or give an absolute path")
    return filename


def report_exception(op, exc) -> set:
    """Report an exception on the operator; returns ``{'CANCELLED'}``.

    Bad input (a ``BliskCamError``) is reported as its message; anything else is a bug: the
    traceback goes to the console and the report says so.
    """
    if isinstance(exc, BliskCamError):
        op.report({"ERROR"}, str(exc))
    else:
        traceback.print_exc()
        op.report(
            {"ERROR"},
            f"{INTERNAL_ERROR} (please report it): {type(exc).__name__}: {exc}",
        )
    return {"CANCELLED"}


def obstacle_arrays(settings, depsgraph, *, exclude=()) -> list:
    """[(name, V, F)] of the meshes in the settings' Obstacles collection (evaluated, world
    frame, mm), leaving out ``exclude`` (object names: the blade) and Blisk CAM's own output
    objects."""
    from ..blender.path_objects import KEY_ROLE

    coll = getattr(settings, "obstacles", None)
    if coll is None:
        return []
    out = []
    for ob in coll.all_objects:
        if ob.name in exclude or KEY_ROLE in ob or ob.type not in ("MESH", "CURVE", "SURFACE",
                                                                    "META", "FONT"):
            continue
        V, F = object_to_arrays(ob, depsgraph)
        out.append((ob.name, V, F))
    return out


def stored_path(blade_name: str):
    """The core ``ToolPath`` of a blade's stored paths JSON; BliskCamError when it has none."""
    from ..blender.path_objects import stored_paths_json
    from ..core.toolpath.paths_io import path_from_dict

    text = stored_paths_json(blade_name) if blade_name else None
    if not text:
        raise BliskCamError(f"'{blade_name}' has no generated paths: press Generate Paths "
                            "first")
    try:
        data = json.loads(text)
    except ValueError as exc:
        raise BliskCamError(f"the stored paths of '{blade_name}' are not valid JSON ({exc}): "
                            "press Generate Paths again") from None
    return path_from_dict(data)
