"""What the operators share: which blade, why an operator cannot run (poll messages), scene
settings → core request, exceptions → reports.

No geometry here: the settings are turned into the plain core objects (``Axis``, ``Cone``,
``PathRequest``) and the mesh into arrays; ``core`` does the rest.
"""

from __future__ import annotations

import json
import traceback

import numpy as np

from ..blender_io import InputError, object_axis, object_to_arrays
from ..core.cones import Cone
from ..core.errors import BliskCamError, ConeError
from ..core.lmrs import Profile, morph_between
from ..core.options import PATH_STAGES, fields
from ..core.pipeline import PathRequest

__all__ = [
    "INTERNAL_ERROR",
    "f32",
    "settings_of",
    "resolve_blade",
    "blade_problem",
    "cones_problem",
    "settings_cones",
    "set_generatrix",
    "profile_from_json",
    "request_options",
    "option_value",
    "stage_values",
    "FIT_NAMES",
    "blade_axis",
    "read_blade",
    "path_request",
    "set_settings_from_request",
    "result_blade_name",
    "report_exception",
    "poll_generated_paths",
    "output_filename",
    "collision_options",
    "obstacle_arrays",
    "stored_path",
]

#: prefix of the report of an unexpected exception (a bug, not bad input); the CLI maps it
#: to exit status 3
INTERNAL_ERROR = "Internal error"

#: fit enum → ``core.fitting.fit_cones_to_mesh(generatrix=...)``
FIT_NAMES = {"AUTO": "auto", "CONE": "cone", "PROFILE": "profile"}


def f32(value) -> float:
    """A float property's value as the decimal the user typed.

    Blender stores float properties in single precision: 0.05 comes back as
    0.05000000074505806. The shortest decimal that rounds to the same float32 ("0.05") is
    what was meant; values computed in double (fitted cones) change by < 1e-7 relative.
    """
    return float(str(np.float32(value)))


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


def profile_from_json(text: str, what: str = "profile") -> Profile:
    """A :class:`~blisk_cam.core.lmrs.Profile` from its stored JSON ``[[r, z], ...]`` (mm);
    ConeError naming ``what`` when the text is not one."""
    try:
        values = json.loads(text)
    except (TypeError, ValueError) as exc:
        raise ConeError(f"{what}: the stored profile is not valid JSON ({exc}); fit the cones "
                        "again or enter the cone") from None
    try:
        return Profile.from_list(values)
    except ConeError as exc:
        raise ConeError(f"{what}: {exc}") from None


def set_generatrix(settings, k: int, generatrix) -> None:
    """Store generatrix ``k`` (1 hub, 2 tip): a ``Cone`` in ``cone<k>``; a ``Profile`` in full
    (full precision JSON) in ``profile<k>``, with its least-squares straight cone in
    ``cone<k>`` for the gizmos and the panel. The cone is written first: writing it clears a
    previous profile (the property's update)."""
    cone = generatrix.to_cone() if isinstance(generatrix, Profile) else generatrix
    setattr(settings, f"cone{k}", cone.as_list())
    setattr(settings, f"profile{k}",
            json.dumps(generatrix.as_list()) if isinstance(generatrix, Profile) else "")


def settings_cones(settings):
    """(generatrix1, generatrix2) from the settings: the stored ``Profile`` when there is one,
    else the ``Cone``, or None for a cone not set (all zero).

    Raises ConeError naming the cone when its numbers are not a valid cone (or profile).
    """
    out = []
    for k, values in ((1, settings.cone1), (2, settings.cone2)):
        text = getattr(settings, f"profile{k}", "")
        if text:
            out.append(profile_from_json(text, f"Profile {k}"))
            continue
        v = [f32(x) for x in values]
        if not any(v):
            out.append(None)
            continue
        try:
            out.append(Cone.from_list(v))
        except ConeError as exc:
            raise ConeError(f"Cone {k} ({', '.join(f'{x:g}' for x in v)}): {exc}") from None
    return tuple(out)


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


def option_value(spec, default, raw):
    """A Blender property's value as the core option (:mod:`blisk_cam.core.options`): enum
    item → core value, float32 → the decimal typed (:func:`f32`), ``spec.none_as`` → None
    for an optional option."""
    if isinstance(default, bool):
        return bool(raw)
    if spec.choices is not None:
        for c in spec.choices:
            if c.blender_id == raw:
                return c.value
        raise BliskCamError(f"{spec.label}: unknown value {raw!r}")
    if spec.size > 1:
        return tuple(f32(x) for x in raw)
    if isinstance(raw, int) and not isinstance(raw, float) and spec.unit == "":
        if default is None and raw == spec.none_as:
            return None  # e.g. Blade Count 0: not set
        return int(raw)
    value = f32(raw)
    if default is None and value == spec.none_as:
        return None
    return value


def stage_values(settings, stage) -> dict:
    """{option: core value} of the options of ``stage`` that Blender declares."""
    return {
        name: option_value(spec, default, getattr(settings, spec.prop_name(name)))
        for name, spec, default in fields(stage)
        if spec.blender
    }


