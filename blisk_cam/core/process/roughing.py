"""Channel roughing: the operation that slots the gaps between the blades from the blank down
to the allowance (paper 003 §5, stage 1: "roughing as slotting — removing most spare
material and remaining 0.5 mm stock", in levels).

One gap — between blade 0 and blade 1 (blade 0 turned by the pitch 2π/N) — is planned; the
program is the same for every gap turned by k · 2π/N (``nc --blade-count N`` repeats it;
the stock of one pitch sector, :mod:`..stock`, is periodic, so simulating the one gap's
program on it simulates all N).

Stages (:mod:`.operation`):

1. ``levels`` — stations along the axis over the blank (and a tool radius beyond its faces),
   the shroud (the blank's top), the floor (the lowest tip that keeps the hub allowance,
   :func:`..channel.levels.floor_radius`) and the levels from the shroud down in the
   requested mode (:func:`..channel.levels.level_radii`; with a level scallop the steps
   from the walls' slope, :mod:`..channel.level_scallop`);
2. ``region`` — the blade's sections on cylinders from the hub to the tip, and per level the
   θ bounds the tool — flute, shank and holder — may take between the blades keeping the
   allowance (:mod:`..channel.region`; the body keeps the allowance plus the safety, since
   the allowance shell is still stock); stations where the bounds cross are left out, with a
   warning naming the level;
3. ``pattern`` — zig-zag passes along the channel stepped across it, plunges
   (:mod:`..channel.patterns`) or trochoidal loops across it stepped along
   (:mod:`..channel.trochoid`);
4. ``link`` — the program: feed links in the air beyond the blank's faces, retract / rapid
   at the safe radius / approach elsewhere; the estimated machining time. Ordered by gap
   (``order``, the default) the gap is linked as one and the post repeats it per gap; by
   level each level is linked alone, from and back to the safe radius, and the post runs
   level 1 in every gap, then level 2 … (``stats["level_blocks"]``); ``gaps`` makes the
   program itself hold several gaps (:mod:`..channel.gaps`).

The tool axis leans with the blades (``follow_blades``, the default): per level and station
the radial direction tilted toward +θ by the blades' mean camber lean over the band of
radii the level's cut adds (:mod:`..channel.axis`), changing by at most ``max_turn`` per
station step, plus the requested lead (toward +z) and side tilt (toward +θ); without
``follow_blades`` it is radial with the requested tilts. The bound holds on the actual tool
axis: where the radial direction's own turn (the tip moving round the blisk axis) makes two
consecutive cutting poses more than ``max_turn`` apart, poses are inserted on the move between
them (:func:`..channel.axis.bound_turn`).

With ``follow_blades`` two more kinds of pass finish the walls at the allowance: on the floor
level and on **wall levels** every ≤ 2 mm between the floor and the level above (on the
floor the cutter's corner rides on the hub fillet and keeps its side off the wall above it),
a **contour pass** along each wall whose side tilt per station is the one (of the level's
own ± 5° and 10°) that brings the tool nearest the wall half a depth per cut above its tip,
limited to ``max_turn`` per step. The material a level staircase leaves on a wall of unit
normal n is at most s |n · a| beyond the allowance (the **level step cusp**: s the step
between the levels bracketing the point, the depth per cut — or the wall-level step in the
floor band —, a the tool axis; the corners of a step of a sharp-cornered tool lie that far off
the plane through the points it touches, a corner radius leaves less). The floor of each level is
computed for its own tilts (a tilted tool's low rim keeps the hub allowance) and the
bounds account for the tilt at every height of the tool.

In the floor band that is not enough: the wall levels' contours touch each wall where their
tilt puts the tool first, and the corner riding on the hub fillet keeps the side off the wall
above it. **Surface-driven passes** (``floor_band_step``, :mod:`..channel.floor_band`) follow
the floor level: rows of contacts on the blades' allowance offset every ``floor_band_step``
mm in height from the hub to the level above, the pose following each contact (side tilt the
mean camber lean ± 5°), checked by exact distances of the cutter's outline to the blades and
the hub and by the region's bounds above a tool radius up the flute (with plunges, rows go
on up the whole wall every half depth per cut: the plunge levels keep one axis each; these
rows feed along the walls, not down the axis). Units mm, radians (degrees only in messages).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..channel.axis import bound_turn, limit_turn, mean_camber_lean
from ..channel.floor_band import FluteCheck, band_contacts, band_pieces, band_poses
from ..channel.gaps import GAP_ORDERS, pattern_gaps
from ..channel.level_scallop import channel_levels, check_depth_options
from ..channel.levels import LEVEL_MODES, Level, floor_radius, stock_top
from ..channel.patterns import (
    Piece,
    link_program,
    machining_time,
    pass_pieces,
    plunge_points,
    pose_frame,
    runs_of,
    zigzag_passes,
)
from ..channel.region import (
    channel_bounds,
    cylinder_sections,
    fill_free,
    offset_table,
    refined_bounds,
    widest_circle,
)
from ..channel.trochoid import trochoid_passes
from ..errors import BliskCamError, StockError, ToolError
from ..geometry.vectors import rotate_about
from ..part.cones import Cone
from ..part.model import BliskPart, theta_about
from ..runtime import Progress, check_cancel
from ..stock.dexels import RadialDexels
from ..stock.removal import body_assembly, remove_program
from ..tool.assembly import ToolAssembly
from ..tool.cutter import Cutter, as_cutter
from ..toolpath.types import MOVE_CUT, STATUS_UNRESOLVED, PassCurve, Program, ToolPath
from .operation import Operation, OperationResult, Stage, run_operation

__all__ = ["BODY_MEETS_STOCK", "PATTERNS", "RoughRequest", "RoughingOperation", "plan_roughing"]

PATTERNS = ("zigzag", "plunge", "trochoid")
#: what the roughing's stock check does where the tool body would meet the stock
BODY_MEETS_STOCK = ("leave-out", "flag")


@dataclass
class RoughRequest:
    """What to rough and how.

    Attributes
    ----------
    tool : Cutter — flat, bull nose or ball (DIN 66215)
    stepover : float, mm — the largest step across the channel (≤ the tool diameter)
    depth_per_cut : float or None, mm — the constant largest step between levels
    level_scallop, max_depth_per_cut : float or None, mm — instead, steps from the walls'
        slope leaving at most this step cusp, capped (None: the flute length;
        :mod:`..channel.level_scallop`)
    levels : str — ``from-hub`` | ``from-shroud`` | ``morph``
    pattern : str — ``zigzag`` | ``plunge`` | ``trochoid``
    allowance : float, mm — material left on the blades (default 0.5, paper 003 §5)
    hub_allowance : float or None, mm — material left on the hub (None: ``allowance``)
    lead, side_tilt : float, rad — the tool axis tilted from radial toward +z / +θ
    assembly : ToolAssembly or None — the body (None: the cutter's shank and holder, the
        same default as the stock simulation's)
    safety : float, mm — the body's distance from the allowance shell
    station_step : float, mm — pose spacing along the channel
    clearance : float, mm — the safe radius above the blank's top for rapids
    feed, plunge_feed, rapid_feed : float, mm/min — for the time estimate (plunge_feed None:
        half the feed)
    spindle : float or None, rpm — recorded in the stats
    margin : float, mm — extra distance kept from the allowance shell (covers the chord
        between stations)
    follow_blades : bool — the axis leans with the blades' mean camber surface (module
        docstring); False: radial
    max_turn : float, rad — the largest turn of the tool axis between consecutive cutting
        poses (the side tilt changes by at most this per station step; where the radial
        direction's own turn makes the axis turn more, poses are inserted on the move,
        :func:`..channel.axis.bound_turn`)
    check_stock : bool — run the program on the blank and leave out what brings the tool
        body against the stock (the ``link`` stage; False: only the simulation afterwards
        reports it); ``fine_check`` (:class:`..stock.fine_check.FineCheck` or None) judges
        the rows near the stock again on a finer stock (the body thinner than a cell)
    order : str — ``gap``: every level of a gap before the next gap; ``level``: a level in
        every gap before the next level (:mod:`..channel.gaps`). The program of one gap is
        posted for the N gaps in that order: by gap the post repeats it per gap; by level
        each level is linked alone (from and back to the safe radius, ``stats
        ["level_blocks"]`` its rows) and the post runs level 1 in every gap, then level 2 …
    gaps : int or None — the program itself holds gaps 0 … gaps − 1 in ``order``, linked
        round the axis at the safe radius (None: one gap); a program of several gaps is
        posted as it is (with the blade count 1 or gaps)
    floor_band_step : float, mm — with ``follow_blades``, the rows of the surface-driven
        passes in the floor band are this far apart in height above the hub (0: none;
        :mod:`..channel.floor_band`)
    body_meets_stock : str — what ``check_stock`` does where the tool body would meet the
        stock: ``leave-out`` that stretch (a warning names the level), or ``flag`` it: the
        passes are kept and those rows flagged as unresolved collisions (the program's
        ``collision_status``; the post refuses them unless the user allows collisions, the
        stock simulation reports the crashes) — the issue's "at the user's choice"
    """

    tool: Cutter
    stepover: float
    depth_per_cut: float | None = None
    levels: str = "from-hub"
    pattern: str = "zigzag"
    allowance: float = 0.5
    hub_allowance: float | None = None
    lead: float = 0.0
    side_tilt: float = 0.0
    assembly: ToolAssembly | None = None
    safety: float = 0.5
    station_step: float = 0.5
    clearance: float = 5.0
    feed: float = 1000.0
    plunge_feed: float | None = None
    rapid_feed: float = 10000.0
    spindle: float | None = None
    margin: float = 0.02
    follow_blades: bool = True
    max_turn: float = math.radians(2.0)
    check_stock: bool = True
    fine_check: object = None
    order: str = "gap"
    gaps: int | None = None
    floor_band_step: float = 0.5
    level_scallop: float | None = None
    max_depth_per_cut: float | None = None
    body_meets_stock: str = "leave-out"


@dataclass
class _State:
    part: BliskPart
    stock: RadialDexels
    req: RoughRequest
    cutter: Cutter
    assembly: ToolAssembly
    theta_ref: float
    hub_a: float
    z: np.ndarray = None
    outside: np.ndarray = None
    top: np.ndarray = None
    floor: np.ndarray = None
    levels: list = field(default_factory=list)
    sections: list = field(default_factory=list)
    bounds: list = field(default_factory=list)
    pieces: list = field(default_factory=list)
    warnings: list = field(default_factory=list)
    unreachable: list = field(default_factory=list)
    contours: list = field(default_factory=list)
    wall_step: float = 0.0
    band_passes: int = 0
    band_tilt: tuple | None = None
    tables: dict = field(default_factory=dict)
    path: ToolPath = None
    depth: float = 0.0
    band: float = 0.0
    steps: list = field(default_factory=list)


def _num(name, value, *, positive=True, error=BliskCamError) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise error(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(v) or (v <= 0 if positive else v < 0):
        raise error(f"{name} must be {'> 0' if positive else '≥ 0'} mm, got {v:g}")
    return v


def _blade_theta(part: BliskPart) -> float:
    _, th, _ = theta_about(part.blade_vertices, part.axis)
    return float(math.atan2(np.sin(th).mean(), np.cos(th).mean()))


class RoughingOperation(Operation):
    """Channel roughing (module docstring). ``part`` a :class:`~..part.model.BliskPart`,
    ``request`` a :class:`RoughRequest`, ``stock`` the blank (radial dexels of one sector,
    e.g. :func:`..stock.blank.stock_from_envelope`)."""

    name = "rough"

    def start(self, part, request, stock=None):
        if not isinstance(part, BliskPart):
            raise BliskCamError("roughing needs the blisk part (axis, blade count, blade and "
                                "hub): build it with part_from_demo/part_from_blade/"
                                "split_blisk_mesh")
        if stock is None:
            raise StockError("roughing needs the blank (the stock it starts from): give "
                             "--stock (a profile, a mesh, envelope:MM or a saved state)")
        if stock.blade_count != part.blade_count:
            raise StockError(f"the blank is for {stock.blade_count} blades, the part has "
                             f"{part.blade_count}; make the blank for this part")
        req = request
        cutter = as_cutter(req.tool)
        if cutter.type == "taper":
            raise ToolError("roughing takes a flat, bull-nose or ball cutter, not a tapered "
                            "ball")
        check_depth_options(req, cutter)
        step = _num("stepover", req.stepover)
        if step > cutter.d * (1 + 1e-9):
            raise ToolError(f"stepover {step:g} mm is larger than the tool diameter "
                            f"{cutter.d:g} mm: material would stay between the passes; give "
                            f"at most {cutter.d:g} mm")
        a = _num("allowance", req.allowance, positive=False)
        ha = a if req.hub_allowance is None else _num("hub allowance", req.hub_allowance,
                                                        positive=False)
        if req.levels not in LEVEL_MODES:
            raise BliskCamError(f"levels must be one of {', '.join(LEVEL_MODES)}, got "
                                f"{req.levels!r}")
        if req.order not in GAP_ORDERS:
            raise BliskCamError(f"order must be one of {', '.join(GAP_ORDERS)} (by gap: all "
                                f"levels of a gap, then the next gap; by level: a level in "
                                f"every gap, then the next level), got {req.order!r}")
        if req.gaps is not None and not (isinstance(req.gaps, (int, np.integer))
                                         and 1 <= req.gaps <= part.blade_count):
            raise BliskCamError(f"the gaps the program holds must be a whole number from 1 to "
                                f"the blade count {part.blade_count}, got {req.gaps!r}")
        if req.body_meets_stock not in BODY_MEETS_STOCK:
            raise BliskCamError(f"where the body meets the stock: one of "
                                f"{', '.join(BODY_MEETS_STOCK)}, got {req.body_meets_stock!r}")
        if req.body_meets_stock == "flag" and (req.gaps or 1) > 1:
            raise BliskCamError("flagging where the body meets the stock needs the program of "
                                "one gap (the post repeats it): leave 'gaps' unset")
        if req.pattern not in PATTERNS:
            raise BliskCamError(f"pattern must be one of {', '.join(PATTERNS)}, got "
                                f"{req.pattern!r}")
        for name, ang in (("lead", req.lead), ("side tilt", req.side_tilt)):
            if not (math.isfinite(ang) and abs(ang) < math.radians(45)):
                raise BliskCamError(f"{name} must be within ±45°, got "
                                    f"{math.degrees(ang):g}°")
        _num("station step", req.station_step)
        _num("floor band step (0: no floor-band passes)", req.floor_band_step, positive=False)
        if not (math.isfinite(req.max_turn) and req.max_turn > 0):
            raise BliskCamError(f"the largest axis turn per step must be > 0°, got "
                                f"{math.degrees(req.max_turn):g}°")
        _num("safety distance", req.safety, positive=False)
        for name, f in (("feed", req.feed), ("rapid feed", req.rapid_feed)):
            _num(name, f)
        # the blank must hold the part
        V = part.blade_vertices
        inside = stock.occupied(V)
        if inside.mean() < 0.995:
            bad = V[~inside][0]
            r, _, z = theta_about(bad[None], part.axis)
            raise StockError(f"the blank does not contain the part: {int((~inside).sum())} of "
                             f"{len(V)} blade points lie outside it (e.g. at r {r[0]:.2f} mm, "
                             f"z {z[0]:.2f} mm); give a larger blank")
        assembly = req.assembly or body_assembly(cutter)
        st = _State(part, stock, req, cutter, assembly, _blade_theta(part), ha)
        self._stations(st)
        # the channel at the hub: allowance and tool against its widest inscribed circle
        r_floor = floor_radius(part.hub_profile, Cutter.ball(1e-3), 0.0, st.z)
        band = (0.0, 2.0)  # the channel just above the hub
        radii = np.arange(float(r_floor.min()) + band[0] - 0.5,
                          float(r_floor.max()) + band[1] + 0.5, 0.25)
        secs = cylinder_sections(V, part.blade_faces, part.axis, radii, st.theta_ref, 0.3)
        widest, throat = widest_circle(part, secs, st.z, r_floor, band)
        if math.isfinite(widest):
            if a >= 0.5 * widest:
                raise BliskCamError(f"allowance {a:g} mm is larger than half the channel: the "
                                    f"widest circle between the blades at the hub is "
                                    f"Ø{widest:.2f} mm; give an allowance below "
                                    f"{0.5 * widest:.2f} mm")
            if 2.0 * (cutter.max_radius + a) > widest:
                raise ToolError(f"the {cutter.type} cutter Ø{cutter.d:g} does not fit the "
                                f"channel at the hub: with {a:g} mm allowance on each blade it "
                                f"needs Ø{2 * (cutter.max_radius + a):.2f} mm, the widest "
                                f"circle between the blades there is Ø{widest:.2f} mm "
                                f"(narrowest gap {max(throat, 0.0):.2f} mm); take a smaller "
                                "tool")
        return st

    def _stations(self, st: _State):
        stock, req, cutter = st.stock, st.req, st.cutter
        z0 = stock.z0
        z1 = stock.z0 + stock.n_z * stock.dz
        reach = cutter.max_radius + 0.5 + abs(math.tan(req.lead)) * st.assembly.top
        lo, hi = z0 - reach - req.station_step, z1 + reach + req.station_step
        n = int(math.ceil((hi - lo) / req.station_step)) + 1
        st.z = lo + np.arange(n) * ((hi - lo) / (n - 1))
        st.outside = (st.z < z0 - reach + 1e-9) | (st.z > z1 + reach - 1e-9)

    def stages(self, state):
        return (Stage("levels", self._levels), Stage("region", self._region),
                Stage("pattern", self._pattern), Stage("link", self._link))

    # ------------------------------------------------------------------ stages
    def _levels(self, st: _State):
        zr, top = stock_top(st.stock)
        if len(zr) == 0:
            raise StockError("the blank is empty")
        req, part = st.req, st.part
        st.top = np.interp(st.z, zr, top)
        st.floor = floor_radius(part.hub_profile, st.cutter, st.hub_a, st.z,
                                lead=req.lead, side=req.side_tilt)
        rv, _, _ = theta_about(part.blade_vertices, part.axis)
        r_lo = max(float(rv.min()), float(st.floor.min()) - req.allowance - 0.5)
        r_hi = float(rv.max())
        # near the hub the blade runs into its fillet nearly parallel to the cylinders: there
        # consecutive sections lie far apart and the corner of the tool could pass between
        # them, so the cylinders are 0.05 mm apart up to a tool radius + 2 mm above the floor
        fine = min(float(st.floor.max()) + st.cutter.max_radius + 2.0, r_hi)
        radii = np.unique(np.concatenate([np.arange(r_lo, fine, 0.05),
                                          np.arange(fine, r_hi + 0.25, 0.25)]))
        st.sections = cylinder_sections(part.blade_vertices, part.blade_faces, part.axis,
                                        radii, st.theta_ref, 0.3)
        st.levels, st.steps, st.depth, st.band = channel_levels(
            part, st.cutter, st.sections, st.z, st.floor, st.top, req,
            lean=req.follow_blades and req.pattern != "plunge")
        yield Progress(0.7, f"blade sections, {len(st.levels)} levels")
        floor_level = st.levels[-1]
        for lv in st.levels:
            # the floor level keeps the radial axis: a tilted flat bottom would leave a
            # sawtooth on the hub, and its low rim would lift the floor
            lv.side = np.full(len(st.z), float(req.side_tilt))
            # (plunges keep one axis on every main level: a plunge's link across the channel
            # runs over the level above, cleared with that level's axis)
            if req.follow_blades and lv is not floor_level and req.pattern != "plunge":
                self._lean(st, lv)
        if req.follow_blades and len(st.levels) > 0:
            # wall levels between the floor and the level above (contour passes only): on the
            # floor the tool's corner rides on the hub fillet and keeps its side off the wall
            # above it; a contour pass every ≤ 2 mm up lets the side reach the wall there
            above = st.levels[-2].r if len(st.levels) > 1 else st.top
            span = float(np.max(above - floor_level.r))
            n = int(math.ceil(span / min(2.0, st.depth) - 1e-9))
            K = len(st.levels)
            st.wall_step = span / n if n > 1 else 0.0
            walls = []
            for j in range(n - 1, 0, -1):  # from the top down, cut before the floor
                off = j * span / n
                wl = Level(0, np.minimum(floor_level.r + off, above),
                           f"wall level {n - j} of {n - 1} above level {K} (+{off:.2f} mm)")
                wl.walls_only = True
                self._lean(st, wl)
                walls.append(wl)
            st.levels[-1:-1] = walls
            for k, lv in enumerate(st.levels):
                lv.index = k
        yield Progress(1.0, "tool axes")

    def _lean(self, st: _State, lv: Level):
        """The level's side tilt following the blades (:mod:`..channel.axis`) and its tip
        radius raised to the floor of that tilt."""
        req = st.req
        lean = mean_camber_lean(st.sections, st.z, lv.r, lv.r + max(st.depth, 2.0))
        lv.side = limit_turn(lean + req.side_tilt, req.max_turn)
        lv.z = st.z
        lv.r = self._floor_of(st, lv, lv.side)
        lv.z = None

    def _region(self, st: _State):
        part, req = st.part, st.req
        overlap = (st.cutter.max_radius + 1.0) / np.maximum(st.floor, 1.0)
        hold = st.cutter.max_radius + 1.0
        for k, lv in enumerate(st.levels):
            check_cancel()
            table = self._table(st, float(np.abs(lv.side).max()))
            z, r, outside, lo, hi, side = refined_bounds(
                st.sections, part.pitch, st.z, lv.r, st.outside, table, req.lead, lv.side)
            lo, hi = fill_free(z, lo, hi, part.pitch, np.interp(z, st.z, overlap), hold, 5.0,
                               0.5 * part.pitch)
            lv.z, lv.r, lv.outside, lv.side = z, r, outside, side
            reach = hi >= lo
            inner = ~outside
            miss = inner & ~reach
            if miss.all() or not reach[inner].any():
                st.warnings.append(f"{lv.label} cannot be reached without the tool or its "
                                   "body touching the allowance: left out")
                st.unreachable.append(lv.label)
            elif miss.any():
                zs = z[miss]
                st.warnings.append(
                    f"{lv.label}: the tool does not fit between the blades at z "
                    f"{zs.min():.1f} … {zs.max():.1f} mm ({miss.sum() / inner.sum():.0%} of "
                    "its stations): that part is left out")
                st.unreachable.append(lv.label)
            st.bounds.append((lo, hi, reach))
            # contour passes on the floor band (the floor level and the wall levels above
            # it): above, the leaning zig-zag's first and last passes follow the walls
            band = lv.walls_only or lv is st.levels[self._floor_index(st)]
            st.contours.append(self._contours(st, lv) if req.follow_blades and band else [])
            yield Progress((k + 1) / len(st.levels), f"region of {lv.label}")

    def _floor_index(self, st: _State) -> int:
        """Index of the floor level (the last one that is not a wall level)."""
        return max(k for k, lv in enumerate(st.levels) if not lv.walls_only)

    def _table(self, st: _State, side: float):
        """The offset table of a tilt up to |side| (rad; rounded up to 0.1°, shared)."""
        req = st.req
        side = math.radians(math.ceil(math.degrees(abs(side)) * 10) / 10)
        tilt = math.atan(math.hypot(math.tan(req.lead), math.tan(side)))
        if tilt not in st.tables:
            st.tables[tilt] = offset_table(st.cutter, st.assembly, req.allowance, req.safety,
                                           req.margin, tilt=tilt)
        return st.tables[tilt]

    def _floor_of(self, st: _State, lv: Level, side) -> np.ndarray:
        """The level's tip radii raised to the floor of the side tilt ``side`` (rad, scalar or
        per station); only stations within a tool radius of the radial floor can need it (a
        tilt drops the rim by at most the radius)."""
        req = st.req
        side = np.broadcast_to(np.asarray(side, float), lv.z.shape)
        near = lv.r < np.interp(lv.z, st.z, st.floor) + st.cutter.max_radius + 1e-9
        r = lv.r.copy()
        if near.any():
            r[near] = np.maximum(r[near], floor_radius(st.part.hub_profile, st.cutter,
                                                       st.hub_a, lv.z[near], lead=req.lead,
                                                       side=side[near]))
        return r

    def _contours(self, st: _State, lv: Level):
        """The contour passes of a level along blade 0's wall and blade 1's: per station the
        side tilt (the level's own ± 5° and 10°) that brings the tool nearest the wall half a
        depth per cut above its tip, limited to the largest turn per step, the tip on the
        floor of that tilt and at the bound of that tilt. Returns [(theta, r, side, reach)]
        over the level's stations, blade 0's wall first."""
        req, part = st.req, st.part
        y = 0.5 * st.depth
        found = [[np.full(len(lv.z), np.inf), lv.side.copy()] for _ in range(2)]
        # the choice on every third section (the bounds of the chosen tilt, below, on all)
        few = st.sections[::3]
        for d in np.radians([0.0, -5.0, 5.0, -10.0, 10.0]):
            c = lv.side + d
            r = self._floor_of(st, lv, c)
            lo, hi = channel_bounds(few, part.pitch, lv.z, r,
                                    self._table(st, float(np.abs(c).max())), lead=req.lead,
                                    side=c)
            ok = np.isfinite(lo) & np.isfinite(hi) & (hi >= lo)
            for low, (best, pick) in zip((True, False), found, strict=True):
                pos = (lo if low else -hi) + (1 if low else -1) * y * np.tan(c) / r
                take = ok & (pos < best)
                best[take], pick[take] = pos[take], c[take]
        out = []
        for low, (_, pick) in zip((True, False), found, strict=True):
            side = limit_turn(pick, req.max_turn)
            r = self._floor_of(st, lv, side)
            lo, hi = channel_bounds(st.sections, part.pitch, lv.z, r,
                                    self._table(st, float(np.abs(side).max())),
                                    lead=req.lead, side=side)
            overlap = (st.cutter.max_radius + 1.0) / np.maximum(r, 1.0)
            lo, hi = fill_free(lv.z, lo, hi, part.pitch, overlap, st.cutter.max_radius + 1.0,
                               5.0, 0.5 * part.pitch)
            out.append(((lo if low else hi), r, side, hi >= lo))
        return out

    def _pattern(self, st: _State):
        req, part = st.req, st.part

        fwd, low = True, True
        r_safe = self._r_safe(st)
        for k, (lv, (lo, hi, reach)) in enumerate(zip(st.levels, st.bounds, strict=True)):
            if not reach.any():
                continue

            def frame(theta, z, r, lv=lv):
                return pose_frame(part.axis, theta, z, r, st.theta_ref, req.lead,
                                  np.interp(z, lv.z, lv.side))

            # the level above: the last one before this that is not a wall level
            prev = next((st.levels[j] for j in range(k - 1, -1, -1)
                         if not st.levels[j].walls_only), None)
            above = (np.interp(lv.z, prev.z, prev.r) if prev is not None
                     else np.full(len(lv.z), r_safe))
            above = np.minimum(above + 1.0, r_safe)
            if lv.walls_only:
                pcs = []
            elif req.pattern == "zigzag":
                pcs, fwd, low = zigzag_passes(k, lv.z, lv.r, lo, hi, reach, lv.outside,
                                              req.stepover, frame, fwd, low)
            elif req.pattern == "trochoid":
                pcs, fwd = trochoid_passes(k, lv.z, lv.r, lo, hi, reach, lv.outside,
                                           req.stepover, frame, fwd, st.cutter.max_radius)
            else:
                # the holes' radius half-way up the corner: the grid leaves no island above
                # half the corner radius (the next level takes the rest)
                pcs = plunge_points(k, lv.z, lv.r, above, lo, hi, reach, req.stepover, frame,
                                    radius=st.cutter.max_radius - 0.5 * st.cutter.r)
            st.pieces.extend(pcs)
            for theta, r, side, ok in st.contours[k]:  # the contour pass along each wall
                n0 = len(st.pieces)
                if req.pattern != "plunge":
                    tips, axes = pose_frame(part.axis, theta, lv.z, r, st.theta_ref, req.lead,
                                            side)
                    st.pieces.extend(pass_pieces(k, tips, axes, ok, lv.outside, fwd))
                    fwd = not fwd
                else:  # plunges along the wall, as close as the holes overlap
                    def wall_frame(theta, z, r, lv=lv, side=side):
                        return pose_frame(part.axis, theta, z, r, st.theta_ref, req.lead,
                                          np.interp(z, lv.z, side))

                    st.pieces.extend(plunge_points(
                        k, lv.z, r, np.maximum(above, r + 1.0), theta, theta,
                        ok & ~lv.outside, min(req.stepover, st.cutter.max_radius), wall_frame,
                        fractions=[0.0]))
                for pc in st.pieces[n0:]:
                    pc.contour = True
            yield Progress((k + 1) / len(st.levels), f"passes of {lv.label}")
        if req.follow_blades and req.floor_band_step > 0:
            self._floor_band(st)
            yield Progress(1.0, f"{st.band_passes} surface-driven passes in the floor band")

    def _floor_band(self, st: _State):
        """The surface-driven passes of the floor band (:mod:`..channel.floor_band`), after
        the floor level and counted with it: rows every ``floor_band_step`` mm from the hub
        up to the allowance + one depth per cut, on both walls (with plunges, and every half
        depth per cut on up the wall)."""
        req, part = st.req, st.part
        H = part.hub_profile
        hub_r = np.interp(st.z, H[:, 1], H[:, 0])
        step = req.floor_band_step
        heights = np.arange(0.5 * step, st.hub_a + st.band + 1e-9, step)
        if req.pattern == "plunge":
            # the plunge levels keep one axis each, which leaves the leaning walls a wedge:
            # rows up the whole wall too, half a depth per cut apart (the level step cusp
            # of that spacing bounds what is left between them)
            rv, _, _ = theta_about(part.blade_vertices, part.axis)
            top = float(rv.max() - hub_r.min())
            heights = np.concatenate([heights, np.arange(heights[-1] + 0.5 * st.depth,
                                                         top, 0.5 * st.depth)])
        contacts = band_contacts(part.blade_vertices, part.blade_faces, part.axis,
                                 st.sections, st.theta_ref, part.pitch, st.z, hub_r, heights,
                                 req.allowance)
        lean = mean_camber_lean(st.sections, st.z, st.floor,
                                st.floor + max(st.depth, 2.0)) + req.side_tilt
        # the exact check up to a tool radius above the corner, the region's bounds above
        # (there the tool is a cylinder, which the bounds model without excess but for the
        # margin, here the check's tolerance instead)
        cut_h = st.cutter.f + st.cutter.max_radius
        check = FluteCheck(st.cutter, part.blade_vertices, part.blade_faces, part.axis,
                           part.pitch, H, req.allowance, st.hub_a, height=cut_h)
        tables: dict = {}

        def body(tip, ax):
            # the shank and holder: the region's bounds with the body's rows of the table
            r, th, z = theta_about(tip, part.axis)
            u = np.stack([np.cos(th), np.sin(th), np.zeros_like(th)], 1)
            t = np.stack([-np.sin(th), np.cos(th), np.zeros_like(th)], 1)
            e = np.stack(part.axis.angular_frame())
            side = np.arctan2(np.einsum("ij,ij->i", ax, t @ e), np.einsum("ij,ij->i", ax,
                                                                          u @ e))
            # (the table of the largest tilt rounded up to 5°: a few tables for all rounds)
            big = math.ceil(math.degrees(float(np.abs(side).max())) / 5.0 + 1e-9) * 5.0
            if big not in tables:
                tilt = math.atan(math.hypot(math.tan(req.lead), math.tan(math.radians(big))))
                hs, os_ = offset_table(st.cutter, st.assembly, req.allowance, req.safety,
                                       -check.tol, tilt=tilt)
                tables[big] = (hs, np.where(hs >= cut_h, os_, -np.inf))
            hs, os_ = tables[big]
            if not np.isfinite(os_).any():
                return np.ones(len(tip), bool)
            lo, hi = channel_bounds(st.sections, part.pitch, z, r, (hs, os_), lead=req.lead,
                                    side=side)
            th = np.mod(th - st.theta_ref + math.pi, 2 * math.pi) - math.pi
            return (th >= lo) & (th <= hi)

        deltas = np.radians([0.0, -5.0, 5.0])
        k = self._floor_index(st)
        fwd, n0 = True, len(st.pieces)
        for wall in contacts:
            bp = band_poses(st.cutter, part.axis, wall, lean, req.lead, check, body, deltas,
                            req.max_turn)
            pcs, fwd = band_pieces(k, bp, st.outside, fwd, check, body)
            st.pieces.extend(pcs)
            if bp.ok.any():
                used = bp.side[bp.ok]
                lo_, hi_ = st.band_tilt or (math.inf, -math.inf)
                st.band_tilt = (min(lo_, float(used.min())), max(hi_, float(used.max())))
        st.band_passes = len(st.pieces) - n0

    def _r_safe(self, st: _State) -> float:
        return float((st.top.max() + st.req.clearance) / math.cos(min(st.part.pitch, 1.0)))

    def _link(self, st: _State):
        req, part = st.req, st.part
        if not st.pieces:
            raise BliskCamError("no level of the channel can be reached with this tool: "
                                + "; ".join(st.warnings[:3]))
        # the turn bound on the actual tool axis (the side tilt's bound leaves out the
        # radial direction's own turn as the tip moves round the blisk axis)
        inserted = 0
        for pc in st.pieces:
            pc.tip, pc.axis, n_in = bound_turn(pc.tip, pc.axis, req.max_turn)
            inserted += n_in
        tip, axis, move, curve, index, rows, blocks = self._linked(st)
        program = Program(tip, axis, move, curve, index, np.zeros(len(tip), np.uint8))
        # the body against the in-process stock: the program run on the blank; a contour
        # pass (its axis differs from the one that cleared the levels above) whose body or
        # approach meets material is left out, any other pass loses the stretch of a tool
        # radius + 2 mm round each such pose, and the rest is linked again
        for round_ in range(4 if req.check_stock else 0):
            check_cancel()  # with a fine check, first the body rows within two cells of material
            near, wide = (None, None) if req.fine_check is None else ([], None if round_ else
                                                                   2.0 * st.stock.resolution)
            res = remove_program(st.stock.copy(), program, st.cutter, st.assembly,
                                 sweep_tolerance=0.05, near=near, near_margin=wide)
            hits: dict = {}
            crashes = res.crashes + (req.fine_check.crashes(
                st.stock, program, st.cutter, st.assembly, near,
                grow=wide and 1.5 * wide) if near else [])
            for c in crashes:
                k = int(curve[c.row]) if c.row < len(curve) else -1
                j = int(index[c.row]) if k >= 0 else 0
                if k < 0:  # a link, rapid or approach: the start of the piece it leads to
                    nxt = np.nonzero(curve[c.row:] >= 0)[0]
                    k = int(curve[c.row + nxt[0]]) if len(nxt) else -1
                if k >= 0:
                    hits.setdefault(k, []).append(j)
            if not hits:
                break
            if req.body_meets_stock == "flag":
                flagged = sorted({int(c.row) for c in crashes if c.row < len(tip)})
                program.collision_status = np.zeros(len(tip), np.int8)
                program.collision_status[flagged] = STATUS_UNRESOLVED
                st.warnings.append(
                    f"{', '.join(sorted({st.levels[st.pieces[k].level].label for k in hits}))}"
                    f": the tool body meets the stock the levels above left on {len(flagged)} "
                    "rows: kept and flagged as unresolved collisions (the post refuses them "
                    "unless collisions are allowed)")
                break
            pieces = []
            for k, pc in enumerate(st.pieces):
                if k not in hits:
                    pieces.append(pc)
                    continue
                label = st.levels[pc.level].label
                _, _, zc = theta_about(pc.tip[np.asarray(hits[k])], part.axis)
                st.warnings.append(
                    f"{label}: the tool body would meet the stock the levels above left at z "
                    f"{zc.min():.1f} … {zc.max():.1f} mm: "
                    + ("that contour pass is left out" if pc.contour or pc.plunge
                       else "that stretch of the pass is left out"))
                if pc.contour or pc.plunge:
                    continue
                s_ = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pc.tip, axis=0),
                                                                     axis=1))])
                keep = np.ones(len(s_), bool)
                for j in hits[k]:
                    keep &= np.abs(s_ - s_[j]) > st.cutter.max_radius + 2.0
                for a0, b0 in runs_of(keep):
                    if b0 - a0 >= 2:
                        pieces.append(Piece(pc.tip[a0:b0], pc.axis[a0:b0], pc.level,
                                            (pc.outside[0] and a0 == 0,
                                             pc.outside[1] and b0 == len(s_)),
                                            band=pc.band))
            st.pieces = pieces
            if not st.pieces:
                raise BliskCamError("every pass of the channel would bring the tool body "
                                    "against the stock: take a tool with a slimmer body")
            tip, axis, move, curve, index, rows, blocks = self._linked(st)
            program = Program(tip, axis, move, curve, index, np.zeros(len(tip), np.uint8))
        else:
            if req.check_stock:
                st.warnings.append("the tool body still meets the stock after four rounds "
                                   "of leaving passes out: check the simulation's crashes")
        curves = [PassCurve(s=float(p.level), closed=False, cc=p.tip, normal=p.axis,
                            tip=p.tip, axis=p.axis) for p in st.pieces]
        starts = np.cumsum([0] + [len(b[0]) for b in blocks])
        n_pat = int(req.gaps) if req.gaps is not None else 1
        if n_pat > 1:
            tip, axis, move, curve, index, rows, curves = self._patterned(
                st, blocks, curves, n_pat)
            program = Program(tip, axis, move, curve, index, np.zeros(len(tip), np.uint8))
        plunge = req.plunge_feed or 0.5 * req.feed
        est = machining_time(tip, move, req.feed, plunge, req.rapid_feed)
        est["minutes"] /= n_pat  # the program holds n_pat gaps
        P = part.hub_profile
        zt = st.z[~st.outside]
        cone1 = Cone(float(P[0, 0]), float(P[0, 1]), float(P[-1, 0]), float(P[-1, 1]))
        top_in = st.top[~st.outside]
        cone2 = Cone(float(top_in[0]), float(zt[0]), float(top_in[-1]), float(zt[-1]))
        c = st.cutter
        scallop = (c.r - math.sqrt(max(c.r * c.r - 0.25 * max(req.stepover - 2 * c.e, 0) ** 2,
                                       0.0))) if c.r > 0 else 0.0
        stats = {
            "operation": "rough",
            "pattern": req.pattern,
            "level_mode": req.levels,
            "levels": len(st.levels),
            "depth_per_cut_mm": float(st.depth),
            "level_scallop_mm": req.level_scallop, "level_steps_mm": list(st.steps),
            "floor_band_height_mm": float(st.hub_a + st.band),
            "stepover_mm": float(req.stepover),
            "allowance_mm": float(req.allowance),
            "hub_allowance_mm": float(st.hub_a),
            "lead_deg": math.degrees(req.lead),
            "side_tilt_deg": math.degrees(req.side_tilt),
            "passes": len(st.pieces),
            "rows": len(tip),
            "gaps": part.blade_count,
            "order": req.order,
            "gaps_in_program": int(n_pat),
            "level_blocks": ([[int(a), int(b)] for a, b in zip(starts[:-1], starts[1:],
                                                              strict=True)]
                             if req.order == "level" and n_pat == 1 else []),
            "level_rows": [[int(rows[k][0]), int(rows[k][1])] if k in rows else [0, 0]
                           for k in range(len(st.levels))],
            "level_labels": [lv.label for lv in st.levels],
            "unreachable_levels": list(st.unreachable),
            "feed_mm_min": float(req.feed),
            "plunge_feed_mm_min": float(plunge),
            "rapid_feed_mm_min": float(req.rapid_feed),
            "machining_time_min_gap": est["minutes"],
            "machining_time_min_all_gaps": est["minutes"] * part.blade_count,
            "length_cut_mm": est["lengths_mm"]["cut"],
            "length_link_mm": est["lengths_mm"]["link"],
            "length_approach_retract_mm": est["lengths_mm"]["approach_retract"],
            "length_rapid_mm": est["lengths_mm"]["rapid"],
            "safe_radius_mm": self._r_safe(st),
            "floor_scallop_mm": scallop,
            "wall_levels": sum(lv.walls_only for lv in st.levels),
            "wall_level_step_mm": float(st.wall_step),
            "floor_band_passes": sum(p.band for p in st.pieces),
            # the surface-driven passes are the last ones: the program's curve index of the
            # first (-1: none)
            "floor_band_first_pass": next((k for k, p in enumerate(st.pieces) if p.band), -1),
            "floor_band_side_tilt_range_deg": [math.degrees(t) for t in st.band_tilt]
            if st.band_tilt else [],
            "max_axis_turn_deg": _max_turn(axis, move),
            "axis": "follows the blades" if req.follow_blades else "radial",
            "max_turn_per_step_deg": math.degrees(req.max_turn),
            "poses_inserted_for_turn": int(inserted),
            "side_tilt_range_deg": [math.degrees(min(float(lv.side.min()) for lv in st.levels)),
                                    math.degrees(max(float(lv.side.max()) for lv in st.levels))],
        }
        if req.spindle:
            stats["spindle_rpm"] = float(req.spindle)
        st.path = ToolPath(axis=part.axis, cone1=cone1, cone2=cone2, tool=st.cutter,
                           cusp=max(scallop, 1e-3), chord=max(req.margin, 1e-3),
                           curves=curves, stats=stats, program=program,
                           warnings=list(st.warnings), operation="rough",
                           collision=None if not req.check_stock else {
                               "mode": "check", "checked_poses": int(len(tip)),
                               "unresolved": int(np.count_nonzero(
                                   program.collision_status
                                   if program.collision_status is not None else ())),
                               "checks": "the tool body kept off the blades' and the hub's "
                                         "allowance by the region; against the stock the "
                                         "levels above left by simulating the program"})
        yield Progress(1.0, f"linked {len(tip)} rows")

    def _linked(self, st: _State):
        """The program of gap 0's pieces in the request's order: (tip, axis, move, curve,
        index, rows, blocks) — by gap linked as one (:func:`..channel.patterns.link_program`),
        by level each level linked alone from and back to the safe radius (the post
        interleaves the gaps level by level); rows[level] the level's [first, last) rows,
        blocks the linked blocks (one, or one per level)."""
        if st.req.order != "level":
            tip, axis, move, curve, index, rows = link_program(st.pieces, st.part.axis,
                                                               self._r_safe(st))
            return tip, axis, move, curve, index, rows, [(tip, axis, move, curve, index)]
        blocks = self._level_blocks(st)
        tip, axis, move, curve, index = (np.concatenate(x) for x in zip(*blocks, strict=True))
        starts = np.cumsum([0] + [len(b[0]) for b in blocks])
        rows = {lv: (int(a), int(b)) for lv, a, b in zip(
            sorted({pc.level for pc in st.pieces}), starts[:-1], starts[1:], strict=True)}
        return tip.reshape(-1, 3), axis.reshape(-1, 3), move, curve, index, rows, blocks

    def _level_blocks(self, st: _State):
        """Gap 0's program as one block per level: each level's pieces linked alone, from and
        back to the safe radius (tip, axis, move, curve, index; curve indexes ``st.pieces``)."""
        blocks = []
        for lv in sorted({pc.level for pc in st.pieces}):
            ids = np.array([k for k, pc in enumerate(st.pieces) if pc.level == lv], np.int64)
            t, a, m, c, i, _ = link_program([st.pieces[k] for k in ids], st.part.axis,
                                            self._r_safe(st))
            blocks.append((t, a, m, np.where(c >= 0, ids[np.maximum(c, 0)], -1), i))
        return blocks

    @staticmethod
    def _rows_of(st: _State, curves, curve) -> dict:
        """{level: [first, last + 1) rows of its passes} of a program's ``curve`` column."""
        level = np.array([int(pc.s) for pc in curves])
        cut = np.nonzero(curve >= 0)[0]
        rows = {}
        for lv in np.unique(level[curve[cut]]):
            r = cut[level[curve[cut]] == lv]
            rows[int(lv)] = (int(r.min()), int(r.max()) + 1)
        return rows

    def _patterned(self, st: _State, blocks, curves, n_gaps: int):
        """The program of ``n_gaps`` gaps in the request's order (:mod:`..channel.gaps`) from
        gap 0's ``blocks`` (the whole gap, or one per level). Returns (tip, axis, move, curve,
        index, rows, curves): rows[level] the [first, last + 1) rows of the level's passes
        over all gaps, curves gap 0's passes then each gap's turned copies."""
        part = st.part
        n = len(curves)
        tip, axis, move, curve, index, _, _ = pattern_gaps(blocks, part.axis, part.pitch,
                                                           n_gaps, st.req.order, n)
        d = part.axis.d
        out = list(curves)
        for g in range(1, n_gaps):
            turn = g * part.pitch
            for pc in curves:
                t = rotate_about(pc.tip, d, turn, part.axis.o)
                a = rotate_about(pc.axis, d, turn)
                out.append(PassCurve(s=pc.s, closed=False, cc=t, normal=a, tip=t, axis=a))
        return tip, axis, move, curve, index, self._rows_of(st, out, curve), out

    def finish(self, state, seconds):
        return OperationResult(state.path, None, dict(seconds))


def _max_turn(axis, move) -> float:
    """Largest angle (degrees) between the tool axes of consecutive cutting poses."""
    cut = np.nonzero((np.asarray(move)[1:] == MOVE_CUT) & (np.asarray(move)[:-1] == MOVE_CUT))[0]
    if len(cut) == 0:
        return 0.0
    a = np.asarray(axis, float)
    w = np.arctan2(np.linalg.norm(np.cross(a[cut], a[cut + 1]), axis=1),
                   np.einsum("ij,ij->i", a[cut], a[cut + 1]))
    return float(np.degrees(w).max())


def plan_roughing(part: BliskPart, request: RoughRequest, stock: RadialDexels) -> ToolPath:
    """Run :class:`RoughingOperation` to the end; returns the tool path."""
    return run_operation(RoughingOperation(), part, request, stock).path
