"""Blade finishing (paper 001), the first operation of the process: the request the panel,
the operators and the CLI all fill in (:class:`PathRequest`), and the run that turns it into a
:class:`ToolPath` (:class:`BladeFinish`, driven by :mod:`.operation`).

Stages, each over one :class:`PlanState`, each stage's work in its own module:
fit (:mod:`..part.fitting`, when a cone is not given; the spacing radius of the cutter,
:mod:`..paths.spacing`) → passes (LMC passes of CC points, :mod:`..paths.passes`, paper 001)
→ order (machining order and direction, spiral blending, :mod:`..paths.linking`, paper 002)
→ orient (tool axes from lead/tilt, :mod:`..paths.orientation`, paper 003; local gouge check
and fix, :mod:`..paths.gouge`; axis smoothing; cutter location per cutter type,
:mod:`..tool.cutter`) → link (approach, retract, links) → checks (the figures in the stats);
the collision check (:func:`.collision_stage.collision_stage`) is an extra stage the caller
adds.

A hub fillet tighter than the spacing ball can only be finished if the local gouge fix may
raise the lead until the cutter fits (the passes are then spaced for that lead range and a
ball that fits the fillet); otherwise the request is refused before any path work with the
figures and the way out (:func:`_fit_concave`). ``PlanResult.path.stats`` records
``expansion_radius``, ``edge_radius``, ``concave_radius``.

Semi-finishing (``allowance`` a > 0, paper 003 §5: the blade left 0.1 mm oversize for the
finishing cut). The paths machine the blade offset outward by a, with the same boundary
conformity (first pass on cone 1, last on cone 2), scallop and chord rules and local gouge
check. They are planned on the true blade with the cutter grown by a
(:meth:`..tool.cutter.Cutter.grown`: ball ρ → ρ + a, bull nose R, r → R + a, r + a, flat →
corner a): the offset surface machined by the cutter is exactly the true surface machined by
the grown cutter (the offset of the swept solid is the sweep of the offset solid), so every
stage — spacing, passes, local gouge fix, the swept link check — runs unchanged on the mesh
as given, with no offset mesh to build (an offset of a triangle mesh self-intersects at
concave places and loses the mesh's exact boundary on the cones). The last stage
(:func:`_stage_allowance`) then reports the path of the real cutter: every CC point moves
out along its normal by a (onto the offset surface, where the real cutter touches) and every
tip, links and rapids included, up its own axis by a (the grown cutter's corner circles are
the real cutter's, so the real cutter sits a higher on the same axis). The scallop left on
the offset surface is the grown cutter's scallop on the blade, so the material left on the
blade lies between a − chord and a + cusp + chord. Refused (ToleranceError) when a is at least
the smallest concave radius between the cones: the offset surface folds there (a fillet of
radius ρ offset by a ≥ ρ has no surface left to touch), and — where the blade count is known
(the command line checks it before planning, :func:`check_allowance_in_channel`) — when a is
at least half the narrowest gap to the neighbour blade. ``path.allowance`` records a (the
paths JSON's ``tolerances.allowance``, read by verify, nc and simulate); ``stats`` adds
``allowance`` and ``planning_tool_radius``, the grown cutter's radius (``expansion_radius`` is
the grown cutter's spacing radius).

Angles are radians, lengths mm, as everywhere in core. ``iter_plan_paths`` yields
:class:`~..runtime.Progress` and returns a :class:`PlanResult` (``StopIteration.value``) so a
modal operator can drive it and cancel between yields; ``plan_paths`` exhausts it.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import BliskCamError, OrientationError, ToleranceError, ToolError
from ..geometry.axis import Axis, cylindrical
from ..geometry.distance import MeshDistance, NearestFaces
from ..geometry.mesh import TriMesh
from ..geometry.vectors import rotation_matrix
from ..options import (
    AxisOptions,
    CutterOptions,
    GougeOptions,
    LinkingOptions,
    ToleranceOptions,
    describe_tool,
)
from ..part.cones import Cone
from ..part.fitting import ConeFit, fit_cones_to_mesh, region_holes
from ..part.profiles import morph_between
from ..paths.gouge import (
    GougeLimits,
    LocalGougeReport,
)
from ..paths.link_check import SweptLinkCheck
from ..paths.linking import Clearance, LinkOptions, SurfaceProjector, build_program, order_passes
from ..paths.orientation import (
    AxisStrategy,
    consecutive_turn,
    lead_tilt_axes,
)
from ..paths.passes import iter_generate_paths
from ..paths.spacing import expansion_radius, lead_for_concave, surface_radii
from ..runtime import Progress, scaled_progress
from ..tool.cutter import Cutter
from ..toolpath.types import (
    FLAG_ZERO_SPEED,
    ToolPath,
)
from .operation import (
    Operation,
    OperationResult,
    Stage,
    iter_run_operation,
    run_operation,
)
from .orient_passes import orient_passes
from .semi_layers import join_programs, layer_allowances, merge_layer_stats

__all__ = [
    "PLAN_STAGES",
    "PathRequest",
    "PlanResult",
    "PlanState",
    "Stage",
    "check_allowance_in_channel",
    "NotSupportedError",
    "ZERO_SPEED_WARN_SHARE",
    "zero_speed_warning",
    "iter_plan_paths",
    "make_cutter",
    "plan_paths",
]

TOOL_TYPES = ("ball", "bull", "flat", "taper")
LINK_MODES = ("oneway", "zigzag", "spiral")


class NotSupportedError(BliskCamError):
    """The request asks for something this version cannot do yet (names what, and the way out)."""


#: the request's stages: attribute name → option class (:mod:`.options`)
REQUEST_STAGES = {
    "cutter": CutterOptions,
    "tolerances": ToleranceOptions,
    "orientation": AxisOptions,
    "gouge": GougeOptions,
    "linking": LinkingOptions,
}
#: option name → stage attribute, for the flat keywords and attributes of a request
_OPTION_STAGE = {
    f.name: stage for stage, cls in REQUEST_STAGES.items() for f in dataclasses.fields(cls)
}


@dataclass(frozen=True, init=False)
class PathRequest:
    """Everything that decides a finishing path, in core units (mm, radians).

    The options live in one frozen stage object each (:mod:`.options` declares every option
    once, with its unit, bounds and help): ``cutter`` (:class:`~.options.CutterOptions`),
    ``tolerances``, ``orientation`` (tool axis), ``gouge`` (local gouge fix), ``linking``.
    Build a request with the stage objects or with flat keywords — ``PathRequest(axis=ax,
    tool_type="bull", tool_diameter=12, corner_radius=2, cusp=0.05, lead=radians(5))`` — and
    read any option flat (``req.lead``, ``req.tool_radius``). ``tool_radius=`` is accepted
    for ``tool_diameter=`` (half of it).

    Attributes
    ----------
    axis : Axis — the blisk axis
    cone1, cone2 : Cone, Profile or None — hub (s = 0) and tip (s = 1) generatrices; None =
        fit from the mesh
    cutter, tolerances, orientation, gouge, linking : the stage options
    extra : dict — options of later stages (kept so the request stays one object)
    """

    axis: Axis
    cone1: Cone | None
    cone2: Cone | None
    cutter: CutterOptions
    tolerances: ToleranceOptions
    orientation: AxisOptions
    gouge: GougeOptions
    linking: LinkingOptions
    extra: dict

    def __init__(self, axis: Axis, cone1=None, cone2=None, *, extra=None, **options):
        stages = {name: options.pop(name, None) for name in REQUEST_STAGES}
        if "tool_radius" in options:
            if "tool_diameter" in options:
                raise TypeError("give tool_diameter or tool_radius, not both")
            radius = float(options.pop("tool_radius"))
            if not radius > 0.0:  # also NaN
                raise ToolError(f"tool radius must be > 0 mm, got {radius:g}")
            options["tool_diameter"] = 2.0 * radius
        routed = {name: {} for name in REQUEST_STAGES}
        for key, value in options.items():
            stage = _OPTION_STAGE.get(key)
            if stage is None:
                raise TypeError(f"PathRequest got an unknown option {key!r}")
            routed[stage][key] = value
        object.__setattr__(self, "axis", axis)
        object.__setattr__(self, "cone1", cone1)
        object.__setattr__(self, "cone2", cone2)
        for name, cls in REQUEST_STAGES.items():
            base = stages[name] if stages[name] is not None else cls()
            if not isinstance(base, cls):
                raise TypeError(f"PathRequest {name}= must be a {cls.__name__}")
            value = dataclasses.replace(base, **routed[name]) if routed[name] else base
            object.__setattr__(self, name, value)
        object.__setattr__(self, "extra", dict(extra or {}))

    def __getattr__(self, name):
        # called only for names that are not attributes: the stage options, read flat
        stage = _OPTION_STAGE.get(name)
        if stage is None and name == "tool_radius":
            stage = "cutter"
        if stage is None or name.startswith("_"):
            raise AttributeError(name)
        return getattr(object.__getattribute__(self, stage), name)

    def stages(self) -> dict:
        """{stage name: stage options}."""
        return {name: getattr(self, name) for name in REQUEST_STAGES}


#: warn when at least this share of the poses cuts at zero speed (``FLAG_ZERO_SPEED``)
ZERO_SPEED_WARN_SHARE = 0.10


def zero_speed_warning(n_zero: int, n_poses: int, share: float = ZERO_SPEED_WARN_SHARE):
    """The warning for ``n_zero`` of ``n_poses`` poses cutting at zero speed, or None when
    they are fewer than ``share`` of the poses."""
    if n_poses <= 0 or n_zero < share * n_poses or n_zero == 0:
        return None
    return (
        f"{n_zero} of {n_poses} poses ({100.0 * n_zero / n_poses:.0f} %) cut with the contact "
        "on the tool axis, where the cutting speed is zero (the tool rubs instead of cutting, "
        "a poor finish and fast wear): tilt the tool off the surface normal — set a lead "
        "angle, e.g. --lead 10 (10°)"
    )


@dataclass
class PlanResult(OperationResult):
    """The path and, when a cone was fitted, the fit (for the residual report): the
    :class:`~.operation.OperationResult` of blade finishing.

    ``gouge`` summarises the local gouge check (:class:`..paths.gouge.LocalGougeReport`).
    ``warnings`` lists every message for the user: the generator's
    (``path.stats["warnings"]``, e.g. uncut poses) and the planning's (``path.warnings``,
    written as the paths JSON's top-level ``"warnings"``, e.g. zero cutting speed)."""

    fit: ConeFit | None = None
    gouge: LocalGougeReport | None = None
    collision: object = None  # .avoidance.CollisionReport when the plan was checked

    @property
    def warnings(self) -> list[str]:
        return [str(w) for w in self.path.stats.get("warnings", []) or []] + list(
            self.path.warnings
        )


