"""Hub finishing (paper 003 §5, Figs. 8–10): the channel between blade 0's one side and blade
1's other side (blade 1 = blade 0 turned by the pitch), finished from the leading to the
trailing edge with a ball by boundary-conformed passes on the hub surface of revolution
(:mod:`..hub.channel`), in two regions with their own spacing (the main hub and the ring
beside the blade roots), patterned to all N gaps on request.

Stages over one :class:`HubState`: channel (clearance boundaries beside both blades, the
edges and the extension) → passes (ratios per region from the stepover or the scallop on the
hub's own curvature, chord sampling, zigzag order) → orient (tool axis: the hub normal leaned
by the lead angle along the feed, so the ball never cuts with its tip at zero speed, and
tilted across the feed toward the channel's middle, by the tilt angle at the blades and 0 in
the middle) → link (approach, retract and rapids via a clearance cylinder outside the blade
tips, :func:`..paths.linking.build_program`) → collision (holder and shank against blade 0
and its neighbours, :mod:`..collision.avoid`, mode "check": reported, nothing changed) →
pattern (the other N − 1 gaps, when asked) → checks (the figures in the stats).

The operation reads a :class:`~..part.model.BliskPart` and a :class:`HubRequest`; the stock
is not read. Lengths mm, angles radians (the stats give degrees for people).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.spatial import cKDTree

from ..collision.obstacles import Obstacles
from ..collision.options import CollisionOptions
from ..collision.scene import CollisionScene
from ..errors import BliskCamError, ToolError
from ..geometry.distance import MeshDistance
from ..geometry.mesh import TriMesh
from ..geometry.vectors import rotate_about
from ..hub.channel import (
    Channel,
    Region,
    TipChannel,
    channel_boundaries,
    pass_ratios,
    sample_pass,
)
from ..hub.surface import HubSurface, scallop_for_stepover
from ..part.model import BliskPart
from ..part.profiles import Profile
from ..paths.linking import Clearance, LinkOptions, build_program
from ..paths.orientation import feed_directions, lead_tilt_axes
from ..runtime import Progress
from ..tool.assembly import ToolAssembly
from ..tool.cutter import Cutter
from ..toolpath.types import (
    FLAG_ZERO_SPEED,
    STATUS_CLEAR,
    STATUS_UNRESOLVED,
    PassCurve,
    Program,
    ToolPath,
)
from .operation import Operation, OperationResult, Stage

__all__ = ["HUB_FINISH", "HubFinish", "HubRequest", "HubState", "body_clearance",
           "flute_clearance", "pattern_gaps", "plan_channel", "start_state", "tool_assembly"]

GAPS = ("one", "all")
AXIS_MODES = ("channel", "normal")


@dataclass(frozen=True)
class HubRequest:
    """What decides a hub (or fillet) finishing path. mm and radians.

    Attributes
    ----------
    tool_diameter : float — the ball's diameter
    stepover, scallop : float or None — the main region's spacing (exactly one)
    ring_width : float — width of the ring beside each blade root with its own spacing
        (0: one region); ring_stepover / ring_scallop its spacing (default: the main one)
    extend : float — passes extended past the leading and trailing edges
    lead : float, rad — tool axis leaned from the hub normal along the feed (≠ 0: the ball
        never cuts at its tip, where the speed is zero)
    tilt : float, rad — tool axis tilted across the feed toward the channel's middle at the
        blades (fading to 0 in the middle); for fillet passes: away from the blade
    axis_mode : "channel" — the axis aims through the channel at the blade tips (kept the
        shank radius + safety inside the tips' gap, at the same ratio across it as the pass),
        then leaned by ``lead`` (and ``tilt``); "normal" — the hub normal leaned by ``lead``
        and tilted by ``tilt``
    aim_spread : float in [0, 1] — channel mode: pass t aims at the ratio 0.5 + (t − 0.5) ×
        aim_spread across the tips' gap (1: the first pass aims beside blade 0's tip, 0: every
        pass at the middle; the blade sides bulge between root and tip)
    allowance : float — distance kept from the blades (stock left on them)
    hub_allowance : float — stock left on the hub, mm (hub semi-finishing, paper 003 §5:
        the passes are planned on the hub offset by it, :meth:`..hub.surface.HubSurface.offset`;
        0: finishing); fillet finishing leaves none
    chord : float — chord tolerance of the CC polylines; max_step the longest step
    gaps : "one" | "all" — gap 0 only (the NC post repeats it per blade) or all N gaps; the
        collision check runs on gap 0 before the pattern and the other gaps take its status
        (the part is one blade and its copies turned by the pitch, so every gap is gap 0
        turned; a scanned blisk whose blades differ is not checked gap by gap)
    approach : float — approach/retract length along the tool axis
    clearance_margin : float — the clearance cylinder lies this far outside the blade tips
    collisions : "check" | "off"; flute_length, holder, safety — the tool assembly
        (:class:`~..collision.options.CollisionOptions`)
    fillet_radius : float or None — fillet finishing: the fillet's radius (the ball must be
        smaller); layers : int — loops across the fillet (1: the lower edge only); or
        ``scallop`` (mm): the layers spaced for it, from the lower edge up to the contact at
        ``layers_top`` mm above the hub (default: the fillet's top; above it up the wall, to
        where blade finishing starts); ``hub_rings`` (with ``scallop``): loops of the ball
        on the hub round the root, outward of the lower edge, spaced for the scallop
    """

    tool_diameter: float
    stepover: float | None = None
    scallop: float | None = None
    ring_width: float = 0.0
    ring_stepover: float | None = None
    ring_scallop: float | None = None
    extend: float = 5.0
    lead: float = math.radians(10.0)
    tilt: float = 0.0
    axis_mode: str = "channel"
    aim_spread: float = 0.3
    allowance: float = 0.0
    hub_allowance: float = 0.0
    chord: float = 0.05
    max_step: float = 2.0
    gaps: str = "one"
    approach: float = 2.0
    clearance_margin: float = 10.0
    collisions: str = "check"
    flute_length: float | None = None
    holder: tuple | None = None
    safety: float = 1.0
    fillet_radius: float | None = None
    layers: int = 1
    layers_top: float | None = None
    hub_rings: int = 0

    @property
    def radius(self) -> float:
        return 0.5 * float(self.tool_diameter)

    @property
    def tool_name(self) -> str:
        return f"Ø{self.tool_diameter:g} ball"

    def check(self, *, spacing: bool = True):
        """ToolError / BliskCamError naming the first bad value."""
        def positive(name, v, zero_ok=False):
            if v is None or not math.isfinite(float(v)) or (float(v) < 0 if zero_ok
                                                             else float(v) <= 0):
                raise BliskCamError(f"{name.replace('_', ' ')} must be a number "
                                    f"{'≥' if zero_ok else '>'} 0 mm, got {v!r}")
        if not (math.isfinite(float(self.tool_diameter)) and self.tool_diameter > 0):
            raise ToolError(f"tool diameter must be > 0 mm, got {self.tool_diameter!r}")
        if spacing:
            if (self.stepover is None) == (self.scallop is None):
                raise BliskCamError("give the hub spacing as a stepover or a scallop height "
                                    "(exactly one)")
            positive("stepover" if self.stepover is not None else "scallop",
                     self.stepover if self.stepover is not None else self.scallop)
            if self.scallop is not None and self.scallop >= self.radius:
                raise BliskCamError(f"scallop {self.scallop:g} mm must be smaller than the ball "
                                    f"radius {self.radius:g} mm")
            if self.ring_stepover is not None and self.ring_scallop is not None:
                raise BliskCamError("give the ring's spacing as a stepover or a scallop, not "
                                    "both")
            for name in ("ring_stepover", "ring_scallop"):
                if getattr(self, name) is not None:
                    positive(name, getattr(self, name))
        for name in ("extend", "allowance", "hub_allowance", "ring_width"):
            positive(name, getattr(self, name), zero_ok=True)
        for name in ("chord", "max_step", "approach", "clearance_margin"):
            positive(name, getattr(self, name))
        for name in ("lead", "tilt"):
            v = float(getattr(self, name))
            if not (math.isfinite(v) and abs(v) < math.radians(60.0)):
                raise BliskCamError(f"{name} must lie within ±60°, got {math.degrees(v):g}°")
        if self.gaps not in GAPS:
            raise BliskCamError(f"gaps must be one of {', '.join(GAPS)}, got {self.gaps!r}")
        if not 0.0 <= float(self.aim_spread) <= 1.0:
            raise BliskCamError(f"aim spread must lie in [0, 1], got {self.aim_spread!r}")
        if self.axis_mode not in AXIS_MODES:
            raise BliskCamError(f"axis mode must be one of {', '.join(AXIS_MODES)}, got "
                                f"{self.axis_mode!r}")
        if self.collisions not in ("check", "off"):
            raise BliskCamError(f"collisions must be check or off, got {self.collisions!r}")

    def main_region(self) -> Region:
        return Region(stepover=self.stepover, scallop=self.scallop)

    def ring_region(self) -> Region:
        if self.ring_stepover is None and self.ring_scallop is None:
            return self.main_region()
        return Region(stepover=self.ring_stepover, scallop=self.ring_scallop)


@dataclass
class HubState:
    """The hub finishing program as its stages build it (see the module docstring)."""

    part: BliskPart
    req: HubRequest
    cutter: Cutter
    hub: HubSurface
    blade: TriMesh
    channel: Channel | None = None
    ratios: np.ndarray | None = None
    curves: list = field(default_factory=list)
    program: Program | None = None
    stats: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)
    collision: dict | None = None  # the collision summary (paths JSON "collision")
    operation: str = "hub-finish"

    def path(self) -> ToolPath:
        prof = Profile.from_list(self.part.hub_profile.tolist())
        return ToolPath(axis=self.part.axis, cone1=prof, cone2=prof, tool=self.cutter,
                        cusp=float(self.req.scallop or self.req.chord), chord=self.req.chord,
                        curves=self.curves, stats=self.stats, program=self.program,
                        warnings=self.warnings,
                        collision=self.collision,
                        operation=self.operation)


def start_state(part: BliskPart, req: HubRequest, *, spacing: bool = True) -> HubState:
    """Checks the inputs (before any long work) and makes the state."""
    if not isinstance(part, BliskPart):
        raise BliskCamError("hub finishing needs the blisk as a part (BliskPart: blade, hub "
                            "profile, blade count)")
    req.check(spacing=spacing)
    if part.blade_count < 2:
        raise BliskCamError("hub finishing needs at least two blades (the gap between blade 0 "
                            "and blade 1)")
    cutter = Cutter.ball(req.radius)
    hub = HubSurface(part.hub_profile, part.axis).offset(req.hub_allowance)
    return HubState(part=part, req=req, cutter=cutter, hub=hub,
                    blade=TriMesh.from_arrays(part.blade_vertices, part.blade_faces))


def _stage_channel(st: HubState):
    st.channel = yield from channel_boundaries(
        st.blade, st.hub, st.part.pitch, st.req.radius, allowance=st.req.allowance,
        extend=st.req.extend, tool_name=st.req.tool_name)
    st.warnings.extend(st.channel.notes)


def plan_channel(part: BliskPart, req: HubRequest) -> Channel:
    """The channel of ``part`` for ``req`` alone (the "channel" stage): its boundaries, e.g.
    to read the stock between them after a simulation."""
    st = start_state(part, req)
    for _ in _stage_channel(st):
        pass
    return st.channel


def _stage_passes(st: HubState):
    req, ch = st.req, st.channel
    st.ratios = pass_ratios(ch, req.main_region(), req.ring_region(), req.ring_width)
    curves = []
    for k, t in enumerate(st.ratios):
        cc, n, _, _ = sample_pass(ch, float(t), req.chord, req.max_step)
        if k % 2 == 1:  # zigzag: every other pass from the trailing edge back
            cc, n = cc[::-1].copy(), n[::-1].copy()
        curves.append(PassCurve(s=float(t), closed=False, cc=cc, normal=n, tip=cc.copy(),
                                axis=n.copy()))
        yield Progress((k + 1) / len(st.ratios), "hub: passes")
    st.curves = curves


def _orient_hub(st: HubState):
    req, hub = st.req, st.hub
    tip_channel = TipChannel(st.blade, hub, st.part.pitch) if req.axis_mode == "channel" else None
    margin = _body_radius(st) + req.safety
    for c in st.curves:
        f = feed_directions(c.cc, c.normal, False)
        k = np.cross(f, c.normal)
        _, th, _ = hub.coordinates(c.cc)
        side = np.sign(np.einsum("ij,ij->i", k, hub.tangential(th)))
        tilt = req.tilt * (1.0 - 2.0 * c.s) * side  # toward the channel's middle
        if tip_channel is None:
            c.axis = lead_tilt_axes(f, c.normal, k, req.lead, tilt)
        else:  # aim through the channel at the tips, then lead and tilt from there
            centre = c.cc + req.radius * c.normal
            z = (c.cc - st.part.axis.o) @ st.part.axis.d
            t_aim = 0.5 + (c.s - 0.5) * req.aim_spread
            aim = tip_channel.point(z, np.full(len(z), t_aim), margin) - centre
            a0 = aim / np.linalg.norm(aim, axis=1)[:, None]
            f0 = f - np.einsum("ij,ij->i", f, a0)[:, None] * a0
            f0 /= np.maximum(np.linalg.norm(f0, axis=1), 1e-300)[:, None]
            k0 = np.cross(f0, a0)
            c.axis = _at_least_lead(lead_tilt_axes(f0, a0, k0, req.lead, tilt), c.normal, f,
                                    abs(req.lead))
        c.tip = st.cutter.cl_points(c.cc, c.normal, c.axis)
        c.flags = np.where(st.cutter.zero_speed(c.normal, c.axis, 1e-3), FLAG_ZERO_SPEED,
                           0).astype(np.uint8)
    return
    yield


def _at_least_lead(a, n, f, lead: float):
    """Axes ``a`` turned away from the normals ``n`` (in their common plane; along the feed
    ``f`` where they coincide) where they lie closer than ``lead`` rad: the ball's contact
    then stays off its tip (zero cutting speed)."""
    cos = np.einsum("ij,ij->i", a, n)
    close = cos > math.cos(lead)
    if lead <= 0.0 or not close.any():
        return a
    u = a - cos[:, None] * n
    ln = np.linalg.norm(u, axis=1)
    u = np.where((ln > 1e-9)[:, None], u / np.maximum(ln, 1e-300)[:, None], f)
    out = a.copy()
    out[close] = math.cos(lead) * n[close] + math.sin(lead) * u[close]
    return out


def _body_radius(st: HubState) -> float:
    """The radius of the tool body just above the flute (shank), mm."""
    if st.req.holder:
        return float(st.req.holder[0][1])
    return 0.5 * float(st.cutter.shank_diameter)


def _stage_link(st: HubState):
    r_top = float(np.max(st.part.envelope[:, 0]))
    opts = LinkOptions(approach=st.req.approach, direct_link=0.0,
                       clearance=Clearance(r_top + st.req.clearance_margin),
                       tool_radius=st.req.radius, chord=st.req.chord)
    st.program = build_program(st.curves, opts, st.part.axis, tool_radius=st.req.radius)
    return
    yield


def tool_assembly(req: HubRequest, cutter: Cutter) -> ToolAssembly:
    """The request's tool assembly (flute length, holder profile, safety)."""
    return CollisionOptions(mode="check", blade_count=2, flute_length=req.flute_length,
                            holder=req.holder, safety=req.safety).assembly(cutter)


