"""Collision avoidance, and the one entry point the front ends call (:func:`run_collisions`).

Mode "avoid" has two methods (``CollisionOptions.method``): **"plan"** (default) chooses the
axes of every pass together by shortest path (:mod:`.axis_plan`: clear, within the lean
limits and a turn limit per mm, the motion between poses checked; unresolved poses as
ranges with a reason, :mod:`.ranges`); **"rotate"** is paper 004 §3, the smallest rotation
of each colliding pose, described below (kept for comparison: its axes may jump between
neighbouring poses).

For a cutting pose whose tool assembly comes closer than ds to an obstacle
(:mod:`.collision`), let F be the closest obstacle point and P the pivot — the ball centre
for a ball-end cutter (the ball keeps its contact at the CC point whatever the axis), the CC
point for other cutters (their tip is recomputed from the CC point for the new axis with
:meth:`..tool.cutter.Cutter.cl_points`, keeping the planned pose's small lift λ along the
normal). In the plane M through P, F and F′ (F's foot on the
axis, Eq. 10) the axis is turned away from F by the smallest angle that puts F at the distance
L = R2 + ds from the axis line (Eq. 11; R2 the radius of the colliding part at F's height):

    θ = arcsin(L / |PF|) − α,      α = ∠(PF, axis)                         (Eq. 12)
    T′ = cos θ · T + sin θ · ê,    ê = (F′ − F) / |F′ − F|                    (Eq. 13)

(the paper prints |PF′| in Eq. 12; the distance of F from an axis through P at angle α + θ is
|PF| sin(α + θ), so |PF| it is — Eq. 17 has it so). The clearance is then measured again;
where a pose still collides (another point of the same blade, or the adjacent blade on the
other side of the channel) the step repeats with L_j = R2 + j · ds (Eqs. 16–17) up to
``max_iterations`` times. A pose whose corrected axis leaves the limits (|lead| ≤ max_lead,
|tilt| ≤ max_tilt from the surface normal, as in :mod:`..paths.gouge`; where the planned axis
already leans further, e.g. a radial strategy, its own |lead| and |tilt| are the limits: the
turn may not lean it further than planned), or that the cutter can
no longer touch, or that the iterations do not clear, is **unresolved**: it keeps its planned
pose and status 2 — it is never dropped.

For comparison (paper 004 Table 1, Ref. [18]) the report gives, per colliding pose, the angle
a rotation toward the obstacle's normal at F would need for the same clearance:
A cos θ + B sin θ = sqrt(|PF|² − L²) with A = PF · T, B = PF · n̂⊥ (n̂⊥ the obstacle normal's
part ⊥ T), i.e. θₙ = atan2(B, A) + arccos(sqrt(|PF|² − L²) / hypot(A, B)) ≥ θ.

Removal depth (Eqs. 14–15): turning the axis changes which part of the flute faces the target
blade. The posed cutter (:class:`~..tool.cutter.Cutter` up to the flute length) is measured against
the target blade's vertices and face centroids around the contact; where it lies deeper than
it did with the planned axis by more than ε (``gouge_tol``, default chord / 4), the tip is
lifted along the surface normal by that excess (Eq. 15) and the pose re-checked.

Smoothing: the corrected axes are kept, and their neighbours on the pass turned toward them
until no consecutive turn exceeds max(``max_turn``, the planned turn there) (default 2° per
pose) — a ramp in and out of every corrected run; then two rounds in which the corrected poses
may move too (toward each other where neighbouring corrections differ). A smoothed pose that
would collide, or leave the lead/tilt limits, keeps its axis of the round before; where the
limit still cannot hold (a corrected pose next to an unresolved one) the report counts it
(``n_turn_over``). Everything is then checked again (all poses, links and rapids included);
approach/retract points follow the corrected axis of the pass end they belong to. A run of
link, approach, retract or rapid poses that still collides is re-routed — retract to the
clearance surface, along it, approach — by :mod:`.reroute`; where no route clears,
its poses stay as planned and the colliding ones are unresolved (status 2).

Status per pose: 0 clear (unchanged), 1 corrected (axis or tip changed, clear), 2 unresolved.
In ``"check"`` mode nothing changes and every colliding pose gets status 2.

Lengths mm, angles radians (the paths JSON writes ``rotation_deg``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial import cKDTree

from ..errors import CollisionError
from ..geometry.vectors import angle_between, unit
from ..paths.orientation import clamp_turn, consecutive_turn, lead_tilt_of, local_frames
from ..runtime import run_to_end
from ..tool.cutter import Cutter
from ..toolpath.types import (
    MOVE_APPROACH,
    MOVE_RETRACT,
    STATUS_CLEAR,
    STATUS_CORRECTED,
    STATUS_UNRESOLVED,
    PassCurve,
    Program,
    ToolPath,
)
from .axis_field import pass_turn_limits
from .axis_plan import plan_axes
from .obstacles import Obstacle, Obstacles
from .options import CollisionOptions
from .posed_tool import PART_FLUTE, _posed_sd
from .ranges import holder_hint, unresolved_ranges
from .report import CollisionReport
from .reroute import reroute_links
from .scene import CollisionScene, Detection

__all__ = ["avoid_collisions", "iter_run_collisions", "run_collisions"]
_DETECT_CHUNK = 4096
#: largest rotation searched per step (beyond the axis limits anyway), radians
_MAX_SEARCH = math.radians(60.0)
#: (pose, angle) pairs evaluated at once by the rotation scan
_SCAN_PAIRS = 200_000


# ====================================================================== helpers
def _copy_curve(c: PassCurve) -> PassCurve:
    return replace(c, cc=c.cc.copy(), normal=c.normal.copy(), tip=c.tip.copy(),
                   axis=c.axis.copy(), face=np.asarray(c.face).copy(),
                   move=c.move.copy(), flags=c.flags.copy(),
                   ratio=None if c.ratio is None else c.ratio.copy())


def _detect_chunks(scene: CollisionScene, tips, axes):
    """Generator: detect in chunks (yields the done fraction), returns arrays."""
    m = len(tips)
    outs = []
    for s in range(0, max(m, 1), _DETECT_CHUNK):
        outs.append(scene.detect(tips[s:s + _DETECT_CHUNK], axes[s:s + _DETECT_CHUNK]))
        yield min(1.0, (s + _DETECT_CHUNK) / max(m, 1))
    return _cat(outs, scene)


def _cat(dets, scene):
    if not dets:
        return Detection(np.zeros(0), np.zeros(0, np.int64), np.zeros(0, np.int8),
                         np.zeros((0, 3)), np.zeros((0, 3)), scene.safety, scene.cap)
    return Detection(*(np.concatenate([getattr(d, k) for d in dets]) for k in
                       ("clearance", "obstacle", "part", "point", "normal")),
                     scene.safety, scene.cap)


def _touch_ok(cutter: Cutter, normal, axis):
    """(k,) bool: the cutting part can touch the surface with this axis."""
    th = angle_between(normal, axis)
    return th <= cutter._g["th_hi"]


def _away(ax, tip, rho, cc, F, ball):
    """(k, 3) unit directions ⊥ the axis from F toward its foot F′ on the axis (Eq. 13's
    (F′ − F)/|F′ − F|), pivot P = ball centre (ball) or CC point."""
    P = tip + rho * ax if ball else cc
    PF = F - P
    perp = PF - np.einsum("ij,ij->i", PF, ax)[:, None] * ax
    return -perp


def _first_clearing_angle(clear_at, todo, target, max_angle, k):
    """The smallest angle (rad) up to ``max_angle`` at which ``clear_at`` reaches ``target``,
    for the poses ``todo`` of k: a 0.25° scan, then a bisection. Returns (poses (i,), angles
    (i,)) for the poses where some angle clears."""
    grid = np.arange(0.0, max_angle + 1e-12, math.radians(0.25))[1:]
    lo = np.full(k, np.nan)
    hi = np.full(k, np.nan)
    # the scan, all angles of a block of poses in one evaluation: the first angle that clears
    block = max(1, _SCAN_PAIRS // len(grid))
    for s in range(0, len(todo), block):
        ii = todo[s:s + block]
        hit = (clear_at(np.tile(grid, len(ii)), np.repeat(ii, len(grid))) >= target) \
            .reshape(len(ii), len(grid))
        any_hit = hit.any(axis=1)
        first = hit.argmax(axis=1)[any_hit]
        jj = ii[any_hit]
        hi[jj] = grid[first]
        lo[jj] = np.where(first > 0, grid[np.maximum(first - 1, 0)], 0.0)
    found = np.isfinite(hi)
    ii = np.nonzero(found)[0]
    a_lo, a_hi = lo[ii], hi[ii]
    for _ in range(28):  # bisection: 0.25° / 2^28 ≈ 2e-11 rad
        mid = 0.5 * (a_lo + a_hi)
        hit = clear_at(mid, ii) >= target
        a_hi = np.where(hit, mid, a_hi)
        a_lo = np.where(hit, a_lo, mid)
    return ii, a_hi


def _rotation_step(scene, cc, nrm, tip, ax, F, owner, j, ball, max_angle=_MAX_SEARCH,
                   direction=None):
    """One rotation step (Eqs. 12–13, 16–17) for k colliding poses.

    The axis turns in the plane M through the pivot P, F and F′, away from F. For a cylinder
    whose side faces F the smallest angle that puts F at the distance R2 + j·ds from the axis
    is Eq. 12/17's θ = arcsin(L_j / |PF|) − α; the tool here is a union of frustums and the
    convex flute, so the same condition — the signed distance from F to the posed tool
    assembly reaches j·ds — is solved for θ directly: the closed form first, then a 0.25°
    scan of θ up to ``max_angle`` and a bisection (to 1e-9 rad) where it turns true. For the
    cylinder the two agree.

    ``direction`` (k, 3), optional: turn toward it (its part ⊥ the axis) instead of away
    from F — the normal-direction rotation of paper 004's Ref. [18], for comparison.

    Returns (new axes (k, 3), θ (k,) rad, ok (k,) bool — False where no angle up to
    ``max_angle`` clears F)."""
    cutter = scene.cutter
    rho = cutter.radius
    P = tip + rho * ax if ball else cc
    PF = F - P
    proj = np.einsum("ij,ij->i", PF, ax)
    perp = PF - proj[:, None] * ax
    lp = np.linalg.norm(perp, axis=1)
    k = len(P)
    e = -perp / np.maximum(lp, 1e-300)[:, None]
    if direction is not None:
        dn = direction - np.einsum("ij,ij->i", direction, ax)[:, None] * ax
        ldn = np.linalg.norm(dn, axis=1)
        lp = np.where(ldn > 1e-9, lp, 0.0)  # no plane: not ok below
        e = dn / np.maximum(ldn, 1e-300)[:, None]
    target = j * scene.safety + 1e-3  # Eq. 16: L_j = R2 + j ds, as a surface distance
    lam = np.zeros_like(tip)  # the current pose's offset from the exact contact
    if not ball:
        good = _touch_ok(cutter, nrm, ax)
        lam[good] = tip[good] - cutter.cl_points(cc[good], nrm[good], ax[good])
    not_target = owner != 0  # the flute may touch the target blade (it cuts it)

    def axes_at(th, idx=slice(None)):  # Eq. 13 as a rotation by th in the plane M
        return unit(np.cos(th)[:, None] * ax[idx] + np.sin(th)[:, None] * e[idx], keep_zero=False)

    def clear_at(th, idx):
        a = axes_at(th, idx)
        if ball:
            t = P[idx] - rho * a
        else:
            t = tip[idx].copy()
            good = _touch_ok(cutter, nrm[idx], a)
            if np.any(good):
                t[good] = cutter.cl_points(cc[idx][good], nrm[idx][good], a[good]) + \
                    lam[idx][good]
        Fi = F[idx]
        d = np.full(len(idx), np.inf)
        for part, _ in scene.parts():
            sd = _posed_sd(part, Fi, t, a)
            if part.kind == PART_FLUTE:
                sd = np.where(not_target[idx], sd, np.inf)
            d = np.minimum(d, sd)
        return d

    # closed form (Eq. 12 with the part radius at F's height) as a first guess
    zF = np.einsum("ij,ij->i", F - tip, ax)
    R2 = scene.assembly.radius_at(zF)
    dist = np.linalg.norm(PF, axis=1)
    ratio = (R2 + target) / np.maximum(dist, 1e-300)
    alpha = np.arctan2(lp, proj)
    th0 = np.where(ratio < 1, np.arcsin(np.minimum(ratio, 1.0)) - alpha, 0.0)
    th0 = np.clip(th0, 0.0, max_angle)
    ok = lp > 1e-9
    theta = np.full(k, np.nan)
    idx = np.arange(k)
    eq12_ok = ok & (th0 > 0) & (direction is None)
    if np.any(eq12_ok):
        good = eq12_ok & (clear_at(np.where(eq12_ok, th0, 0.0)[idx], idx) >= target)
        theta[good] = th0[good]
        # an Eq. 12 angle that clears may overshoot where the closest point is a cap or a
        # shoulder; the scan below finds the smallest
    ii, a_hi = _first_clearing_angle(clear_at, np.nonzero(ok)[0], target, max_angle, k)
    theta[ii] = np.fmin(theta[ii], a_hi) if len(ii) else theta[ii]
    ok &= np.isfinite(theta)
    theta = np.where(ok, theta, 0.0)
    return axes_at(theta), theta, ok


def _depth_near(cutter, tree, S, tips, axes):
    """(k,) largest depth (mm, ≥ 0) of the target-blade samples inside the posed cutter.

    The cutter lies within ρ ≤ R (its largest radius), 0 ≤ z ≤ h of its axis: balls of
    radius √(R² + Δ²/4) about the axis points z = 0, Δ, 2Δ, … (Δ = R) cover that cylinder
    with far less volume than one ball about the tip (a sample found twice counts once)."""
    out = np.zeros(len(tips))
    if len(tips) == 0:
        return out
    R, h = float(cutter.max_radius), float(cutter.h)
    zs = np.arange(0.0, h + R, R)
    zs = np.minimum(zs, h)
    centres = (tips[:, None, :] + zs[None, :, None] * axes[:, None, :]).reshape(-1, 3)
    pairs = tree.query_ball_point(centres, r=math.hypot(R, 0.5 * R), return_sorted=False)
    cnt = np.fromiter((len(p) for p in pairs), dtype=np.int64, count=len(pairs))
    if cnt.sum() == 0:
        return out
    pi = np.repeat(np.arange(len(tips)), len(zs))
    pi = np.repeat(pi, cnt)
    si = np.concatenate([np.asarray(p, dtype=np.int64) for p in pairs])
    sd = cutter.signed_distance(S[si], tips[pi], axes[pi])
    np.maximum.at(out, pi, -sd)
    return np.maximum(out, 0.0)


def _smooth(planned, cur, fixed, normals, delta, closed):
    """Turn the non-fixed axes toward the fixed (corrected) ones until every consecutive
    turn is within max(delta, planned turn there). Returns (k, 3)."""
    k = len(cur)
    if k < 2:
        return cur
    allowed = np.maximum(delta, consecutive_turn(planned, closed))
    out = [tuple(x) for x in cur.tolist()]
    hint = [tuple(x) for x in normals.tolist()]
    pairs = [(i, i + 1) for i in range(k - 1)]
    if closed and k > 2:
        pairs.append((k - 1, 0))

    def dang(a, b):
        c = a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
        return math.acos(max(-1.0, min(1.0, c)))

    for _ in range(2 if closed else 1):
        for pi, (i, j) in enumerate(pairs):  # forward: j toward i
            if not fixed[j] and dang(out[i], out[j]) > allowed[pi]:
                out[j] = clamp_turn(out[i], out[j], allowed[pi], hint[j])
        for pi in range(len(pairs) - 1, -1, -1):  # backward: i toward j
            i, j = pairs[pi]
            if not fixed[i] and dang(out[i], out[j]) > allowed[pi]:
                out[i] = clamp_turn(out[j], out[i], allowed[pi], hint[i])
    return np.asarray(out)


# ====================================================================== avoidance
@dataclass
class _Poses:
    """The poses of a path stacked (n rows): contact point, unit normal, planned and current
    tip (mm) and axis, the planned tip's offset from the exact contact, and per-pose records
    of the avoidance (normal-direction and first rotation, rad; lift, mm)."""

    cc: np.ndarray
    nrm: np.ndarray
    tip0: np.ndarray
    ax0: np.ndarray
    off0: np.ndarray
    tip: np.ndarray
    ax: np.ndarray
    rot_normal: np.ndarray
    first_theta: np.ndarray
    lift: np.ndarray


def _stacked(curves, attr):
    """(n, 3) float64: one per-pose attribute of all curves, stacked."""
    return np.vstack([np.asarray(getattr(c, attr), dtype=np.float64) for c in curves])


def _contact_offsets(cutter, cc, nrm, tip0, ax0):
    """(n, 3) mm: each planned tip's offset from the exact contact (the path generator's
    few-µm lift λ along the normal, see :mod:`.toolpath`), kept when the axis turns."""
    touch0 = _touch_ok(cutter, nrm, ax0)
    off0 = np.zeros_like(tip0)
    if np.any(touch0):
        off0[touch0] = tip0[touch0] - cutter.cl_points(cc[touch0], nrm[touch0], ax0[touch0])
    return off0


def iter_avoid_collisions(scene: CollisionScene, path: ToolPath, options: CollisionOptions):
    """Generator: yields progress fractions, returns ``(ToolPath, CollisionReport)`` (see the
    module docstring). The input path is not changed."""
    cutter = scene.cutter
    curves = [_copy_curve(c) for c in path.curves]
    sizes = [len(c) for c in curves]
    offs = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
    n = int(offs[-1])
    if n == 0:
        raise CollisionError("the path has no poses to check")
    cc, nrm = _stacked(curves, "cc"), unit(_stacked(curves, "normal"), keep_zero=False)
    tip0, ax_in = _stacked(curves, "tip"), _stacked(curves, "axis")
    ax0 = unit(ax_in, keep_zero=False)
    det0 = yield from _scaled(_detect_chunks(scene, tip0, ax0), 0.0, 0.4)
    off0 = _contact_offsets(cutter, cc, nrm, tip0, ax0)
    P = _Poses(cc, nrm, tip0, ax0, off0, tip0.copy(), ax0.copy(), np.full(n, np.nan),
               np.full(n, np.nan), np.zeros(n))
    det, plan = det0, None
    if options.mode == "avoid" and det0.colliding.any():
        det, plan = yield from _avoid(scene, path, options, curves, offs, P, det0)
    tip, ax = P.tip, P.ax
    # per pose status
    changed = (angle_between(ax, ax0) > 1e-9) | (np.linalg.norm(tip - tip0, axis=1) > 1e-9)
    bad = det.colliding if plan is None else det.colliding | plan.unresolved
    status = np.where(bad, STATUS_UNRESOLVED,
                      np.where(changed, STATUS_CORRECTED, STATUS_CLEAR)).astype(np.int8)
    rotation = angle_between(ax, ax0)
    same = np.all(ax == ax0, axis=1)
    ax[same] = ax_in[same]  # unchanged poses keep their axes bit for bit
    for ci, c in enumerate(curves):
        s, e = offs[ci], offs[ci + 1]
        c.tip, c.axis = tip[s:e].copy(), ax[s:e].copy()
        c.collision = {"status": status[s:e].copy(), "clearance": det.clearance[s:e].copy(),
                       "rotation": rotation[s:e].copy()}
    report = _curve_report(scene, options, offs, P, status, det, rotation)
    _count_turn_over(report, path, curves, options, scene.cutter)
    if options.mode == "avoid":
        report.method = options.method
    if plan is not None:
        report.unresolved_ranges = unresolved_ranges(offs, status, det.clearance, plan)
        report.planner = {"poses_planned": plan.n_window, "candidates": plan.n_candidates,
                          "turn_per_mm_deg": math.degrees(options.turn_per_mm),
                          "max_turn_per_pose_deg": math.degrees(options.plan_max_turn),
                          "axis_reference": options.axis_reference}
        if report.unresolved_ranges:
            report.tool_hint = holder_hint(scene, P, status == STATUS_UNRESOLVED, plan)
    elif options.mode != "off":
        report.unresolved_ranges = unresolved_ranges(offs, status, det.clearance, None)
    program = None
    if path.program is not None:
        program, final, coll_before = yield from _checked_program(
            scene, path, options, curves, offs, P, status, det, det0, report)
    else:
        coll_before = det0.colliding
        report.n_checked = n
        report.min_clearance = float(det.clearance.min()) if n else math.nan
        report.min_clearance_before = float(det0.clearance.min()) if n else math.nan
        final = status
    report.n_colliding_before = int(coll_before.sum())
    report.n_corrected = int(np.sum(final == STATUS_CORRECTED))
    report.n_unresolved = int(np.sum(final == STATUS_UNRESOLVED))
    out = replace(path, curves=curves, program=program, stats=dict(path.stats))
    out.collision = report.summary()
    yield 1.0
    return out, report


def _avoid(scene, path, options, curves, offs, P: _Poses, det0):
    """Generator: the axis planner (method "plan", :mod:`.axis_plan`) or paper 004 §3 on
    the colliding poses — rotate, lift, smooth, check again — changing ``P.tip`` and
    ``P.ax`` in place; returns (the Detection of the final poses, the AxisPlan or None)."""
    lim = _lean_limits(curves, options, P)
    if options.method == "plan":
        return (yield from _avoid_by_plan(scene, path, options, curves, offs, P, det0, lim))
    unresolved = yield from _rotate_colliding(scene, options, P, det0, lim)
    # unresolved poses keep their planned pose
    P.tip[unresolved], P.ax[unresolved] = P.tip0[unresolved], P.ax0[unresolved]
    fixed = det0.colliding & ~unresolved
    _lift_by_depth(scene, path, options, P, fixed)
    _smooth_corrected(scene, options, curves, offs, P, fixed, unresolved, lim)
    yield 0.8
    det = yield from _scaled(_detect_chunks(scene, P.tip, P.ax), 0.8, 0.95)
    # a changed pose that collides after all (a lift, a neighbour's smoothing) goes back
    # to its planned pose: unresolved poses are never moved
    bad = det.colliding & ((angle_between(P.ax, P.ax0) > 0) | np.any(P.tip != P.tip0, axis=1))
    if np.any(bad):
        b = np.nonzero(bad)[0]
        P.tip[b], P.ax[b] = P.tip0[b], P.ax0[b]
        for key in ("clearance", "obstacle", "part", "point", "normal"):
            getattr(det, key)[b] = getattr(det0, key)[b]
    return det, None


def _avoid_by_plan(scene, path, options, curves, offs, P: _Poses, det0, lim):
    """Generator: the axes of every pass chosen together (:func:`.axis_plan.plan_axes`);
    unresolved poses keep the planner's axis (the least colliding one the turn limit
    allows), so the turn limit holds everywhere. Returns (Detection, AxisPlan)."""
    box = {}

    def prog(x):
        box["x"] = x

    plan = plan_axes(scene, curves, offs, P, lim, det0.colliding,
                     turn_per_mm=float(options.turn_per_mm), max_turn=options.plan_max_turn,
                     machine=options.machine, reference=options.axis_reference,
                     blisk_axis=path.axis, blade_count=options.blade_count,
                     edge_lead=options.plan_edge_lead, jumps=bool(options.turn_jumps),
                     progress=prog, direction=options.reference_direction)
    yield 0.8
    P.tip[:], P.ax[:] = plan.tip, plan.axis
    det = yield from _scaled(_detect_chunks(scene, P.tip, P.ax), 0.8, 0.95)
    return det, plan


def _lean_limits(curves, options, P: _Poses):
    """(f, k_side (n, 3) local frame vectors, lim_lead, lim_tilt (n,) rad): how far
    avoidance may lean each axis from the normal."""
    frames = [local_frames(c.cc, c.normal, c.closed) for c in curves]
    f = np.vstack([fr[0] for fr in frames])
    k_side = np.vstack([fr[2] for fr in frames])
    # the limits bound how far avoidance may lean an axis from the normal; where the plan
    # itself leans further (a radial or fixed-point strategy), the turn may not lean it
    # further than planned
    lead0, tilt0 = lead_tilt_of(P.ax0, f, P.nrm, k_side)
    lim_lead = np.maximum(options.max_lead, np.nan_to_num(np.abs(lead0)))
    lim_tilt = np.maximum(options.max_tilt, np.nan_to_num(np.abs(tilt0)))
    return f, k_side, lim_lead, lim_tilt


def _rotate_colliding(scene, options, P: _Poses, det0, lim):
    """Generator: rotation steps j = 1, 2, … (Eqs. 12–13, 16–17) of the colliding poses
    until they clear or ``options.max_iterations``; changes ``P.tip``/``P.ax``, records
    ``P.rot_normal`` and ``P.first_theta``; returns the (n,) bool mask of unresolved poses."""
    cutter = scene.cutter
    ball = cutter.type == "ball"
    unresolved = np.zeros(len(P.tip), bool)
    pt, nF = det0.point.copy(), det0.normal.copy()
    owner = det0.obstacle.copy()
    active = np.nonzero(det0.colliding)[0]
    a = active
    _, th_n, ok_n = _rotation_step(scene, P.cc[a], P.nrm[a], P.tip[a], P.ax[a], pt[a],
                                   owner[a], 1, ball, direction=nF[a])
    P.rot_normal[a] = np.where(ok_n, th_n, np.nan)
    for j in range(1, options.max_iterations + 1):
        if len(active) == 0:
            break
        a = active
        best_th, new = _smallest_turn(scene, P, a, pt, nF, owner, j, lim)
        ok = np.isfinite(best_th)
        unresolved[a[~ok]] = True
        a, new = a[ok], new[ok]
        if len(a) == 0:
            active = a
            break
        nt = cutter.cl_points(P.cc[a], P.nrm[a], new) + P.off0[a]
        d = scene.detect(nt, new)
        P.tip[a], P.ax[a] = nt, new
        pt[a], owner[a] = d.point, d.obstacle
        active = a[d.colliding]
        yield 0.4 + 0.3 * j / options.max_iterations
    unresolved[active] = True
    return unresolved


def _smallest_turn(scene, P: _Poses, a, pt, nF, owner, j, lim):
    """Step j for the poses ``a``: the smallest turn within the limits among four planes.

    Plane M away from F (Eqs. 12–13); where F lies beyond the axis (a deep penetration) or
    that turn leaves the limits, the other sense and the obstacle normal's (± ``nF``) are
    tried too. Records ``P.first_theta`` at j = 1. Returns (θ (k,) rad, inf where no turn
    is feasible; new axes (k, 3))."""
    cutter = scene.cutter
    ball = cutter.type == "ball"
    f, k_side, lim_lead, lim_tilt = lim
    best_th = np.full(len(a), np.inf)
    new = P.ax[a].copy()
    for variant in range(4):
        if variant == 0:
            direction = None  # Eq. 13's (F' - F)/|F' - F|, with Eq. 12's first guess
        elif variant == 1:
            e_away = _away(P.ax[a], P.tip[a], cutter.radius, P.cc[a], pt[a], ball)
            direction = -e_away
        else:
            direction = nF[a] if variant == 2 else -nF[a]
        cand, th, ok_v = _rotation_step(scene, P.cc[a], P.nrm[a], P.tip[a], P.ax[a], pt[a],
                                        owner[a], j, ball, direction=direction)
        if j == 1 and variant == 0:
            P.first_theta[a] = np.where(ok_v, th, np.nan)
        lead, tilt = lead_tilt_of(cand, f[a], P.nrm[a], k_side[a])
        ok_v &= np.isfinite(lead) & (np.abs(lead) <= lim_lead[a] + 1e-12)
        ok_v &= np.isfinite(tilt) & (np.abs(tilt) <= lim_tilt[a] + 1e-12)
        ok_v &= _touch_ok(cutter, P.nrm[a], cand)
        take = ok_v & (th < best_th)
        best_th = np.where(take, th, best_th)
        new[take] = cand[take]
    return best_th, new


def _lift_by_depth(scene, path, options, P: _Poses, fixed):
    """Eqs. 14–15: lift each corrected tip along the normal by the removal depth its new
    axis adds on the target blade beyond ε (``gouge_tol``, default chord / 4); records
    ``P.lift``."""
    blade = scene.obstacles.meshes[0]
    S = np.vstack([blade.V, blade.V[blade.F].mean(axis=1)])
    tree = cKDTree(S)
    fc = scene.flute.cutter
    eps = (path.chord / 4.0) if options.gouge_tol is None else float(options.gouge_tol)
    fi = np.nonzero(fixed)[0]
    if len(fi):
        d_new = _depth_near(fc, tree, S, P.tip[fi], P.ax[fi])
        d_old = _depth_near(fc, tree, S, P.tip0[fi], P.ax0[fi])
        h = d_new - d_old
        up = h > eps
        if np.any(up):
            g = fi[up]
            P.lift[g] = h[up]
            P.tip[g] = P.tip[g] + h[up][:, None] * P.nrm[g]  # Eq. 15


def _smooth_corrected(scene, options, curves, offs, P: _Poses, fixed, unresolved, lim):
    """Smooth the axes around the corrected poses, pass by pass, in place.

    First the neighbours of the corrected poses turn toward them (the corrected ones stay),
    then two rounds in which the corrected poses may move too (toward each other where their
    turns differ); a moved pose that would collide, or leave the limits, keeps its axis of
    the round before. Unresolved poses stay as planned."""
    cutter = scene.cutter
    cc, nrm, ax0, tip, ax = P.cc, P.nrm, P.ax0, P.tip, P.ax
    f, k_side, lim_lead, lim_tilt = lim
    delta = math.radians(2.0) if options.max_turn is None else float(options.max_turn)
    for rnd in range(3):
        hold = fixed | unresolved if rnd == 0 else unresolved
        before, tip_before = ax.copy(), tip.copy()
        for ci, c in enumerate(curves):
            s, e = offs[ci], offs[ci + 1]
            if not fixed[s:e].any():
                continue
            ax[s:e] = _smooth(ax0[s:e], ax[s:e], hold[s:e], nrm[s:e], delta, c.closed)
        moved = (angle_between(ax, before) > 1e-12) & ~hold & _touch_ok(cutter, nrm, ax)
        lead, tilt = lead_tilt_of(ax, f, nrm, k_side)
        lead_b, tilt_b = lead_tilt_of(before, f, nrm, k_side)
        moved &= (np.abs(lead) <= lim_lead + 1e-12) | (np.abs(lead) <= np.abs(lead_b))
        moved &= (np.abs(tilt) <= lim_tilt + 1e-12) | (np.abs(tilt) <= np.abs(tilt_b))
        ax[~moved] = before[~moved]
        mi = np.nonzero(moved)[0]
        if len(mi) == 0:
            break
        tip[mi] = (cutter.cl_points(cc[mi], nrm[mi], ax[mi]) + P.off0[mi]
                   + P.lift[mi][:, None] * nrm[mi])
        d = scene.detect(tip[mi], ax[mi])
        back = mi[d.colliding]
        tip[back], ax[back] = tip_before[back], before[back]


def _curve_report(scene, options, offs, P: _Poses, status, det, rotation):
    """The CollisionReport with its per-curve rows (status, clearance, rotations, lift)."""
    def per_curve(x):
        return [x[offs[i]:offs[i + 1]] for i in range(len(offs) - 1)]

    return CollisionReport(
        mode=options.mode, safety=scene.safety,
        obstacles=scene.obstacles.summary(), assembly=scene.assembly.as_dict(),
        assembly_text=scene.assembly.describe(),
        curve_status=per_curve(status), curve_clearance=per_curve(det.clearance),
        curve_rotation=per_curve(rotation), curve_rotation_normal=per_curve(P.rot_normal),
        curve_rotation_first=per_curve(P.first_theta), curve_lift=per_curve(P.lift),
    )


def _count_turn_over(report, path, curves, options, cutter: Cutter):
    """Count in ``report`` the consecutive turns over the limit: the planner's
    (:func:`.axis_field.turn_limits`, per mm of the tool path of ``cutter``) for method
    "plan", else max(planned turn, ``max_turn``) (the rotation's own smoothing limit)."""
    delta = math.radians(2.0) if options.max_turn is None else float(options.max_turn)
    for c0, c1 in zip(path.curves, curves, strict=True):
        if len(c1) < 2:
            continue
        t0 = consecutive_turn(c0.axis, c0.closed)
        t1 = consecutive_turn(c1.axis, c1.closed)
        limit = np.maximum(t0, delta)
        if options.mode == "avoid" and options.method == "plan":  # the planner's limit
            limit = pass_turn_limits(c0.cc, c0.normal, c0.axis, c1.closed,
                                     cutter.corner_radius, float(options.turn_per_mm),
                                     options.plan_max_turn)
        over = t1 > limit + 1e-9
        if options.mode == "avoid" and options.method == "plan":
            # the planner jumps only between two unresolved poses (not cut): counted apart
            st = np.asarray(c1.collision["status"]) == STATUS_UNRESOLVED
            st = np.r_[st, st[:1]] if c1.closed and len(c1) > 2 else st
            inside = over & st[:-1] & st[1:]
            report.n_turn_unresolved += int(inside.sum())
            over &= ~inside
        report.n_turn_over += int(over.sum())
        if over.any():
            report.max_turn_deg = max(report.max_turn_deg, float(np.degrees(t1[over].max())))


def _checked_program(scene, path, options, curves, offs, P: _Poses, status, det, det0,
                     report):
    """Generator: the program with the corrected poses, its colliding links re-routed
    through the clearance surface, its rows' status and clearance in ``report``; returns
    (Program, final status (m,), colliding before (m,) bool)."""
    program, pstat, pclr, pclr0 = yield from _program(scene, path.program, curves, offs,
                                                      P.tip0, P.ax0, status, det, det0)
    # colliding links, retracts and rapids: re-routed through the clearance surface
    program, report.links = yield from _scaled(reroute_links(
        scene, program, path.program, path.axis, report.curve_rotation,
        reroute=options.mode == "avoid", max_turn=options.max_turn), 0.99, 1.0)
    pstat, pclr = program.collision_status, program.clearance
    report.program_status, report.program_clearance = pstat, pclr
    report.n_checked = len(pstat)
    report.min_clearance = float(pclr.min()) if len(pclr) else math.nan
    report.min_clearance_before = float(pclr0.min()) if len(pclr0) else math.nan
    return program, pstat, pclr0 < scene.safety


def _scaled(gen, a, b):
    """Re-yield a sub-generator's fractions mapped into [a, b]; return its value."""
    while True:
        try:
            x = next(gen)
        except StopIteration as stop:
            return stop.value
        yield a + (b - a) * x


def _program(scene, prog: Program, curves, offs, tip0, ax0, status, det, det0):
    """The program with the corrected pass poses (and the approach/retract points of changed
    pass ends), its status and clearance per row. Generator (progress), returns
    (Program, status (m,), clearance (m,), clearance before (m,))."""
    m = len(prog)
    tip, ax = prog.tip.copy(), prog.axis.copy()
    cur = np.asarray(prog.curve)
    idx = np.asarray(prog.index)
    on = cur >= 0
    g = offs[cur[on]] + idx[on]
    new_tip = np.vstack([c.tip for c in curves]) if len(curves) else np.zeros((0, 3))
    new_ax = np.vstack([c.axis for c in curves]) if len(curves) else np.zeros((0, 3))
    tip[on], ax[on] = new_tip[g], new_ax[g]
    glob = np.full(m, -1, dtype=np.int64)
    glob[on] = g
    # approach / retract points above a changed pass end follow it
    for r in np.nonzero(~on)[0]:
        for nb, kind in ((r + 1, MOVE_APPROACH), (r - 1, MOVE_RETRACT)):
            if not (0 <= nb < m) or glob[nb] < 0:
                continue
            if kind == MOVE_APPROACH and prog.move[nb] != MOVE_APPROACH:
                continue
            if kind == MOVE_RETRACT and prog.move[r] != MOVE_RETRACT:
                continue
            q = glob[nb]
            if status[q] != STATUS_CORRECTED:
                continue
            rel = prog.tip[r] - tip0[q]
            dd = float(rel @ ax0[q])
            if np.linalg.norm(rel - dd * ax0[q]) <= 1e-6 and dd > 0:
                tip[r] = new_tip[q] + dd * new_ax[q]
                ax[r] = new_ax[q]
    off = np.nonzero(~on)[0]
    d_off = yield from _scaled(_detect_chunks(scene, tip[off], ax[off]), 0.95, 0.98)
    d_off0 = yield from _scaled(_detect_chunks(scene, prog.tip[off], prog.axis[off]), 0.98,
                                0.99)
    clr = np.empty(m)
    clr0 = np.empty(m)
    clr[on] = det.clearance[g]
    clr0[on] = det0.clearance[g]
    clr[off] = d_off.clearance
    clr0[off] = d_off0.clearance
    st = np.zeros(m, dtype=np.int8)
    st[on] = status[g]
    changed = (np.linalg.norm(tip[off] - prog.tip[off], axis=1) > 1e-9)
    st[off] = np.where(d_off.colliding, STATUS_UNRESOLVED,
                       np.where(changed, STATUS_CORRECTED, STATUS_CLEAR))
    out = replace(prog, tip=tip, axis=ax, collision_status=st, clearance=clr)
    return out, st, clr, clr0


def avoid_collisions(scene: CollisionScene, path: ToolPath, options: CollisionOptions):
    """Run :func:`iter_avoid_collisions` to the end: ``(ToolPath, CollisionReport)``."""
    return run_to_end(iter_avoid_collisions(scene, path, options))


# ====================================================================== entry point
def _blade_arrays(mesh_or_blade):
    if hasattr(mesh_or_blade, "V") and hasattr(mesh_or_blade, "F"):
        return np.asarray(mesh_or_blade.V), np.asarray(mesh_or_blade.F)
    try:
        V, F = mesh_or_blade
    except (TypeError, ValueError):
        raise CollisionError("the blade must be a TriMesh or a (vertices, faces) pair") from None
    return V, F


def iter_run_collisions(mesh_or_blade, path: ToolPath, obstacles_extra=(),
                        options: CollisionOptions | None = None):
    """Generator behind :func:`run_collisions`: yields fractions in [0, 1] (a modal operator
    can cancel between them), returns ``(ToolPath, CollisionReport)``."""
    options = options or CollisionOptions()
    if options.mode == "off":
        yield 1.0
        return path, CollisionReport(mode="off", safety=float(options.safety))
    V, F = _blade_arrays(mesh_or_blade)
    extra = [e if isinstance(e, Obstacle) else tuple(e) for e in (obstacles_extra or ())]
    obstacles = Obstacles.build(V, F, path.axis, options.blade_count, options.neighbours, extra)
    scene = CollisionScene(obstacles, path.tool, options.assembly(path.tool))
    yield 0.0
    return (yield from iter_avoid_collisions(scene, path, options))


def run_collisions(mesh_or_blade, path: ToolPath, obstacles_extra=(),
                   options: CollisionOptions | None = None, progress=None):
    """Check (and in mode "avoid" correct) a tool path against the blisk.

    Parameters
    ----------
    mesh_or_blade : TriMesh or (V (n, 3), F (m, 3)) — the target blade (the path's mesh)
    path : ToolPath — with curves and, usually, the linked program
    obstacles_extra : iterable of (name, V, F) or Obstacle — hub, whole blisk, fixture...
    options : CollisionOptions
    progress : callable(fraction) or None

    Returns
    -------
    (ToolPath, CollisionReport) — a new path (the input is not changed); with mode "off" the
    input path itself and an empty report.

    Raises
    ------
    CollisionError (a BliskCamError) naming the problem: blade count, neighbours, holder
    profile, safety, an obstacle containing the blade...
    """
    return run_to_end(iter_run_collisions(mesh_or_blade, path, obstacles_extra, options),
                      None if progress is None else (lambda x: progress(float(x))))
