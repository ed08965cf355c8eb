"""Scene settings ↔ core requests: the options of ``scene.blisk_cam`` read generically from
their one declaration (:mod:`..core.options`), the cones and profiles stored on the settings,
the request a Generate runs and the statistics a result leaves on the settings.

No geometry here: the settings become the plain core objects (``Cone``, ``Profile``,
``PathRequest``, ``CollisionOptions``); ``core`` does the rest.
"""

from __future__ import annotations

import json

import numpy as np

from ..core.collision.options import DEFAULT_CHECK_MODE, CollisionOptions
from ..core.errors import BliskCamError, ConeError
from ..core.options import PATH_OPTION_GROUPS, fields
from ..core.part.cones import Cone
from ..core.part.profiles import Profile
from ..core.process.blade_finish import PathRequest
from ..core.tool.assembly import AssemblyError, holder_profile
from ..core.toolpath.types import MOVE_CUT, MOVE_NAMES, MOVE_RAPID

__all__ = [
    "FIT_NAMES",
    "f32",
    "profile_from_json",
    "set_generatrix",
    "settings_cones",
    "option_value",
    "group_values",
    "request_options",
    "set_settings_from_request",
    "path_request",
    "collision_options",
    "nc_options",
    "robot_options",
    "store_statistics",
    "summary",
]

#: fit enum → ``core.part.fitting.fit_cones_to_mesh(generatrix=...)``
FIT_NAMES = {"AUTO": "auto", "CONE": "cone", "PROFILE": "profile"}


def f32(value) -> float:
    """A float property's value as the decimal the user typed.

    Blender stores float properties in single precision: 0.05 comes back as
    0.05000000074505806. The shortest decimal that rounds to the same float32 ("0.05") is
    what was meant; values computed in double (fitted cones) change by < 1e-7 relative.
    """
    return float(str(np.float32(value)))


def profile_from_json(text: str, what: str = "profile") -> Profile:
    """A :class:`~blisk_cam.core.part.profiles.Profile` from its stored JSON ``[[r, z], ...]`` (mm);
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


def group_values(settings, stage) -> dict:
    """{option: core value} of the options of ``stage`` that Blender declares."""
    return {
        name: option_value(spec, default, getattr(settings, spec.prop_name(name)))
        for name, spec, default in fields(stage)
        if spec.blender
    }


def request_options(settings, axis=None) -> dict:
    """The ``PathRequest`` keyword arguments of the scene settings, except ``axis`` and the
    cones, in core units (mm, radians, core names): every declared option
    (:data:`blisk_cam.core.options.PATH_OPTION_GROUPS`) read generically, then the hand-made ones —
    the hub → tip variation behind its toggle and the fixed point or line of the fixed axis
    modes.

    ``axis`` (core ``Axis``) is needed by the modes toward/away from the blisk axis.
    """
    opts = {}
    for stage in PATH_OPTION_GROUPS:
        opts.update(group_values(settings, stage))
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
    for stage in PATH_OPTION_GROUPS:
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


def collision_options(settings):
    """The core ``CollisionOptions`` of the settings for a check from the panel: every
    declared option read generically, mode off → check (the button always checks), the
    holder string parsed. BliskCamError naming the setting when one is missing or bad."""

    values = group_values(settings, CollisionOptions)
    if values.get("mode", "off") == "off":
        values["mode"] = DEFAULT_CHECK_MODE
    if values.get("blade_count") is None:
        raise BliskCamError("Blade Count is not set: set the Blade Count (the blades on the "
                            "blisk, ≥ 2) in the Collisions panel; the neighbours are the blade "
                            "turned by 360°/N")
    text = (settings.holder or "").strip()
    if text:
        try:
            values["holder"] = holder_profile(text, "Holder")
        except AssemblyError as exc:
            raise BliskCamError(str(exc)) from None
    return CollisionOptions(**values)


def nc_options(settings, **extra):
    """The core ``NcOptions`` of the settings: every declared NC option, and the blades from
    the one Blade Count of the scene (the Collisions and Machine & NC panels show the same
    property; 0, not set: the one blade)."""
    from ..core.post.blocks import NcOptions

    return NcOptions(**group_values(settings, NcOptions),
                     blades=max(int(settings.blade_count), 1), **extra)


def robot_options(settings, *, notes=()):
    """The core ``(FreeAngleOptions, ProgramOptions)`` of the Robot panel: feed mm/min, joint
    step and wrist margin in radians (the panel shows degrees), force N (0: not stated)."""
    from ..core.robot.free_angle import FreeAngleOptions
    from ..core.robot.programs import ProgramOptions

    feed = float(settings.robot_feed)
    force = float(settings.robot_force)
    plan = FreeAngleOptions(samples=int(settings.robot_samples), feed=feed,
                            max_joint_step=float(settings.robot_max_step),
                            min_wrist=float(settings.robot_min_wrist))
    program = ProgramOptions(feed=feed, force=force if force > 0 else None, notes=tuple(notes))
    return plan, program


def store_statistics(settings, blade_name, path, verify, seconds, verdict=None):
    """Statistics of the result on the settings (saved in the .blend, shown by the panel);
    ``verdict`` (core.verify.verdict.Verdict) gives ``stat_verdict`` "PASS"/"FAIL" ("" without)."""
    settings.has_result = True
    settings.stat_blade = blade_name
    settings.stat_curves = len(path.curves)
    settings.stat_passes = int(path.stats.get("passes", len(path.levels)))
    settings.stat_poses = path.n_poses
    settings.stat_length = path.length()
    program = getattr(path, "program", None)
    link = rapid = 0.0
    if program is not None and len(program):
        feed_links = [k for k in range(len(MOVE_NAMES)) if k not in (MOVE_CUT, MOVE_RAPID)]
        link, rapid = program.length(feed_links), program.length([MOVE_RAPID])
    settings.stat_link_length, settings.stat_rapid_length = link, rapid
    settings.stat_warnings = len(path.stats.get("warnings", []) or []) + len(
        getattr(path, "warnings", []) or []
    )
    settings.stat_seconds = seconds
    cusps = [c for c in path.stats.get("measured_cusp", []) if np.isfinite(c)]
    settings.stat_cusp = max(cusps) if cusps else 0.0
    settings.stat_verified = verify is not None
    if verify is not None:
        # with an allowance (semi-finishing) the material left on the blade, and the gouge
        # as the depth cut into the allowance (core.verify.allowance)
        left = float(verify.max_material_left) + float(getattr(verify, "allowance", 0.0))
        gouge = float(verify.max_gouge)
        settings.stat_material_left = left if np.isfinite(left) else 0.0
        settings.stat_gouge = gouge if np.isfinite(gouge) else 0.0
    else:
        settings.stat_material_left = settings.stat_gouge = 0.0
    settings.stat_verdict = verdict.status if verdict is not None and verify is not None else ""


def summary(settings) -> str:
    """One line: counts, length, time and the measured figures."""
    text = (
        f"{settings.stat_passes} passes, {settings.stat_curves} curves, "
        f"{settings.stat_poses} poses, {settings.stat_length:.1f} mm of path "
        f"in {settings.stat_seconds:.1f} s"
    )
    if settings.stat_warnings:
        text += f"; {settings.stat_warnings} warning(s)"
    if settings.stat_verified:
        text += (
            f"; measured max material left {settings.stat_material_left:.4f} mm, "
            f"max gouge {settings.stat_gouge:.4f} mm"
        )
    return text