def body_clearance(part: BliskPart, cutter: Cutter, assembly: ToolAssembly, tips, axes):
    """(k,) clearance (mm) of the tool body — shank and holder, everything above the flute —
    from blade 0 and its two neighbours at each pose (tips, axes (k, 3)), by the collision
    scene (:mod:`..collision.scene`); capped at safety + a margin. The flute itself (the ball
    and the cutting length) is left out: it is meant to come as close as the allowance to
    both blades (see :func:`flute_clearance`); the scene sees the axis line from the ball
    centre to the flute's end, then the body."""
    fl = float(assembly.flute_length)
    rho = float(cutter.radius)
    tiny = 0.1  # the scene's own "flute": a 0.1 mm ball at the ball centre
    prof = tuple((float(z) - rho, float(r)) for z, r in assembly.profile)
    body = ToolAssembly(tiny, ((tiny, 0.0), (max(fl - rho, tiny), 0.0)) + prof,
                        assembly.safety)
    obstacles = Obstacles.build(part.blade_vertices, part.blade_faces, part.axis,
                                part.blade_count, 1, [])
    scene = CollisionScene(obstacles, Cutter.ball(0.5 * tiny), body)
    tips = np.asarray(tips, float)
    axes = np.asarray(axes, float)
    return scene.detect(tips + rho * axes, axes).clearance