def make_cutter(req: PathRequest) -> Cutter:
    """The request's :class:`~..tool.cutter.Cutter` (ToolError on impossible dimensions)."""
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


def _fit_concave(
    cutter, strategy, limits, req, edge: float, concave: float, rho: float
) -> float:
    """Pass spacing radius (mm) given a concave region of radius ``concave`` (a hub fillet)
    and the radius ``rho`` the passes would be spaced for, or a ToleranceError naming the fix.

    Nothing changes when the requested orientation already curves at least as much as the
    region and ``rho`` fits it.
    The local gouge fix (:mod:`..paths.gouge`) raises the lead there until the cutter's
    effective radius fits; the passes are then spaced for the whole lead range the path will
    use (requested → needed, :func:`expansion_radius`) and for a ball that fits the concave
    region itself (:mod:`..paths.passes` spaces with a ball). When no lead within the gouge-fix
    limit fits — or the fix is off, or the axis is not lead/tilt — the request cannot be
    finished without gouging: say so, with the figures."""
    kind = {"bull": "bull-nose", "flat": "flat end mill", "taper": "taper cutter"}[cutter.type]
    (l0, l1), _ = strategy.angle_bounds()
    lead0 = max(abs(l0), abs(l1))
    lead_txt = f"{math.degrees(lead0):.1f}°"
    need, best = (None, math.inf)
    if strategy.mode == "local":
        need, best = lead_for_concave(cutter, strategy, limits, concave)
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


