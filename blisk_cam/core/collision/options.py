"""The collision options (declared once: the panel, the CLI and the paths
JSON read them from here) and the default tool assembly. mm, degrees in
user-facing fields.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import CollisionError
from ..options import Choice, OptionGroup, check_group, option
from ..tool.assembly import DEFAULT_SAFETY, ToolAssembly
from ..tool.cutter import Cutter, as_cutter

__all__ = ["COLLISION_MODES", "DEFAULT_CHECK_MODE", "CollisionOptions", "default_assembly"]

COLLISION_MODES = ("off", "check", "avoid")
#: the mode a front end uses when the user gives a blade count (or presses Check Collisions)
#: without choosing one: check, the same in the panel and the command line. Check is the
#: safer default: it changes nothing the user planned and verified (avoid turns tool axes,
#: which can change the finish and approach the machine's reach), reports every collision,
#: and the NC gate (post/gate.py) refuses to post unresolved poses; avoid is chosen on purpose
DEFAULT_CHECK_MODE = "check"
#: the axis planner's default cap on the turn its limit adds to the planned one between two
#: consecutive poses, rad (:attr:`CollisionOptions.plan_max_turn`)
DEFAULT_PLAN_MAX_TURN = math.radians(5.0)
#: what the axis planner may keep the axes close to (``axis_reference``)
AXIS_REFERENCES = ("planned", "channel", "pass", "fixed")


@dataclass(frozen=True)
class CollisionOptions(OptionGroup):
    """What the front ends set (units mm, radians).

    Attributes
    ----------
    mode : "off" | "check" | "avoid"
    blade_count : int or None — blades on the blisk (required unless mode is "off")
    neighbours : int — adjacent blades checked per side (default 2)
    flute_length : float or None, mm — None: the cutter's flute length h
    holder : sequence of (z, r) or None, mm — the body profile from the flute length up
        (:class:`~..tool.assembly.ToolAssembly`); None: :func:`default_assembly`
    safety : float, mm — ds (default 1 mm)
    max_lead, max_tilt : float, rad — axis limits of a corrected pose from the surface normal
        (default 30° each, either sign; a pose planned beyond them: its planned angles)
    max_turn : float or None, rad — the turn limit per pose: method "rotate", its smoothing
        limit between consecutive poses (None: 2°); "plan", the cap on the turn
        ``turn_per_mm`` adds to the planned one (None: 5°, :attr:`plan_max_turn`)
    method : "plan" | "rotate" — avoidance by the axis planner over the whole pass
        (:mod:`.axis_plan`, default) or by paper 004's per-pose rotation (:mod:`.avoid`)
    turn_per_mm : float, rad/mm — the planner's largest axis turn per mm of the tool's path
        (2°/mm; the length the corner centre at the contact travels, a ball's centre:
        :func:`.axis_field.path_steps`)
    axis_reference : "planned" | "channel" | "pass" | "fixed" — what the planner keeps the
        axes close to (:func:`.axis_plan.reference_axes`)
    reference_direction : (3,) or None — the direction of ``axis_reference="fixed"``
    edge_lead : float or None, rad — extra lead at the pass ends (None: 5° with the channel
        reference, 0 otherwise; :attr:`plan_edge_lead`)
    machine : Machine or None — the planner keeps the axes inside its rotaries' reach
    max_iterations : int — rotation steps per pose (Eqs. 16–17)
    gouge_tol : float or None, mm — ε of Eq. 14 (None: the path's chord tolerance / 4)
    turn_jumps : bool — let the planner turn past the turn limit between two consecutive
        poses that both collide whatever their axis (fewer unresolved poses, but the path is
        then not bounded in turn there; default False: bounded everywhere, issue 25)
    """

    title = "Collisions (holder and shank against the blade, its neighbours, obstacles)"
    error = CollisionError

    mode: str = option(
        "off", "Collisions", "Collision checking of holder, shank and flute: off; check "
        "(colour and report, change nothing); avoid (turn the tool axis clear, paper 004). "
        "The command line turns it to check when a blade count or an obstacle is given",
        choices=(Choice("off", "Off", "No collision checking"),
                 Choice("check", "Check", "Detect and report; change nothing"),
                 Choice("avoid", "Avoid", "Detect, then turn the tool axis clear")),
        flag="--collisions")
    blade_count: int | None = option(
        None, "Blade Count", "Blades on the blisk: the neighbours are the blade turned by "
        "k·360°/N (0 in the panel: not set)", lo=2, none_as=0)
    neighbours: int = option(2, "Neighbours", "Adjacent blades checked on each side", lo=0)
    flute_length: float | None = option(
        None, "Flute Length", "Cutting length of the tool from the tip, mm (0 or not given: "
        "the cutter's own, 3 × the diameter)", unit="mm", lo=0.0, none_as=0.0,
        soft_max=200.0)
    holder: tuple | None = None  # (z, r) body profile above the flute, mm (flag --holder)
    safety: float = option(DEFAULT_SAFETY, "Safety Distance", "Smallest allowed clearance "
                           "ds between the tool body and any obstacle, mm", unit="mm", lo=0.0,
                           soft_max=10.0)
    max_lead: float = option(
        math.radians(30.0), "Max Lead", "A corrected tool axis may lean at most this far "
        "from the surface normal in the feed direction, degrees (either sign); an axis planned "
        "further may turn but not lean further than planned", unit="deg",
        lo=0.0, hi=math.radians(89.0))
    max_tilt: float = option(
        math.radians(30.0), "Max Tilt", "A corrected tool axis may lean at most this far "
        "from the surface normal across the feed, degrees (either sign); an axis planned "
        "further may turn but not lean further than planned", unit="deg",
        lo=0.0, hi=math.radians(89.0))
    method: str = option(
        "plan", "Avoidance", "How avoid turns the axes: plan (the axes of a whole pass chosen "
        "together, clear, within the turn limit per mm, closest to the requested lead/tilt) or "
        "rotate (paper 004: each colliding pose by its smallest rotation, then smoothed)",
        choices=(Choice("plan", "Plan", "Axis planner over the whole pass"),
                 Choice("rotate", "Rotate", "Per-pose smallest rotation (paper 004)")),
        flag="--avoid-method", prop="avoid_method")
    turn_per_mm: float = option(
        math.radians(2.0), "Max Turn per mm", "Avoidance (plan) turns the tool axis by at most "
        "this many degrees per mm of the tool's path (a ball's centre) between consecutive "
        "poses, and at most 5° per pose, beyond the planned turn there", unit="deg", lo=0.0,
        lo_open=True, hi=math.radians(90.0),
        flag="--max-turn-per-mm")
    axis_reference: str = option(
        "planned", "Axis Reference", "What avoidance (plan) keeps the axes close to: the "
        "planned (requested) lead/tilt; the channel: the axis interpolated between the two "
        "blade sides of the gap (radial in the channel's mid-plane), with extra lead at the "
        "leading and trailing edges; one direction per pass (the mean of its planned axes); "
        "or a fixed direction",
        choices=(Choice("planned", "Planned", "Closest to the requested lead/tilt"),
                 Choice("channel", "Channel", "Closest to the channel's mid-plane"),
                 Choice("pass", "Per Pass", "Closest to one direction per pass (the mean of "
                        "its planned axes): the rotaries move least"),
                 Choice("fixed", "Fixed", "Closest to one direction for every pose (Reference "
                        "Direction)")),
        flag="--axis-reference")
    reference_direction: tuple | None = option(
        None, "Reference Direction", "Axis reference fixed: the direction the tool axes are "
        "kept close to, in the part's frame (x y z, any length; 0 0 0: not set)", size=3,
        flag="--reference-direction", none_as=(0.0, 0.0, 0.0))
    edge_lead: float | None = option(
        None, "Edge Lead", "Avoidance (plan) adds this lead to the reference within one tool "
        "diameter of each pass end (the leading and trailing edges), degrees (not set: 5° with "
        "the channel reference, none otherwise)", unit="deg", lo=0.0, hi=math.radians(45.0),
        flag="--edge-lead", blender=False)
    machine: object = None  # core.machine Machine: avoidance stays inside its reach
    max_turn: float | None = option(
        None, "Max Turn per Pose", "Avoidance turns the tool axis by at most this angle "
        "between consecutive poses, degrees: plan, on top of the planned turn and within the "
        "limit per mm (0: 5°); rotate, its smoothing limit (0: 2°)", unit="deg", lo=0.0,
        hi=math.radians(89.0), none_as=0.0, flag="--max-turn-per-pose")
    max_iterations: int = 8
    gouge_tol: float | None = None
    turn_jumps: bool = option(
        False, "Jump Between Unresolved", "Avoidance (plan) may turn past the turn limit "
        "between two consecutive poses that collide whatever their axis: fewer unresolved "
        "poses, but the axis is not bounded in turn there (off: bounded everywhere)",
        flag="--turn-jumps")

    def __post_init__(self):
        mode = str(self.mode).strip().lower()
        if mode not in COLLISION_MODES:
            raise CollisionError(f"collision mode must be one of {', '.join(COLLISION_MODES)}, "
                                 f"got {self.mode!r}")
        object.__setattr__(self, "mode", mode)
        if mode != "off" and self.blade_count is None:
            raise CollisionError("collision checking needs the blade count of the blisk (the "
                                 "neighbours are the blade turned by 360°/N); give blade_count")
        for name in ("max_lead", "max_tilt"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v)
                    and 0 <= v <= math.radians(89)):
                raise CollisionError(f"collision {name} must lie in [0°, 89°], got {v!r} rad")
        if self.max_turn is not None and not (0 < float(self.max_turn) < math.pi / 2):
            raise CollisionError(f"collision smoothing max_turn must lie in (0°, 90°), got "
                                 f"{self.max_turn!r} rad")
        if self.method not in ("plan", "rotate"):
            raise CollisionError(f"avoidance method must be plan or rotate, got {self.method!r}")
        if self.axis_reference not in AXIS_REFERENCES:
            raise CollisionError(f"axis reference must be one of {', '.join(AXIS_REFERENCES)}, "
                                 f"got {self.axis_reference!r}")
        if self.axis_reference == "fixed":
            d = self.reference_direction
            ok = d is not None and len(d) == 3 and all(math.isfinite(float(x)) for x in d)
            if not ok or math.hypot(*map(float, d)) < 1e-9:
                raise CollisionError("the fixed axis reference needs a direction: set Reference "
                                     "Direction (--reference-direction X Y Z), not zero, got "
                                     f"{d!r}")
        if not (isinstance(self.turn_per_mm, (int, float)) and 0 < self.turn_per_mm
                and math.isfinite(self.turn_per_mm)):
            raise CollisionError(f"the turn limit per mm must be > 0°/mm, got "
                                 f"{self.turn_per_mm!r} rad/mm")
        if not (isinstance(self.max_iterations, int) and self.max_iterations >= 1):
            raise CollisionError("collision max_iterations must be an integer ≥ 1")
        if self.gouge_tol is not None and not float(self.gouge_tol) >= 0:
            raise CollisionError(f"collision gouge tolerance must be ≥ 0 mm, got "
                                 f"{self.gouge_tol!r}")
        check_group(self)  # the declared bounds (as the panel and the flags show them)

    @property
    def plan_max_turn(self) -> float:
        """The axis planner's per-pose cap, rad: ``max_turn``, or 5° when None. The turn limit
        is per mm of path, but the turn between two poses matters too: the machine turns the
        axis uniformly while the programmed tip goes straight, so a ball's centre leaves the
        straight line between two poses by R·(1 − cos(θ/2)) — 0.051 mm for a Ø12 ball
        turning 15°, which the path's long steps allowed at 2°/mm (up to 17.6° on Rotor 37),
        0.006 mm at 5°."""
        return DEFAULT_PLAN_MAX_TURN if self.max_turn is None else float(self.max_turn)

    @property
    def plan_edge_lead(self) -> float:
        """The planner's extra lead at the pass ends, rad: ``edge_lead``, or 5° with the
        channel reference and 0 otherwise when None."""
        if self.edge_lead is not None:
            return float(self.edge_lead)
        return math.radians(5.0) if self.axis_reference == "channel" else 0.0

    def assembly(self, cutter) -> ToolAssembly:
        """The :class:`~..tool.assembly.ToolAssembly` of these options for ``cutter``."""
        cutter = as_cutter(cutter)
        if self.holder is None:
            return default_assembly(cutter, self.flute_length, self.safety)
        fl = cutter.h if self.flute_length is None else self.flute_length
        return ToolAssembly(fl, tuple(map(tuple, self.holder)), self.safety)


def default_assembly(cutter: Cutter, flute_length: float | None = None,
                     safety: float = DEFAULT_SAFETY) -> ToolAssembly:
    """The cutter's own shank and holder (:class:`~..tool.cutter.Cutter` fields): the shank
    Ø ``shank_diameter`` for 2 d (plus the neck) above the flute, then the holder
    Ø ``holder_diameter`` for ``holder_length``."""
    fl = cutter.h if flute_length is None else float(flute_length)
    rs, rh = 0.5 * cutter.shank_diameter, 0.5 * cutter.holder_diameter
    z1 = fl + 2.0 * cutter.d + cutter.neck_length
    return ToolAssembly(fl, ((fl, rs), (z1, rs), (z1, rh), (z1 + cutter.holder_length, rh)),
                        safety)