def flute_clearance(part: BliskPart, blade: MeshDistance, radius: float, flute_length: float,
                    tips, axes, step: float = 1.0, report: float = 5.0) -> np.ndarray:
    """(k,) clearance (mm) of the flute (ball and cutting length, radius ``radius``) from
    blade 0 and blade 1 (the gap's two blades): the distance of its axis segment (ball centre
    → flute end, sampled every ``step`` mm) to the blade meshes minus the radius (< 0: the
    flute would cut into a blade). Figures beyond ``report`` mm are capped there (the
    samples far from every blade vertex are not measured exactly)."""
    n = max(2, int(math.ceil(max(flute_length - radius, 0.0) / step)) + 1)
    s = radius + (flute_length - radius) * np.linspace(0.0, 1.0, n)
    P = (tips[:, None, :] + s[None, :, None] * axes[:, None, :]).reshape(-1, 3)
    V, F = blade.mesh.V, blade.mesh.F
    edge = float(np.linalg.norm(V[F] - V[np.roll(F, 1, axis=1)], axis=2).max())
    tree = cKDTree(V)
    best = np.full(len(P), radius + report)
    for k in (0, 1):
        Q = rotate_about(P, part.axis.d, -k * part.pitch, part.axis.o) if k else P
        dv, _ = tree.query(Q)
        near = dv - edge < radius + report  # mesh distance ≥ vertex distance − edge length
        if near.any():
            best[near] = np.minimum(best[near], blade.query(Q[near]).distance)
    return np.minimum(best.reshape(len(tips), n).min(axis=1) - radius, report)