@dataclass
class PlanState:
    """The program as the stages build it (:data:`PLAN_STAGES`): each stage reads what the
    earlier ones left here and adds its part. Lengths mm, angles radians.

    Attributes
    ----------
    mesh, req : the input (never modified)
    cutter, strategy, limits : the request's cutter, axis strategy and gouge-fix limits
    fit : ConeFit or None — set by "fit" when a cone was not given
    cone1, cone2 : the generatrices in use
    edge, concave : smallest convex / concave surface radius between the cones (inf: not
        needed), rho : ball radius the passes are spaced for
    passes : the CC passes of "passes"; morph, projector : the morph field and the surface
        projector shared by the later stages
    link_options : LinkOptions; curves : list of PassCurve in machining order ("order"),
        oriented with tips by "orient"; gouge : LocalGougeReport
    program : Program ("link"); stats : dict (every stage adds; "checks" summarises)
    warnings : list of str — for the user (the paths JSON's top-level "warnings")
    """

    mesh: TriMesh
    req: PathRequest
    cutter: Cutter
    strategy: AxisStrategy
    limits: GougeLimits
    fit: ConeFit | None = None
    cone1: object = None
    cone2: object = None
    edge: float = math.inf
    concave: float = math.inf
    rho: float = 0.0
    passes: object = None
    morph: object = None
    projector: SurfaceProjector | None = None
    nearest: NearestFaces | None = None  # the projector's, made by "passes"
    link_options: LinkOptions | None = None
    curves: list = field(default_factory=list)
    gouge: LocalGougeReport = field(default_factory=LocalGougeReport)
    program: object = None
    stats: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)
    collision: object = None  # CollisionReport of the "collision" stage (when added)
    #: semi-finishing: mm of stock left; ``cutter`` is then the real cutter grown by it
    #: until "allowance" puts the real one (``tool``) back
    allowance: float = 0.0
    tool: Cutter | None = None
    #: semi-finishing in layers: the layers' allowances (:mod:`.semi_layers`), () for one
    layers: tuple = ()

    def result(self) -> PlanResult:
        path = ToolPath(
            axis=self.req.axis,
            cone1=self.passes.cone1 if self.passes is not None else self.cone1,
            cone2=self.passes.cone2 if self.passes is not None else self.cone2,
            tool=self.cutter,
            cusp=self.req.cusp,
            chord=self.req.chord,
            curves=self.curves,
            stats=self.stats,
            program=self.program,
            warnings=self.warnings,
            collision=None if self.collision is None else self.collision.summary(),
            allowance=self.allowance,
        )
        return PlanResult(path=path, fit=self.fit, gouge=self.gouge, collision=self.collision)