def request_options(settings, axis=None) -> dict:
    """The ``PathRequest`` keyword arguments of the scene settings, except ``axis`` and the
    cones, in core units (mm, radians, core names): every declared option
    (:data:`blisk_cam.core.options.PATH_STAGES`) read generically, then the hand-made ones —
    the hub → tip variation behind its toggle and the fixed point or line of the fixed axis
    modes.

    ``axis`` (core ``Axis``) is needed by the modes toward/away from the blisk axis.
    """
    opts = {}
    for stage in PATH_STAGES:
        opts.update(stage_values(settings, stage))
    mode = opts["axis_mode"]
    fixed = "axis" if mode.endswith("_line") else "point" if mode.endswith("_point") else None
    vary = bool(settings.vary_lead_tilt)
    opts.update(
        tilt=opts["tilt"] if mode != "radial" else 0.0,
        lead_tip=f32(settings.lead_tip) if vary else None,
        tilt_tip=(f32(settings.tilt_tip) if mode != "radial" else 0.0) if vary else None,
        radial_tilt=opts["radial_tilt"] if mode == "radial" else 0.0,
    )
    if fixed is not None:  # a fixed point or line decides the axis: no lead/tilt
        opts.update(lead=0.0, tilt=0.0, lead_tip=None, tilt_tip=None)
        if fixed == "axis":
            if axis is None:
                raise BliskCamError(f"tool-axis mode {settings.axis_mode} needs the blisk axis")
            opts.update(axis_point=tuple(map(float, axis.o)),
                        axis_direction=tuple(map(float, axis.d)))
        else:
            opts["axis_point"] = tuple(f32(x) for x in settings.axis_point)
    return opts


def set_settings_from_request(settings, req: PathRequest, *, fit: str | None = None) -> None:
    """Fill the scene settings from a core request (the inverse of :func:`request_options`):
    what the batch command line saves in a .blend, so that the file regenerates the same
    path from the sidebar."""
    for stage in PATH_STAGES:
        for name, spec, _ in fields(stage):
            if not spec.blender:
                continue
            value = getattr(req, name)
            if spec.choices is not None and not isinstance(value, bool):
                value = spec.choice(value).blender_id
            elif value is None:
                value = spec.none_as
                if value is None:  # not used by this cutter (normalised away): keep
                    continue
            setattr(settings, spec.prop_name(name), value)
    vary = req.lead_tip is not None or req.tilt_tip is not None
    settings.vary_lead_tilt = vary
    settings.lead_tip = req.lead if req.lead_tip is None else req.lead_tip
    settings.tilt_tip = req.tilt if req.tilt_tip is None else req.tilt_tip
    if req.axis_point is not None and req.axis_mode.endswith("_point"):
        settings.axis_point = req.axis_point
    if fit is not None:
        settings.fit_generatrix = fit.upper()
    for k, g in ((1, req.cone1), (2, req.cone2)):
        if g is not None:
            set_generatrix(settings, k, g)


def path_request(settings, axis, cone1, cone2) -> PathRequest:
    """The core request of the settings (see :func:`request_options`)."""
    return PathRequest(axis=axis, cone1=cone1, cone2=cone2, **request_options(settings, axis))


def result_blade_name(context, *, paths_only: bool = True) -> str | None:
    """Name of the blade whose generated paths the export/clear operators act on: the
    current blade if it has paths, else the blade of the last result; None without paths.
    With ``paths_only=False`` an output collection holding only the fitted cones counts."""
    from ..output import find_output_collection, has_paths

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


def poll_generated_paths(cls, context) -> bool:
    """The poll of the operators that act on the generated paths (export, NC, animation):
    False with the reason set when the add-on or the paths are missing."""
    if settings_of(context) is None:
        cls.poll_message_set("Blisk CAM settings are missing: enable the add-on")
        return False
    if result_blade_name(context) is None:
        cls.poll_message_set("No generated paths: press Generate Paths first")
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


def collision_options(settings):
    """The core ``CollisionOptions`` of the settings for a check from the panel: every
    declared option read generically, mode off → check (the button always checks), the
    holder string parsed. BliskCamError naming the setting when one is missing or bad."""
    from ..core.avoidance import CollisionOptions

    values = stage_values(settings, CollisionOptions)
    if values.get("mode", "off") == "off":
        values["mode"] = "check"
    if values.get("blade_count") is None:
        raise BliskCamError("Blade Count is not set: set the Blade Count (the blades on the "
                            "blisk, ≥ 2) in the Collisions panel; the neighbours are the blade "
                            "turned by 360°/N")
    text = (settings.holder or "").strip()
    if text:
        from ..cli import parse_holder

        try:
            values["holder"] = parse_holder(text)
        except BliskCamError as exc:
            raise BliskCamError(str(exc).replace("--holder", "Holder", 1)) from None
    return CollisionOptions(**values)


def obstacle_arrays(settings, depsgraph, *, exclude=()) -> list:
    """[(name, V, F)] of the meshes in the settings' Obstacles collection (evaluated, world
    frame, mm), leaving out ``exclude`` (object names: the blade) and Blisk CAM's own output
    objects."""
    from ..output import KEY_ROLE

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
    from ..core.paths_io import path_from_dict
    from ..output import stored_paths_json

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