def _stage_collision(st: HubState):
    """Holder and shank against both blades of the gap (and the next ones), the flute's
    clearance; figures in the stats, a warning naming the poses that collide."""
    if st.req.collisions == "off":
        return
    yield Progress(0.0, "hub: holder and shank against the blades")
    asm = tool_assembly(st.req, st.cutter)
    prog = st.program
    body = body_clearance(st.part, st.cutter, asm, prog.tip, prog.axis)
    cut = prog.curve >= 0
    flute = flute_clearance(st.part, MeshDistance(st.blade), st.req.radius,
                            float(asm.flute_length), prog.tip[cut], prog.axis[cut])
    hit = body < asm.safety
    status = np.where(hit, STATUS_UNRESOLVED, STATUS_CLEAR).astype(np.int8)
    clearance = np.minimum(body, float(asm.safety) + 5.0)
    prog.collision_status, prog.clearance = status, clearance
    prog.rotation_deg = np.zeros(len(prog))
    for ci, c in enumerate(st.curves):
        rows = np.flatnonzero(prog.curve == ci)
        k = len(c.cc)
        cs, cl = np.zeros(k, np.int8), np.full(k, float(asm.safety) + 5.0)
        cs[prog.index[rows]] = status[rows]
        cl[prog.index[rows]] = clearance[rows]
        c.collision = {"status": cs, "clearance": cl, "rotation": np.zeros(k),
                       "rotation_deg": np.zeros(k)}
    st.collision = {
        "mode": "check", "checked_poses": int(len(prog)), "colliding_before": int(hit.sum()),
        "corrected": 0, "unresolved": int(hit.sum()), "min_clearance": float(body.min()),
        "obstacles": {"names": ["blade", "blade +1", "blade -1"],
                      "blade_count": st.part.blade_count, "neighbours": 1},
        "assembly": asm.as_dict(), "assembly_text": asm.describe(),
        "safety": float(asm.safety),
        "checks": "tool body (shank, holder) against the blades; the flute's clearance is "
                  "in the stats (flute_clearance_min_mm)",
    }
    st.stats.update({
        "assembly": asm.describe(),
        "body_clearance_min_mm": float(body.min()),
        "body_collision_rows": int(hit.sum()),
        "flute_clearance_min_mm": float(flute.min()),
    })
    if hit.any():
        rows = np.flatnonzero(hit)
        st.warnings.append(
            f"the tool body (shank or holder) comes within the safety distance "
            f"{asm.safety:g} mm of a blade at {len(rows)} program rows (first row {rows[0]}, "
            f"clearance {body.min():.2f} mm): use a longer or slimmer shank (--holder), "
            "a smaller aim spread or another lead")
    yield Progress(1.0, "hub: collisions checked")