def _stage_fit(st: PlanState):
    """Cones not given are fitted to the blade's boundary loops (:mod:`..part.fitting`); the pass
    spacing radius follows from the cutter and the surface (:func:`expansion_radius`)."""
    req = st.req
    st.cone1, st.cone2 = req.cone1, req.cone2
    if st.cone1 is None or st.cone2 is None:
        st.fit = fit_cones_to_mesh(st.mesh, req.axis)
        st.cone1 = st.cone1 or st.fit.cone1
        st.cone2 = st.cone2 or st.fit.cone2
    holes = region_holes(st.mesh, req.axis, st.cone1, st.cone2)
    if holes:  # the passes break at each; nothing is machined or measured there (issue 28)
        shown = "; ".join(h.describe() for h in holes[:3])
        more = f"; and {len(holes) - 3} more" if len(holes) > 3 else ""
        st.stats["holes"] = len(holes)
        st.stats["holes_area"] = float(sum(h.area for h in holes))
        st.warnings.append(
            f"the blade mesh has {len(holes)} hole(s) inside the region between the cones "
            f"({shown}{more}): the passes break at each hole into open pieces and nothing "
            "there is machined or can be verified; fill the holes in the mesh (e.g. a "
            "scan's gaps) or move the cones off them")
    if st.cutter.type != "ball" or st.allowance > 0:
        st.edge, st.concave = surface_radii(st.mesh, req.axis, morph_between(st.cone1, st.cone2))
    if st.allowance > 0 and st.allowance >= st.concave:
        raise ToleranceError(
            f"an allowance of {st.allowance:g} mm is more than the surface between the cones "
            f"allows: its tightest concave radius (e.g. the hub fillet) is {st.concave:.2f} mm, "
            "and the blade offset by the allowance folds over itself there; leave less than "
            f"{st.concave:.2f} mm of stock, or move the hub cone off the fillet")
    if st.cutter.type == "ball":
        st.edge = math.inf  # a ball is spaced without the edge radius (as at allowance 0)
        st.concave = math.inf
    st.rho = expansion_radius(st.cutter, st.strategy, req.cusp, st.edge)
    if math.isfinite(st.concave):
        try:
            st.rho = _fit_concave(st.cutter, st.strategy, st.limits, req, st.edge,
                                  st.concave, st.rho)
        except ToleranceError as err:
            if st.allowance <= 0:
                raise
            raise ToleranceError(
                f"{err} (the allowance of {st.allowance:g} mm counts: the cutter touching "
                "the blade offset by it is planned as the cutter grown by it on the blade, "
                f"a {describe_tool(st.cutter.type, 2 * st.cutter.radius, st.cutter.r)}; "
                "leave less stock or use a smaller cutter)") from None
    return
    yield  # a generator: nothing to report in between


