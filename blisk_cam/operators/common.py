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
from ..core.pipeline import PathRequest

__all__ = [
    "INTERNAL_ERROR",
    "TOOL_NAMES",
    "LINK_NAMES",
    "f32",
    "settings_of",
    "resolve_blade",
    "blade_problem",
    "cones_problem",
    "settings_cones",
    "set_generatrix",
    "profile_from_json",
    "request_options",
    "AXIS_MODE_NAMES",
    "FIT_NAMES",
    "blade_axis",
    "read_blade",
    "path_request",
    "result_blade_name",
    "report_exception",
]

#: prefix of the report of an unexpected exception (a bug, not bad input); the CLI maps it
#: to exit status 3
INTERNAL_ERROR = "Internal error"

#: property enum → core name
TOOL_NAMES = {"BALL": "ball", "BULL": "bull", "FLAT": "flat", "TAPER": "taper"}
LINK_NAMES = {"ONE_WAY": "oneway", "ZIGZAG": "zigzag", "SPIRAL": "spiral"}
#: axis mode enum → (core ``PathRequest.axis_mode``, fixed geometry: None, "axis" or "point")
AXIS_MODE_NAMES = {
    "LOCAL": ("local", None),
    "RADIAL": ("radial", None),
    "TOWARD_AXIS": ("toward_line", "axis"),
    "FROM_AXIS": ("from_line", "axis"),
    "TOWARD_POINT": ("toward_point", "point"),
    "FROM_POINT": ("from_point", "point"),
}
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


def request_options(settings, axis=None) -> dict:
    """The ``PathRequest`` keyword arguments of the scene settings, except ``axis`` and the
    cones: the one mapping from the panel's properties to the core (the CLI fills the same
    properties), in core units (mm, radians, lowercase names).

    ``axis`` (core ``Axis``) is needed by the modes toward/away from the blisk axis.
    """
    tool = TOOL_NAMES[settings.tool_type]
    mode, fixed = AXIS_MODE_NAMES[settings.axis_mode]
    vary = bool(settings.vary_lead_tilt)
    opts = dict(
        tool_type=tool,
        tool_radius=f32(settings.tool_radius),
        corner_radius=f32(settings.corner_radius) if tool == "bull" else 0.0,  # torus radius
        taper_angle=f32(settings.taper_angle) if tool == "taper" else None,
        cusp=f32(settings.cusp),
        chord=f32(settings.chord),
        axis_mode=mode,
        lead=f32(settings.lead),
        tilt=f32(settings.tilt) if mode != "radial" else 0.0,
        lead_tip=f32(settings.lead_tip) if vary else None,
        tilt_tip=(f32(settings.tilt_tip) if mode != "radial" else 0.0) if vary else None,
        radial_tilt=f32(settings.radial_tilt) if mode == "radial" else 0.0,
        max_axis_turn=f32(settings.max_axis_turn) if settings.max_axis_turn > 0.0 else None,
        fix_local_gouge=bool(settings.fix_local_gouge),
        link=LINK_NAMES[settings.link_mode],
        climb=bool(settings.climb),
        approach=f32(settings.approach),
        clearance_radius=(f32(settings.clearance_radius)
                          if settings.clearance_radius > 0.0 else None),
        clearance_margin=f32(settings.clearance_margin),
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