def _stage_pattern(st: HubState):
    if st.req.gaps == "all":
        st.curves, st.program = pattern_gaps(st.curves, st.program, st.part)
    return
    yield


def _stage_checks(st: HubState):
    """Figures measured on the result: the ball centres' clearance from the blades, the
    spacing and the scallop the spacing leaves on the hub's curvature."""
    req, ch, hub = st.req, st.channel, st.hub
    dist = MeshDistance(st.blade)
    gap0 = [c for c in st.curves[:len(st.ratios)]]
    C = np.vstack([c.cc + req.radius * c.normal for c in gap0])
    d0 = dist.query(C).signed_distance
    C1 = rotate_about(C, st.part.axis.d, -st.part.pitch, st.part.axis.o)
    d1 = dist.query(C1).signed_distance
    # the distance between neighbouring passes (⊥ to them) and the scallop it leaves on the
    # hub's normal curvature across them, at every station
    r = hub.rz(ch.m)[:, 0]
    dth = ch.theta_b - ch.theta_a
    dm = np.gradient(ch.m)
    sep_max, scallop_max = 0.0, 0.0
    for t0, t1 in zip(st.ratios[:-1], st.ratios[1:], strict=True):
        th = ch.theta_a + 0.5 * (t0 + t1) * dth
        beta = np.arctan2(r * np.gradient(th), dm)
        sep = (t1 - t0) * r * np.abs(dth) * np.abs(np.cos(beta))
        kappa = hub.normal_curvature(ch.m, beta + 0.5 * math.pi)
        sep_max = max(sep_max, float(sep.max()))
        scallop_max = max(scallop_max, float(scallop_for_stepover(req.radius, sep, kappa).max()))
    zero = int(sum(int(np.count_nonzero(c.flags & FLAG_ZERO_SPEED)) for c in st.curves))
    # the ball's distance from the hub itself (the part's profile, not the offset planned on):
    # the stock it leaves where it touches, measured independently of the offset
    left = HubSurface(st.part.hub_profile, st.part.axis).distance(C) - req.radius
    st.stats.update({
        "operation": st.operation,
        "tool": st.req.tool_name,
        "passes": int(len(st.ratios)),
        "gaps": st.part.blade_count if req.gaps == "all" else 1,
        "curves": len(st.curves),
        "poses": int(sum(len(c.cc) for c in st.curves)),
        "channel_width_min_mm": float(ch.min_width),
        "leading_edge_m_mm": float(ch.m_le),
        "trailing_edge_m_mm": float(ch.m_te),
        "extension_clipped": bool(ch.clipped),
        "stepover_max_mm": sep_max,
        "scallop_estimate_mm": scallop_max,
        "clearance_blade0_min_mm": float(d0.min() - req.radius),
        "clearance_blade1_min_mm": float(d1.min() - req.radius),
        "lead_deg": math.degrees(req.lead),
        "tilt_deg": math.degrees(req.tilt),
        "ring_width_mm": float(req.ring_width),
        "zero_speed_poses": zero,
        "hub_allowance_mm": float(req.hub_allowance),
        "hub_left_min_mm": float(left.min()),
        "hub_left_max_mm": float(left.max()),
    })
    return
    yield