def _stage_passes(st: PlanState):
    """The CC passes: mesh ∩ LMC, sampled for the chord, spaced for the cusp (paper 001)."""
    it = iter_generate_paths(
        st.mesh, st.req.axis, st.cone1, st.cone2, tool_radius=st.rho, cusp=st.req.cusp,
        chord=st.req.chord,
    )
    # the orient stage's face tree (one compiled call, ~0.2 s at 1M faces) is built beside
    # the passes, from their first progress on (their own sample tree is built by then)
    st.nearest = NearestFaces(st.mesh)
    try:
        first = next(it)
    except StopIteration as stop:
        st.passes = stop.value
    else:
        st.nearest.build_alongside()
        yield first
        st.passes = yield from it
    st.stats.update(st.passes.stats)
    yield Progress(1.0, "orienting and linking")


def _stage_order(st: PlanState):
    """Machining order and direction of the passes, the spiral (:mod:`..paths.linking`)."""
    st.morph = morph_between(st.passes.cone1, st.passes.cone2)  # LMC, or LMRS for a Profile
    st.projector = SurfaceProjector(st.mesh, st.req.axis, st.morph, nearest=st.nearest)
    st.link_options = _link_options(st.req, st.rho)
    st.curves = order_passes(st.passes.curves, st.link_options, st.morph, st.req.axis,
                             st.projector)
    return
    yield


