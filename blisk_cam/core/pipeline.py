"""One entry point from user settings to a finished tool path: the request the panel, the
operators and the CLI all fill in, and the run that turns it into a :class:`ToolPath`.

Stages (each its own module, one concept of the papers each):
cone fitting (:mod:`.fitting`, when a cone is not given) → LMC passes of CC points
(:mod:`.pathgen`, paper 001) → machining order and direction, spiral blending
(:mod:`.linking`, paper 002) → tool axes from lead/tilt (:mod:`.orientation`, paper 003) →
local gouge check and fix (:mod:`.local_gouge`) → axis smoothing → cutter location per cutter
type (:mod:`.cutter`, paper 003) → the linked program with approach/retract/links.

Pass spacing for non-ball cutters. :mod:`.pathgen` spaces passes for a ball. With lead/tilt
given in the local frame, the cutter's swept envelope across the feed does not depend on the
surface, so the passes are spaced for the ball that leaves the same scallop at the same step
(:func:`expansion_radius`), the smallest over the requested lead/tilt range (the conservative
choice). Two surface figures enter (:func:`surface_radii`): the smallest convex radius — a
bull nose's or flat end's envelope trails the contact, and rolled around a thin leading edge
it covers less than on a plane (issue #4: a flat at lead 10° left 0.17 mm for 0.05 mm at the
demo blade's 0.3 mm edges) — and the smallest concave radius: a hub fillet tighter than the
equivalent ball can only be finished if the local gouge fix may raise the lead until the
cutter fits (the passes are then spaced for that lead range and a ball that fits the fillet),
otherwise the request is refused before any path work with the figures and the way out
(:func:`_fit_concave`). The true tips then come from the cutter itself. For fixed-axis modes
the inclination is not known in advance and the range 0–80° is used.
``PlanResult.path.stats`` records ``expansion_radius``, ``edge_radius``, ``concave_radius``.

Angles are radians, lengths mm, as everywhere in core. ``iter_plan_paths`` yields
:class:`~.pathgen.Progress` and returns a :class:`PlanResult` (``StopIteration.value``) so a
modal operator can drive it and cancel between yields; ``plan_paths`` exhausts it.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from .cones import Axis, Cone
from .cutter import Cutter
from .errors import BliskCamError, ToleranceError
from .fitting import ConeFit, fit_cones_to_mesh
from .linking import Clearance, LinkOptions, SurfaceProjector, build_program, order_passes
from .lmrs import morph_between
from .local_gouge import (
    GougeLimits,
    LocalGougeReport,
    fix_local_gouges,
    fix_near_gouges,
    surface_normal_curvature,
)
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
    "convex_edge_radius",
    "surface_radii",
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


def _cusp_equivalent_radius(cutter: Cutter, axis, cusp: float, edge_radius: float = math.inf):
    """Radius (mm) of the ball that leaves the same scallop ``cusp`` at the same side step as
    ``cutter`` posed with unit ``axis`` (3,) in the frame f = x, n = z, k = f × n — on a plane
    (``edge_radius`` ∞) or on a convex cylinder of radius ``edge_radius`` about k (a leading or
    trailing edge, the pass running around it).

    Why the edge matters. Across the feed, a posed ball's envelope is a great circle through
    the contact (feed offset x = 0 at every side offset y); a bull nose's or flat end's is not:
    with lead λ the point of a flat's bottom rim at side offset y trails the contact by
    x ≈ cos λ · y² / 2R while rising only z ≈ sin λ · y² / 2R. On a plane only z counts; as the
    tool rolls around an edge of radius r_e (the pass turning about k) the point sweeps a circle
    about the edge's axis at the distance ``hypot(x, z + r_e) − r_e ≈ z + x² / 2 r_e`` from the
    surface, so the rim covers less across the feed — the demo blade's 0.3 mm edges left
    0.17 mm for a 0.05 mm tolerance with a flat at lead 10° spaced for the plane (issue #4).

    The envelope's cross-section (height above the surface over y) is the lower boundary of the
    cutter's points mapped to (y, height), sampled from the revolved profile and binned in y;
    the step w whose neighbouring passes cross at height ``cusp`` is bisected, and a ball of
    radius (w²/4 + h²)/2h has the same step on a plane. The ball rolling around the same edge
    leaves the same scallop as on the plane (its envelope has x = 0), so spacing for this ball
    holds the tolerance on the edge as well."""
    n = np.array([0.0, 0.0, 1.0])
    f = np.array([1.0, 0.0, 0.0])
    k = np.cross(f, n)
    off = cutter.cl_points(np.zeros((1, 3)), n[None], axis[None])[0]  # tip for cc = origin
    prof0 = cutter.profile(128)
    prof0 = prof0[: int(np.searchsorted(prof0[:, 1], cutter.radius, side="right")) + 1]
    seg = np.linalg.norm(np.diff(prof0, axis=0), axis=1)
    t0 = np.concatenate([[0.0], np.cumsum(seg)])  # arc length along the profile

    def resample(ta, tb, step):  # profile points every ``step`` mm of arc in [ta, tb]
        tt = np.linspace(ta, tb, int((tb - ta) / step) + 2)
        return tt, np.stack([np.interp(tt, t0, prof0[:, j]) for j in (0, 1)], 1)

    u1 = np.cross(axis, [0.0, 1.0, 0.0] if abs(axis[1]) < 0.9 else [1.0, 0.0, 0.0])
    u1 /= np.linalg.norm(u1)
    u2 = np.cross(axis, u1)
    re = float(edge_radius)

    def points(prof, ph):  # (y, height) (p, a) of the profile revolved to the angles ph
        radial = np.cos(ph)[:, None] * u1 + np.sin(ph)[:, None] * u2  # (a, 3)
        P = off + prof[:, 0, None, None] * radial[None] + prof[:, 1, None, None] * axis
        x, y, z = P @ f, P @ k, P @ n
        h = np.hypot(x, z + re) - re if math.isfinite(re) else z
        return y, h

    # coarse samples find where the cutter comes within 2 cusp of the surface; fine samples
    # there (4 µm along the profile, 1/32° about the axis): a flat's rim is a sharp edge, and
    # rolled around an edge only the points of one angle come close — every 5 µm bin below
    # must hold points of the true boundary
    tc, pc = resample(0.0, t0[-1], 0.03)
    coarse = np.linspace(0.0, 2 * np.pi, 720, endpoint=False)
    _, h = points(pc, coarse)
    close = h <= 2.0 * cusp
    near = np.nonzero(close.any(axis=0))[0]
    near = np.unique(np.concatenate([near - 1, near, near + 1]) % len(coarse))
    rows = np.nonzero(close.any(axis=1))[0]
    ta, tb = tc[max(rows.min() - 1, 0)], tc[min(rows.max() + 1, len(tc) - 1)]
    _, pf = resample(ta, tb, 0.004)
    sub = np.arange(16) / 16.0 * (coarse[1] - coarse[0])
    y, h = points(pf, (coarse[near][:, None] + sub[None, :]).ravel())
    y, h = y.ravel(), h.ravel()
    # lower boundary over y: the least height per 5 µm bin. Rolled around an edge only the
    # points of one angle come close (x ≈ 0), spaced along y by the profile sampling: empty
    # bins between filled ones are interpolated (the boundary is smooth there); beyond the
    # sampled angles it lies above any cusp of interest
    nb = max(int((y.max() - y.min()) / 0.005), 2)
    edges = np.linspace(y.min(), y.max(), nb + 1)
    b = np.clip(np.searchsorted(edges, y, side="right") - 1, 0, nb - 1)
    low = np.full(nb, np.inf)
    np.minimum.at(low, b, h)
    yc = 0.5 * (edges[:-1] + edges[1:])
    have = np.isfinite(low)
    low = np.interp(yc, yc[have], low[have], left=10.0 * cusp, right=10.0 * cusp)
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


def surface_radii(mesh: TriMesh, axis: Axis, morph) -> tuple[float, float]:
    """(smallest convex, smallest concave) principal radius of curvature (mm) of the mesh
    between the cones; ∞ where the surface never curves that way.

    Per face whose centroid lies in the band 0 ≤ s ≤ 1: the shape operator is the symmetric
    part of the Jacobian of the linearly interpolated vertex normals (the curvature tool of
    :mod:`.local_gouge`), restricted to the face's tangent plane; its eigenvalues are the
    principal curvatures (> 0 convex, outward normals). A thin leading/trailing edge sets the
    convex radius (the demo blade: 0.27 mm, Rotor 37: 0.08 mm), a hub fillet the concave one
    (the demo's 8 mm fillet: 4.2 mm where it meets the trailing edge)."""
    V, F = mesh.V, mesh.F
    s = morph.ratio_of_points(V[F].mean(axis=1), axis)
    band = np.nonzero((s >= -1e-6) & (s <= 1 + 1e-6))[0]
    if len(band) == 0:
        return math.inf, math.inf
    Fb = F[band]
    fn = mesh.face_normals[band]
    a2 = mesh.face_areas[band] * 2.0
    inv = np.where(a2 > 0, 1.0 / np.where(a2 > 0, a2, 1.0), 0.0)
    vn = mesh.vertex_normals
    J = np.zeros((len(band), 3, 3))
    for i in range(3):
        e = V[Fb[:, (i + 2) % 3]] - V[Fb[:, (i + 1) % 3]]
        g = np.cross(fn, e) * inv[:, None]  # gradient of corner i's hat function
        J += vn[Fb[:, i]][:, :, None] * g[:, None, :]
    P = np.eye(3)[None] - fn[:, :, None] * fn[:, None, :]
    S = P @ (0.5 * (J + J.transpose(0, 2, 1))) @ P
    w = np.linalg.eigvalsh(S)  # ascending; one eigenvalue ≈ 0 belongs to the normal
    kmin, kmax = float(w[:, 0].min()), float(w[:, 2].max())
    return (1.0 / kmax if kmax > 0 else math.inf, -1.0 / kmin if kmin < 0 else math.inf)


def convex_edge_radius(mesh: TriMesh, axis: Axis, morph) -> float:
    """Smallest convex radius of curvature (mm) between the cones (:func:`surface_radii`)."""
    return surface_radii(mesh, axis, morph)[0]


def _lead_for_concave(cutter: Cutter, strategy: AxisStrategy, limits, concave: float):
    """Smallest |lead| (radians) at which ``cutter`` curves at least as much as a concave
    surface of radius ``concave`` (mm) in both the feed and the side direction (the local
    gouge condition, :mod:`.local_gouge`), searching leads from the requested one up to the
    gouge-fix limit at the requested tilts; None when no lead within the limit does.

    Returns (lead or None, the smallest effective radius (mm) reachable within the limit)."""
    (l0, l1), (t0, t1) = strategy.angle_bounds()
    lead0 = max(abs(l0), abs(l1))
    leads = np.linspace(lead0, max(limits.max_lead, lead0), 121)
    tilts = np.linspace(t0, t1, 3)
    L, T = (x.ravel() for x in np.meshgrid(leads, tilts, indexing="ij"))
    n = np.tile([0.0, 0.0, 1.0], (len(L), 1))
    f = np.tile([1.0, 0.0, 0.0], (len(L), 1))
    k = np.cross(f, n)
    a = lead_tilt_axes(f, n, k, L, T)
    try:
        eff = np.maximum(cutter.effective_radius(n, a, f), cutter.effective_radius(n, a, k))
    except BliskCamError:
        return None, math.inf
    eff = np.max(eff.reshape(len(leads), len(tilts)), axis=1)  # every requested tilt must fit
    fits = np.nonzero(eff <= concave)[0]
    return (float(leads[fits[0]]) if len(fits) else None), float(eff.min())


def expansion_radius(
    cutter: Cutter, strategy: AxisStrategy, cusp: float = 0.05, edge_radius: float = math.inf
) -> float:
    """Radius (mm) of the ball the passes are spaced for: over the strategy's lead/tilt range
    (a 5 × 5 grid), the smallest of the cutter's cross-feed effective radius (the osculating
    circle of the swept envelope, :meth:`.cutter.Cutter.effective_radius`) and the radius of
    the ball leaving the same scallop ``cusp`` on a plane and, with ``edge_radius`` (mm, the
    smallest convex radius the passes run around, :func:`convex_edge_radius`), on that edge
    (:func:`_cusp_equivalent_radius` — the osculating radius alone over-estimates a bull nose's
    or flat end's side step, since its envelope curves more away from the contact, and an
    edge costs it more); capped at ``MAX_EXPANSION_FACTOR`` × the tool radius."""
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
    radii = [math.inf] if not math.isfinite(edge_radius) else [math.inf, float(edge_radius)]
    sec = np.array(
        [_cusp_equivalent_radius(cutter, ai, float(cusp), re) for ai in a for re in radii]
    )
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
                f"{math.degrees(limits.max_lead):.1f}°, "
                f"tilt ≤ {math.degrees(limits.max_tilt):.1f}°); "
                "raise gouge_max_lead/gouge_max_tilt or switch fix_local_gouge off"
            )
    return cutter, strategy, opts, limits


def _orient(
    curve, mesh, projector, cutter, strategy, limits, req, blisk_axis, report, near_field=None
):
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
        if near_field is not None:  # the cutter's reach beyond the contact (a fillet corner)
            S, tree = near_field
            lead2, tilt2, nflag, nleft, _ = fix_near_gouges(
                cutter, S, cc, f, n, k, lead2, tilt2, limits, tol=0.25 * req.chord,
                fix=req.fix_local_gouge, tree=tree,
            )
            flagged, left = flagged | nflag, (left & ~nflag) | nleft
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


def _fit_concave(
    cutter, strategy, limits, req, edge: float, concave: float, rho: float
) -> float:
    """Pass spacing radius (mm) given a concave region of radius ``concave`` (a hub fillet)
    and the radius ``rho`` the passes would be spaced for, or a ToleranceError naming the fix.

    Nothing changes when the requested orientation already curves at least as much as the
    region and ``rho`` fits it.
    The local gouge fix (:mod:`.local_gouge`) raises the lead there until the cutter's
    effective radius fits; the passes are then spaced for the whole lead range the path will
    use (requested → needed, :func:`expansion_radius`) and for a ball that fits the concave
    region itself (:mod:`.pathgen` spaces with a ball). When no lead within the gouge-fix
    limit fits — or the fix is off, or the axis is not lead/tilt — the request cannot be
    finished without gouging: say so, with the figures."""
    kind = {"bull": "bull-nose", "flat": "flat end mill", "taper": "taper cutter"}[cutter.type]
    (l0, l1), _ = strategy.angle_bounds()
    lead0 = max(abs(l0), abs(l1))
    lead_txt = f"{math.degrees(lead0):.1f}°"
    need, best = (None, math.inf)
    if strategy.mode == "local":
        need, best = _lead_for_concave(cutter, strategy, limits, concave)
        if need is not None and need <= lead0 + 1e-12 and rho <= concave:
            return rho  # the requested orientation already fits the concave region
    if rho <= concave and (strategy.mode != "local" or not req.fix_local_gouge):
        return rho  # the gouge check flags what does not fit (fix off / fixed axis)
    if need is None or not req.fix_local_gouge:
        req_eff = best
        if strategy.mode == "local":
            f = np.array([[1.0, 0.0, 0.0]])
            n = np.array([[0.0, 0.0, 1.0]])
            a = lead_tilt_axes(f, n, np.cross(f, n), max(abs(l0), abs(l1)), 0.0)
            req_eff = float(cutter.effective_radius(n, a, np.cross(f, n))[0])
        hint = (
            f"a lead of {math.degrees(need):.1f}° would fit: switch the local gouge fix on"
            if need is not None
            else "use lead/tilt (mode 'local') so the gouge fix can raise the lead"
            if strategy.mode != "local"
            else f"no lead up to the gouge-fix limit {math.degrees(limits.max_lead):.0f}° fits "
            f"(the smallest effective radius reachable is {best:.1f} mm)"
        )
        eff_txt = (
            f"({req_eff:.1f} mm at lead {lead_txt})"
            if math.isfinite(req_eff)
            else f"(mode {strategy.mode!r} cannot raise the lead to fit it)"
        )
        raise ToleranceError(
            f"the surface between the cones has a concave region of radius {concave:.2f} mm (e.g. "
            f"the hub fillet) tighter than the {kind}'s effective radius across the feed "
            f"{eff_txt}; {hint}. Use a ball of radius ≤ {concave:.2f} mm, or move the hub cone "
            "off the fillet"
        )
    wide = AxisStrategy(
        mode="local",
        lead=(min(l0, -need) if l0 < 0 and l1 <= 0 else l0, max(l1, need) if l1 >= 0 else l1),
        tilt=strategy.tilt,
    )
    return min(expansion_radius(cutter, wide, req.cusp, edge), 0.95 * concave)


def iter_plan_paths(mesh: TriMesh, req: PathRequest):
    """Generator: yields Progress, returns a :class:`PlanResult`.

    Raises
    ------
    BliskCamError (ToolError, OrientationError, LinkError, ConeError, ToleranceError …) with a
    message naming the problem, before any long work where the request itself is bad.
    """
    t_plan = time.perf_counter()
    cutter, strategy, opts, limits = _check(req)
    fit = None
    c1, c2 = req.cone1, req.cone2
    if c1 is None or c2 is None:
        fit = fit_cones_to_mesh(mesh, req.axis)
        c1 = c1 or fit.cone1
        c2 = c2 or fit.cone2
    edge = concave = math.inf
    if cutter.type != "ball":
        edge, concave = surface_radii(mesh, req.axis, morph_between(c1, c2))
    rho = expansion_radius(cutter, strategy, req.cusp, edge)
    if math.isfinite(concave):
        rho = _fit_concave(cutter, strategy, limits, req, edge, concave, rho)
    times = {"seconds_fit": time.perf_counter() - t_plan}
    gen = iter_generate_paths(
        mesh, req.axis, c1, c2, tool_radius=rho, cusp=req.cusp, chord=req.chord
    )
    passes = yield from _timed(gen, times, "seconds_passes")
    yield Progress(1.0, "orienting and linking")
    t1 = time.perf_counter()
    morph = morph_between(passes.cone1, passes.cone2)  # LMC, or LMRS for a Profile
    projector = SurfaceProjector(mesh, req.axis, morph)
    opts = _link_options(req, rho)
    curves = order_passes(passes.curves, opts, morph, req.axis, projector)
    t2 = time.perf_counter()
    report = LocalGougeReport()
    near_field = None
    if cutter.type != "ball" and math.isfinite(concave):
        # a concave region: check the cutter against the surface around each contact too
        S = np.vstack([mesh.V, mesh.V[mesh.F].mean(axis=1)])
        near_field = (S, cKDTree(S))
    for c in curves:
        _orient(c, mesh, projector, cutter, strategy, limits, req, req.axis, report, near_field)
    t3 = time.perf_counter()
    program = build_program(
        curves,
        opts,
        req.axis,
        tool_radius=cutter.radius,
        projector=projector,
        cl_points=cutter.cl_points,
    )
    t4 = time.perf_counter()
    turns = [consecutive_turn(c.axis, c.closed) for c in curves if len(c.cc) > 1]
    stats = dict(passes.stats)
    stats.update(
        {
            "expansion_radius": float(rho),
            # smallest convex / concave radius between the cones (None: not needed, a ball)
            "edge_radius": float(edge) if math.isfinite(edge) else None,
            "concave_radius": float(concave) if math.isfinite(concave) else None,
            "curves": len(curves),
            "poses": int(sum(len(c.cc) for c in curves)),
            "max_axis_turn": float(max((t.max() for t in turns if len(t)), default=0.0)),
            "local_gouge": report.summary(),
            "zero_speed_poses": int(
                sum(int(np.count_nonzero(c.flags & FLAG_ZERO_SPEED)) for c in curves)
            ),
            "link": opts.mode,
            # wall time per stage, s; "seconds" (from pathgen) stays the pass generation
            # alone. Time the caller spends between progress steps is not counted.
            **times,
            "seconds_orient": t3 - t2,
            "seconds_link": (t2 - t1) + (t4 - t3),
            "seconds_plan": times["seconds_fit"] + times["seconds_passes"] + (t4 - t1),
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


def _timed(gen, times: dict, key: str):
    """``yield from gen``, adding to ``times[key]`` only the time spent inside ``gen`` (not the
    caller's time between progress steps); returns the generator's value."""
    times[key] = times.get(key, 0.0)
    t0 = time.perf_counter()
    while True:
        try:
            item = next(gen)
        except StopIteration as stop:
            times[key] += time.perf_counter() - t0
            return stop.value
        times[key] += time.perf_counter() - t0
        yield item
        t0 = time.perf_counter()


def plan_paths(mesh: TriMesh, req: PathRequest) -> PlanResult:
    """Run :func:`iter_plan_paths` to the end."""
    it = iter_plan_paths(mesh, req)
    while True:
        try:
            next(it)
        except StopIteration as stop:
            return stop.value