def pattern_gaps(curves, program: Program, part: BliskPart):
    """The passes and program of gap 0 repeated for gaps 1 … N − 1 (turned by k · pitch),
    joined by rapids along the clearance radius (every 5° so the chord stays outside)."""
    ax = part.axis
    n = part.blade_count
    out_curves = []
    parts = []
    last_tip = last_axis = None
    for k in range(n):
        ang = k * part.pitch

        def rot(P, vec=False, ang=ang):
            return rotate_about(P, ax.d, ang, None if vec else ax.o)
        for c in curves:
            out_curves.append(replace(c, cc=rot(c.cc), normal=rot(c.normal, True),
                                      tip=rot(c.tip), axis=rot(c.axis, True)))
        tip, axis = rot(program.tip), rot(program.axis, True)
        if last_tip is not None:
            parts.append(_arc_rows(last_tip, last_axis, tip[0], axis[0], ax, program))
        cur = program.curve.copy()
        cur[cur >= 0] += k * len(curves)
        parts.append(Program(tip=tip, axis=axis, move=program.move.copy(), curve=cur,
                             index=program.index.copy(), flags=program.flags.copy(),
                             collision_status=program.collision_status,
                             clearance=program.clearance, rotation_deg=program.rotation_deg))
        last_tip, last_axis = tip[-1], axis[-1]
    cat = {}
    for name in ("tip", "axis", "move", "curve", "index", "flags"):
        cat[name] = np.concatenate([getattr(p, name) for p in parts])
    for name in ("collision_status", "clearance", "rotation_deg"):
        vals = [getattr(p, name) for p in parts]
        cat[name] = None if any(v is None for v in vals) else np.concatenate(vals)
    return out_curves, Program(**cat)