def _stage_orient(st: PlanState):
    """Tool axes, the local gouge check and fix, smoothing and the tool tips per pass
    (:func:`.orient_passes.orient_passes`)."""
    near_field = None
    if st.cutter.type != "ball" and math.isfinite(st.concave):
        # a concave region: check the cutter against the surface around each contact too
        from scipy.spatial import cKDTree  # optional: on first use (~60 ms)

        S = np.vstack([st.mesh.V, st.mesh.V[st.mesh.F].mean(axis=1)])
        near_field = (S, cKDTree(S))
    orient_passes(st.curves, st.mesh, st.projector.nearest_faces, st.cutter, st.strategy,
                  st.limits, st.req, st.gouge, near_field)
    return
    yield


def _stage_link(st: PlanState):
    """The linked program: approach, cut, links on the surface or via the clearance
    surface (:func:`..paths.linking.build_program`). An on-surface link whose swept cutter
    would cut the blade deeper than the chord tolerance goes through the air instead
    (:class:`..paths.link_check.SweptLinkCheck`); the count is in the stats and the warnings."""
    # the projector's nearest faces (their trees built by the orient stage) measure the
    # links: the same distances as MeshDistance's own tree, which at 1M faces took longer
    # to build than the whole plan
    dist = MeshDistance(st.mesh, faces=st.projector.nearest_faces)
    check = SweptLinkCheck(st.mesh, st.cutter, st.req.chord, distance=dist)
    st.program = build_program(
        st.curves,
        st.link_options,
        st.req.axis,
        tool_radius=st.cutter.radius,
        projector=st.projector,
        cl_points=st.cutter.cl_points,
        link_check=check,
    )
    st.stats["links_rerouted"] = check.rerouted
    st.stats["links_rerouted_depth"] = check.worst
    st.stats["links_rerouted_still_cutting"] = check.still
    st.stats["clearance_routes_cutting"] = check.rapids
    st.stats["clearance_routes_depth"] = check.rapids_worst
    st.warnings.extend(check.warnings())
    return
    yield


def _stage_checks(st: PlanState):
    """The figures of the finished plan (stats)."""
    curves = st.curves
    turns = [consecutive_turn(c.axis, c.closed) for c in curves if len(c.cc) > 1]
    st.stats.update(
        {
            "expansion_radius": float(st.rho),
            # smallest convex / concave radius between the cones (None: not needed, a ball)
            "edge_radius": float(st.edge) if math.isfinite(st.edge) else None,
            "concave_radius": float(st.concave) if math.isfinite(st.concave) else None,
            "curves": len(curves),
            "poses": int(sum(len(c.cc) for c in curves)),
            "max_axis_turn": float(max((t.max() for t in turns if len(t)), default=0.0)),
            "local_gouge": st.gouge.summary(),
            "zero_speed_poses": int(
                sum(int(np.count_nonzero(c.flags & FLAG_ZERO_SPEED)) for c in curves)
            ),
            "link": st.link_options.mode,
        }
    )
    zs = zero_speed_warning(st.stats["zero_speed_poses"], st.stats["poses"])
    if zs:
        st.warnings.append(zs)
    return
    yield


def _stage_allowance(st: PlanState):
    """Semi-finishing: the path planned with the grown cutter on the blade becomes the real
    cutter's path on the blade offset by the allowance a (see the module docstring): CC
    points out along their normals by a, every tip (cuts, links, approaches, rapids) up its
    own axis by a, the real cutter in place of the grown one."""
    a = st.allowance
    for c in st.curves:
        c.cc = c.cc + a * c.normal
        c.tip = c.tip + a * c.axis
    if st.program is not None:
        st.program.tip = st.program.tip + a * st.program.axis
    st.stats["allowance"] = float(a)
    st.stats["planning_tool_radius"] = float(st.cutter.radius)
    if st.stats.get("warnings"):  # the generator's own warnings name the cutter it planned with
        planned = describe_tool(st.cutter.type, 2 * st.cutter.radius, st.cutter.r)
        real = describe_tool(st.tool.type, 2 * st.tool.radius, st.tool.r)
        st.warnings.append(
            f"the warnings that name a {planned} mean the {real} grown by the allowance of "
            f"{a:g} mm: the semi-finishing passes are planned with it on the blade (what the "
            f"{real} leaves on the blade offset by {a:g} mm)")
    st.cutter = st.tool
    return
    yield


