"""One entry point from user settings to a finished tool path: the request the panel, the
operators and the CLI all fill in, and the run that turns it into a :class:`ToolPath`.

Stages (each its own module, one concept of the papers each):
cone fitting (:mod:`.fitting`, when a cone is not given) → LMC passes of CC points
(:mod:`.pathgen`, paper 001) → machining order and direction, spiral blending
(:mod:`.linking`, paper 002) → tool axes from lead/tilt (:mod:`.orientation`, paper 003) →
local gouge check and fix (:mod:`.local_gouge`) → axis smoothing → cutter location per cutter
type (:mod:`.cutter`, paper 003) → the linked program with approach/retract/links.

Pass spacing for non-ball cutters. :mod:`.pathgen` spaces passes for a ball. With lead/tilt
given in the local frame, the cutter's effective radius across the feed
(:meth:`.cutter.Cutter.effective_radius` along k) does not depend on the surface, so the passes
are spaced for a ball of the smallest effective radius over the requested lead/tilt range (the
conservative choice: a smaller radius leaves a higher scallop for the same step). The true
tips then come from the cutter itself. For fixed-axis modes the inclination is not known in
advance and the range 0–80° is used. ``PlanResult.path.stats["expansion_radius"]`` records it.

Angles are radians, lengths mm, as everywhere in core. ``iter_plan_paths`` yields
:class:`~.pathgen.Progress` and returns a :class:`PlanResult` (``StopIteration.value``) so a
modal operator can drive it and cancel between yields; ``plan_paths`` exhausts it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import ConvexHull

from .cones import Axis, Cone, MorphingCones
from .cutter import Cutter
from .errors import BliskCamError
from .fitting import ConeFit, fit_cones_to_mesh
from .linking import Clearance, LinkOptions, SurfaceProjector, build_program, order_passes
from .local_gouge import GougeLimits, LocalGougeReport, fix_local_gouges, surface_normal_curvature
from .mesh import TriMesh
from .orientation import (
    AxisStrategy,
    OrientationError,
    axes_for_curve,
    consecutive_turn,
    lead_tilt_axes,
    local_frames,
    smooth_axes,
)
from .pathgen import Progress, iter_generate_paths
from .toolpath import (
    FLAG_AXIS_SMOOTHED,
    FLAG_GOUGE_FIXED,
    FLAG_LOCAL_GOUGE,
    FLAG_ZERO_SPEED,
    ToolPath,
)

__all__ = [
    "PathRequest",
    "PlanResult",
    "NotSupportedError",
    "expansion_radius",
    "iter_plan_paths",
    "make_cutter",
    "plan_paths",
]

TOOL_TYPES = ("ball", "bull", "flat", "taper")
LINK_MODES = ("oneway", "zigzag", "spiral")
#: largest ball radius the passes are spaced for, as a multiple of the tool radius (a flat
#: bottom at a small lead has a very large cross-feed radius)
MAX_EXPANSION_FACTOR = 20.0


class NotSupportedError(BliskCamError):
    """The request asks for something this version cannot do yet (names what, and the way out)."""


@dataclass(frozen=True)
class PathRequest:
    """Everything that decides a finishing path, in core units.

    Attributes
    ----------
    axis : Axis — the blisk axis
    cone1, cone2 : Cone or None — hub (s = 0) and tip (s = 1) cones; None = fit from the mesh
    tool_type : one of ``TOOL_TYPES``
    tool_radius : float, mm — cutter radius d/2
    corner_radius : float, mm — torus corner radius of a bull-nose cutter (0 otherwise)
    taper_angle : float, radians, or None — side angle of a taper cutter (None: 3°)
    cusp, chord : float, mm — scallop height and chord error tolerances
    lead, tilt : float, radians — tool axis angles in the local (feed, normal, side) frame
        (:mod:`.orientation` for the signs); at the hub (s = 0) when ``lead_tip``/``tilt_tip``
        are given, which make them vary linearly to the tip (s = 1)
    lead_tip, tilt_tip : float, radians, or None
    axis_mode : one of :data:`.orientation.AXIS_MODES` ("local" default)
    radial_tilt : float, radians — mode "radial": lean away from (> 0) / toward the blisk axis
    axis_point, axis_direction : (3,) mm / (3,) — fixed axis point / line direction
    max_axis_turn : float, radians, or None — axis smoothing: largest angle between
        consecutive poses (None: no smoothing)
    link : one of ``LINK_MODES``
    climb : bool — climb milling for an M03 spindle (False: conventional)
    order : "hub_to_tip" | "tip_to_hub"
    approach : float, mm — approach/retract distance along the tool axis
    clearance_radius : float, mm, or None — clearance cone radius at ``clearance_z0`` (None: the
        passes' largest radius + ``clearance_margin``); ``clearance_slope`` dr/dz
    direct_link : float, mm, or None — largest gap linked on the surface (None: 2 × radius)
    fix_local_gouge : bool — raise lead/tilt within ``gouge_max_lead``/``gouge_max_tilt`` to
        clear local gouges (else only flag them)
    zero_speed_tol : float, mm — contact within this of the axis is flagged zero speed
    extra : dict — options of later stages (kept so the request stays one object)
    """

    axis: Axis
    cone1: Cone | None = None
    cone2: Cone | None = None
    tool_type: str = "ball"
    tool_radius: float = 6.0
    corner_radius: float = 0.0
    cusp: float = 0.05
    chord: float = 0.05
    lead: float = 0.0
    tilt: float = 0.0
    link: str = "oneway"
    extra: dict = field(default_factory=dict)
    taper_angle: float | None = None
    lead_tip: float | None = None
    tilt_tip: float | None = None
    axis_mode: str = "local"
    radial_tilt: float = 0.0
    axis_point: tuple | None = None
    axis_direction: tuple | None = None
    max_axis_turn: float | None = None
    climb: bool = True
    order: str = "hub_to_tip"
    approach: float = 2.0
    clearance_radius: float | None = None
    clearance_z0: float = 0.0
    clearance_slope: float = 0.0
    clearance_margin: float = 5.0
    direct_link: float | None = None
    fix_local_gouge: bool = True
    gouge_max_lead: float = math.radians(30.0)
    gouge_max_tilt: float = math.radians(20.0)
    zero_speed_tol: float = 1e-3


@dataclass
class PlanResult:
    """The path and, when a cone was fitted, the fit (for the residual report).

    ``gouge`` summarises the local gouge check (:class:`.local_gouge.LocalGougeReport`)."""

    path: ToolPath
    fit: ConeFit | None = None
    gouge: LocalGougeReport | None = None


def make_cutter(req: PathRequest) -> Cutter:
    """The request's :class:`~.cutter.Cutter` (ToolError on impossible dimensions)."""
    if req.tool_type not in TOOL_TYPES:
        raise BliskCamError(
            f"unknown tool type {req.tool_type!r}; use one of {', '.join(TOOL_TYPES)}"
        )
    kw = {}
    if req.tool_type == "taper" and req.taper_angle is not None:
        kw["taper_angle"] = req.taper_angle
    return Cutter.from_spec(req.tool_type, req.tool_radius, req.corner_radius, **kw)


def _strategy(req: PathRequest) -> AxisStrategy:
    lead = req.lead if req.lead_tip is None else (req.lead, req.lead_tip)
    tilt = req.tilt if req.tilt_tip is None else (req.tilt, req.tilt_tip)
    return AxisStrategy(
        mode=req.axis_mode,
        lead=lead,
        tilt=tilt,
        radial=req.radial_tilt,
        point=req.axis_point,
        direction=req.axis_direction,
        max_turn=req.max_axis_turn,
    )


def _link_options(req: PathRequest, rho: float | None = None) -> LinkOptions:
    if req.link not in LINK_MODES:
        raise BliskCamError(f"unknown link mode {req.link!r}; use one of {', '.join(LINK_MODES)}")
    clear = None
    if req.clearance_radius is not None:
        clear = Clearance(req.clearance_radius, req.clearance_z0, req.clearance_slope)
    return LinkOptions(
        mode=req.link,
        climb=bool(req.climb),
        order=req.order,
        approach=req.approach,
        clearance=clear,
        clearance_margin=req.clearance_margin,
        direct_link=req.direct_link,
        chord=req.chord,
        tool_radius=req.tool_radius if rho is None else rho,
    )


def _plane_cusp_radius(cutter: Cutter, axis, cusp: float) -> float:
    """Radius (mm) of the ball that leaves the same scallop ``cusp`` on a plane at the same
    side step as ``cutter`` posed with unit ``axis`` (3,) in the frame f = x, n = z, k = f × n.

    The swept envelope's cross-section across the feed is the lower boundary of the cutter's
    projection along f (a convex solid); its height z(y) over the side offset y is sampled from
    the revolved profile, the step w whose two neighbouring passes cross at height ``cusp`` is
    bisected, and a ball of radius (w²/4 + h²)/2h has the same step."""
    n = np.array([0.0, 0.0, 1.0])
    f = np.array([1.0, 0.0, 0.0])
    k = np.cross(f, n)
    off = cutter.cl_points(np.zeros((1, 3)), n[None], axis[None])[0]  # tip for cc = origin
    prof = cutter.profile(256)
    u1 = np.cross(axis, [0.0, 1.0, 0.0] if abs(axis[1]) < 0.9 else [1.0, 0.0, 0.0])
    u1 /= np.linalg.norm(u1)
    u2 = np.cross(axis, u1)
    ph = np.linspace(0.0, 2 * np.pi, 1440, endpoint=False)
    radial = np.cos(ph)[:, None] * u1 + np.sin(ph)[:, None] * u2  # (a, 3)
    P = off + prof[:, 0, None, None] * radial[None] + prof[:, 1, None, None] * axis  # (p, a, 3)
    y = (P @ k).ravel()
    z = (P @ n).ravel()
    # the projection of a convex solid is convex: its lower boundary is the lower hull
    hull = ConvexHull(np.stack([y, z], axis=1))
    hv = hull.points[hull.vertices]
    i0, i1 = int(np.argmin(hv[:, 0])), int(np.argmax(hv[:, 0]))
    # vertices are counter-clockwise: from the leftmost to the rightmost runs the lower chain
    idx = [(i0 + j) % len(hv) for j in range(((i1 - i0) % len(hv)) + 1)]
    chain = hv[idx]
    yc = np.linspace(chain[0, 0], chain[-1, 0], 8001)
    low = np.interp(yc, chain[:, 0], chain[:, 1])
    low = low - low.min()
    y0 = float(yc[np.argmin(low)])  # the contact

    def crossing(w):  # scallop between passes at 0 and w: max over y of min of the two profiles
        between = (yc >= y0) & (yc <= y0 + w)
        if not np.any(between):
            return 0.0
        yy = yc[between]
        other = np.interp(yy - w, yc, low, left=np.inf, right=np.inf)
        return float(np.max(np.minimum(low[between], other)))

    lo_w, hi_w = 0.0, float(yc.max() - yc.min())
    if crossing(hi_w) < cusp:
        return np.inf
    for _ in range(50):
        mid = 0.5 * (lo_w + hi_w)
        if crossing(mid) < cusp:
            lo_w = mid
        else:
            hi_w = mid
    w = lo_w
    return (0.25 * w * w + cusp * cusp) / (2.0 * cusp)


def expansion_radius(cutter: Cutter, strategy: AxisStrategy, cusp: float = 0.05) -> float:
    """Radius (mm) of the ball the passes are spaced for: over the strategy's lead/tilt range
    (a 5 × 5 grid), the smallest of the cutter's cross-feed effective radius (the osculating
    circle of the swept envelope, :meth:`.cutter.Cutter.effective_radius`) and the radius of
    the ball leaving the same scallop ``cusp`` on a plane (the envelope's secant at the cusp
    height — the osculating radius alone over-estimates a bull nose's or flat end's side step,
    since its envelope curves more away from the contact); capped at ``MAX_EXPANSION_FACTOR``
    × the tool radius."""
    if cutter.type == "ball":
        return cutter.radius
    if strategy.mode in ("local", "radial"):
        (l0, l1), (t0, t1) = strategy.angle_bounds()
    else:
        l0, l1, t0, t1 = 0.0, math.radians(80.0), 0.0, 0.0
    L, T = np.meshgrid(np.linspace(l0, l1, 5), np.linspace(t0, t1, 5))
    L, T = np.unique(np.stack([L.ravel(), T.ravel()], 1), axis=0).T
    n = np.tile([0.0, 0.0, 1.0], (len(L), 1))
    f = np.tile([1.0, 0.0, 0.0], (len(L), 1))
    k = np.cross(f, n)
    a = lead_tilt_axes(f, n, k, L, T)
    r = cutter.effective_radius(n, a, k)
    sec = np.array([_plane_cusp_radius(cutter, ai, float(cusp)) for ai in a])
    return float(min(np.min(r), np.min(sec), MAX_EXPANSION_FACTOR * cutter.radius))


def _check(req: PathRequest):
    cutter = make_cutter(req)
    strategy = _strategy(req)
    opts = _link_options(req)
    limits = GougeLimits(max_lead=req.gouge_max_lead, max_tilt=req.gouge_max_tilt)
    if not (math.isfinite(req.zero_speed_tol) and req.zero_speed_tol >= 0):
        raise BliskCamError(f"zero-speed tolerance must be ≥ 0 mm, got {req.zero_speed_tol!r}")
    if cutter.type == "flat" and strategy.mode == "local":
        ss = np.linspace(0.0, 1.0, 101)
        flush = (np.abs(strategy.at("lead", ss)) < math.radians(0.5)) & (
            np.abs(strategy.at("tilt", ss)) < math.radians(0.5)
        )
        if np.any(flush):
            raise OrientationError(
                "a flat end mill with lead = tilt = 0 touches with its whole face (zero cutting "
                "speed at the centre, no defined side step): give a lead of a few degrees "
                "(e.g. --lead 5) or use a ball or bull-nose cutter"
            )
    if strategy.mode == "local" and req.fix_local_gouge:
        (l0, l1), (t0, t1) = strategy.angle_bounds()
        if max(abs(l0), abs(l1)) > limits.max_lead or max(abs(t0), abs(t1)) > limits.max_tilt:
            raise OrientationError(
                f"the requested lead/tilt exceed the local-gouge fix limits (lead ≤ "
                f"{math.degrees(limits.max_lead):.1f}°, tilt ≤ {math.degrees(limits.max_tilt):.1f}°); "
                "raise gouge_max_lead/gouge_max_tilt or switch fix_local_gouge off"
            )
    return cutter, strategy, opts, limits


def _orient(curve, mesh, projector, cutter, strategy, limits, req, blisk_axis, report):
    """Axes, flags and tips of one pass in place."""
    cc, nrm, closed = curve.cc, curve.normal, curve.closed
    s = curve.ratios
    flags = np.zeros(len(cc), dtype=np.uint8)
    if strategy.mode == "local":
        f, n, k = local_frames(cc, nrm, closed)
        lead, tilt = strategy.at("lead", s), strategy.at("tilt", s)
        if len(curve.face) == len(cc) and np.all(curve.face >= 0):
            faces = curve.face
        else:
            _, _, faces = projector.project(cc)
        kf = surface_normal_curvature(mesh, faces, f)
        kk = surface_normal_curvature(mesh, faces, k)
        lead2, tilt2, flagged, left, margin = fix_local_gouges(
            cutter, f, n, k, lead, tilt, kf, kk, limits, fix=req.fix_local_gouge
        )
        want = lead_tilt_axes(f, n, k, lead2, tilt2)
        flags[flagged & ~left] |= FLAG_GOUGE_FIXED
        flags[left] |= FLAG_LOCAL_GOUGE
        report.add(
            LocalGougeReport(
                n_poses=len(cc),
                n_flagged=int(flagged.sum()),
                n_fixed=int((flagged & ~left).sum()),
                n_left=int(left.sum()),
                worst=float(min(0.0, margin[left].min())) if left.any() else 0.0,
                left_at=cc[left],
            )
        )
    else:
        want = axes_for_curve(cc, nrm, closed, s, strategy, blisk_axis)
        report.add(LocalGougeReport(n_poses=len(cc)))
    axes = want
    if strategy.max_turn is not None:
        axes = smooth_axes(want, nrm, strategy.max_turn, closed)
        moved = np.einsum("ij,ij->i", axes, want) < math.cos(1e-6)
        flags[moved] |= FLAG_AXIS_SMOOTHED
    flags[cutter.zero_speed(nrm, axes, req.zero_speed_tol)] |= FLAG_ZERO_SPEED
    curve.axis = axes
    curve.tip = cutter.cl_points(cc, nrm, axes)
    curve.flags = curve.flags | flags


def iter_plan_paths(mesh: TriMesh, req: PathRequest):
    """Generator: yields Progress, returns a :class:`PlanResult`.

    Raises
    ------
    BliskCamError (ToolError, OrientationError, LinkError, ConeError, ToleranceError …) with a
    message naming the problem, before any long work where the request itself is bad.
    """
    cutter, strategy, opts, limits = _check(req)
    fit = None
    c1, c2 = req.cone1, req.cone2
    if c1 is None or c2 is None:
        fit = fit_cones_to_mesh(mesh, req.axis)
        c1 = c1 or fit.cone1
        c2 = c2 or fit.cone2
    rho = expansion_radius(cutter, strategy, req.cusp)
    passes = yield from iter_generate_paths(
        mesh, req.axis, c1, c2, tool_radius=rho, cusp=req.cusp, chord=req.chord
    )
    yield Progress(1.0, "orienting and linking")
    morph = MorphingCones(passes.cone1, passes.cone2)
    projector = SurfaceProjector(mesh, req.axis, morph)
    opts = _link_options(req, rho)
    curves = order_passes(passes.curves, opts, morph, req.axis, projector)
    report = LocalGougeReport()
    for c in curves:
        _orient(c, mesh, projector, cutter, strategy, limits, req, req.axis, report)
    program = build_program(
        curves,
        opts,
        req.axis,
        tool_radius=cutter.radius,
        projector=projector,
        cl_points=cutter.cl_points,
    )
    turns = [consecutive_turn(c.axis, c.closed) for c in curves if len(c.cc) > 1]
    stats = dict(passes.stats)
    stats.update(
        {
            "expansion_radius": float(rho),
            "curves": len(curves),
            "poses": int(sum(len(c.cc) for c in curves)),
            "max_axis_turn": float(max((t.max() for t in turns if len(t)), default=0.0)),
            "local_gouge": report.summary(),
            "zero_speed_poses": int(
                sum(int(np.count_nonzero(c.flags & FLAG_ZERO_SPEED)) for c in curves)
            ),
            "link": opts.mode,
        }
    )
    path = ToolPath(
        axis=req.axis,
        cone1=passes.cone1,
        cone2=passes.cone2,
        tool=cutter,
        cusp=req.cusp,
        chord=req.chord,
        curves=curves,
        stats=stats,
        program=program,
    )
    return PlanResult(path=path, fit=fit, gouge=report)


def plan_paths(mesh: TriMesh, req: PathRequest) -> PlanResult:
    """Run :func:`iter_plan_paths` to the end."""
    it = iter_plan_paths(mesh, req)
    while True:
        try:
            next(it)
        except StopIteration as stop:
            return stop.value