def _arc_rows(p0, a0, p1, a1, ax, like: Program) -> Program:
    """Rapid rows from p0 to p1 (both at the clearance radius) along the clearance circle."""
    e1, e2, d = ax.angular_frame()
    q0, q1 = p0 - ax.o, p1 - ax.o
    r0, r1 = np.hypot(q0 @ e1, q0 @ e2), np.hypot(q1 @ e1, q1 @ e2)
    t0, t1 = math.atan2(q0 @ e2, q0 @ e1), math.atan2(q1 @ e2, q1 @ e1)
    dt = (t1 - t0 + math.pi) % (2 * math.pi) - math.pi
    k = max(1, int(math.ceil(abs(dt) / math.radians(5.0))))
    s = np.arange(1, k) / k
    th = t0 + s * dt
    rr = np.maximum(r0, r1)
    z = q0 @ d + s * (q1 @ d - q0 @ d)
    P = ax.o + z[:, None] * d + rr * (np.cos(th)[:, None] * e1 + np.sin(th)[:, None] * e2)
    A = (1 - s)[:, None] * a0 + s[:, None] * a1
    A /= np.linalg.norm(A, axis=1)[:, None]
    m = len(P)
    return Program(tip=P.reshape(-1, 3), axis=A.reshape(-1, 3), move=np.full(m, 4, np.int8),
                   curve=np.full(m, -1, np.int64), index=np.full(m, -1, np.int64),
                   flags=np.zeros(m, np.uint8),
                   collision_status=None if like.collision_status is None else
                   np.zeros(m, np.int8),
                   clearance=None if like.clearance is None else
                   np.full(m, float(like.clearance[-1])),
                   rotation_deg=None if like.rotation_deg is None else np.zeros(m))


class HubFinish(Operation):
    """Hub finishing as an operation (see the module docstring)."""

    name = "hub_finish"

    def start(self, part: BliskPart, request: HubRequest, stock=None) -> HubState:
        return start_state(part, request)

    def stages(self, state: HubState) -> tuple[Stage, ...]:
        return (Stage("channel", _stage_channel), Stage("passes", _stage_passes),
                Stage("orient", _orient_hub), Stage("link", _stage_link),
                Stage("collision", _stage_collision), Stage("pattern", _stage_pattern),
                Stage("checks", _stage_checks))

    def finish(self, state: HubState, seconds: dict) -> OperationResult:
        return OperationResult(path=state.path())


#: the hub finishing operation
HUB_FINISH = HubFinish()