ALLOWANCE_STAGE = Stage("allowance", _stage_allowance)


def _stage_layers(st: PlanState):
    """Semi-finishing in layers (:mod:`.semi_layers`): each layer's allowance planned as its
    own path (the cones fitted once, by the first), then one program of them all."""
    req, k = st.req, len(st.layers)
    cones = (req.cone1, req.cone2)
    paths = []
    for i, a in enumerate(st.layers):
        tol = dataclasses.replace(req.tolerances, allowance=float(a), offset_layers=1)
        sub = PathRequest(req.axis, *cones, cutter=req.cutter, tolerances=tol,
                          orientation=req.orientation, gouge=req.gouge, linking=req.linking,
                          extra=req.extra)
        res = yield from scaled_progress(iter_run_operation(BLADE_FINISH, st.mesh, sub),
                                         i / k, (i + 1) / k, f"layer {i + 1} of {k} ({a:.3f} mm)")
        if i == 0:
            st.fit = res.fit
            cones = (res.path.cone1, res.path.cone2)
        paths.append(res.path)
        st.gouge = res.gouge
    st.cone1, st.cone2 = cones
    st.curves = [c for p in paths for c in p.curves]
    st.program = join_programs([p.program for p in paths], [len(p.curves) for p in paths],
                               req.axis, _link_options(req).rapid_step)
    st.stats = merge_layer_stats([p.stats for p in paths], st.layers,
                                 [len(p.curves) for p in paths])
    st.warnings = [f"layer {i + 1} ({a:g} mm): {w}"
                   for i, (a, p) in enumerate(zip(st.layers, paths, strict=True))
                   for w in p.warnings]


LAYERS_STAGE = Stage("layers", _stage_layers)


def check_allowance_in_channel(mesh: TriMesh, axis: Axis, blade_count: int,
                               allowance: float, *, candidates: int = 256) -> float:
    """The narrowest gap (mm) between the blade and its neighbour (the blade turned by
    360°/N about ``axis``), or a ToleranceError when the allowance is at least half of it:
    the blade and its neighbour, each offset by the allowance, would overlap, leaving no
    channel to cut (issue 23: "an allowance larger than half the channel"). The blade
    vertices nearest a neighbour vertex (k-d trees, ``candidates`` of them) are measured
    exactly against the neighbour's triangles: the gap is that of the nearest vertex (on a
    mesh finer than the blade's curvature, the true gap to second order in the edge)."""
    a = float(allowance)
    n = int(blade_count)
    if a <= 0 or n < 2:
        return math.inf
    from scipy.spatial import cKDTree  # optional: on first use (~60 ms)

    R = rotation_matrix(axis.d, 2.0 * math.pi / n)
    W = (mesh.V - axis.o) @ R.T + axis.o
    tree = cKDTree(W)
    # every 8th vertex first (the k-d tree's far queries are the cost), then every vertex
    # within 5 mm of the nearest of those, then the triangles near them exactly
    coarse = mesh.V[::8]
    near, _ = tree.query(coarse)
    seeds = coarse[np.argsort(near)[:candidates // 8]]
    around = cKDTree(mesh.V).query_ball_point(seeds, 5.0)
    P = mesh.V[np.unique(np.concatenate([np.asarray(h, dtype=np.int64) for h in around]))]
    near, _ = tree.query(P)
    P = P[np.argsort(near)[:candidates]]
    # the neighbour's triangles with a corner within reach of those vertices (the longest
    # edge further than the nearest corner): their exact closest points are the gap's
    edge = float(np.linalg.norm(W[mesh.F] - W[np.roll(mesh.F, 1, axis=1)], axis=2).max())
    hits = tree.query_ball_point(P, float(near.min()) + 2.0 * edge)
    corner = np.zeros(len(W), bool)
    corner[np.unique(np.concatenate([np.asarray(h, dtype=np.int64) for h in hits]))] = True
    faces = mesh.F[corner[mesh.F].any(axis=1)]
    used, local = np.unique(faces, return_inverse=True)
    d = MeshDistance(TriMesh.from_arrays(W[used], local.reshape(-1, 3))).query(P).distance
    k = int(np.argmin(d))
    gap = float(d[k])
    if a >= 0.5 * gap:
        r, _, z, _ = cylindrical(P[k:k + 1], axis)
        raise ToleranceError(
            f"an allowance of {a:g} mm is more than the channel allows: the narrowest gap "
            f"between the blade and its neighbour ({n} blades) is {gap:.3f} mm (at r = "
            f"{float(r[0]):.1f} mm, z = {float(z[0]):.1f} mm), and both blades offset by the "
            f"allowance would overlap there; leave less than {0.5 * gap:.3f} mm of stock")
    return gap


#: the plan, in order: fit → passes → order → orient/gouge → link → checks. Later stages
#: (collision) are appended by the caller: ``iter_plan_paths(mesh, req, extra=(stage,))``.
PLAN_STAGES = (
    Stage("fit", _stage_fit),
    Stage("passes", _stage_passes),
    Stage("order", _stage_order),
    Stage("orient", _stage_orient),
    Stage("link", _stage_link),
    Stage("checks", _stage_checks),
)


class BladeFinish(Operation):
    """LMC blade finishing as an operation (paper 001): the blade mesh is the part, the
    :class:`PathRequest` carries the tool and the options; the stock is not read."""

    name = "blade_finish"

    def start(self, part: TriMesh, request: PathRequest, stock=None) -> PlanState:
        cutter, strategy, _, limits = _check(request)
        allowance = float(request.allowance)
        if request.offset_layers > 1:  # one pass set per layer (:func:`_stage_layers`)
            layers = tuple(layer_allowances(allowance, request.offset_from,
                                            request.offset_layers))
            return PlanState(mesh=part, req=request, cutter=cutter, strategy=strategy,
                             limits=limits, allowance=allowance, tool=cutter, layers=layers)
        if allowance > 0:  # semi-finishing: plan with the grown cutter (module docstring)
            return PlanState(mesh=part, req=request, cutter=cutter.grown(allowance),
                             strategy=strategy, limits=limits, allowance=allowance,
                             tool=cutter)
        return PlanState(mesh=part, req=request, cutter=cutter, strategy=strategy,
                         limits=limits)

    def stages(self, state: PlanState) -> tuple[Stage, ...]:
        if state.layers:
            return (LAYERS_STAGE,)
        if state.allowance > 0:
            return (*PLAN_STAGES, ALLOWANCE_STAGE)
        return PLAN_STAGES

    def finish(self, state: PlanState, seconds: dict) -> PlanResult:
        return state.result()


#: the blade finishing operation
BLADE_FINISH = BladeFinish()


def iter_plan_paths(mesh: TriMesh, req: PathRequest, *, extra=()):
    """Generator: runs :data:`PLAN_STAGES` (then the ``extra`` stages) over one
    :class:`PlanState` (:func:`~.operation.iter_run_operation` of :data:`BLADE_FINISH`);
    yields Progress, returns a :class:`PlanResult`. Each stage's wall time, inside the stage
    only, is in the stats as ``seconds_<stage>`` ("seconds", from the pass generation, stays
    the pass generation alone).

    Raises
    ------
    BliskCamError (ToolError, OrientationError, LinkError, ConeError, ToleranceError …) with a
    message naming the problem, before any long work where the request itself is bad.
    """
    return (yield from iter_run_operation(BLADE_FINISH, mesh, req, extra=extra))


def plan_paths(mesh: TriMesh, req: PathRequest, *, extra=()) -> PlanResult:
    """Run :func:`iter_plan_paths` to the end."""
    return run_operation(BLADE_FINISH, mesh, req, extra=extra)
