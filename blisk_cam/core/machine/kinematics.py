"""Inverse kinematics and linearization: tool tip + axis (paths' frame) → X, Y, Z, θ1, θ2.

Orientation. Every kind reduces to Paden–Kahan sub-problem 2: find (α, β) with
``exp(ωa α) exp(ωb β) p = q`` for unit vectors (see :func:`_two_rotations`):

=============  ======================  =====  ========  ===========
kind           equation                ωa/α   ωb/β      p → q
=============  ======================  =====  ========  ===========
table-table    R1(θ1) R2(θ2) a0 = s     ω1/θ1  ω2/θ2     a0 → s
head-table     R1(−θ1) R2(θ2) a0 = s    −ω1/θ1 ω2/θ2     a0 → s
head-head      R2(−θ2) R1(−θ1) a0 = s   −ω2/θ2 −ω1/θ1    a0 → s
=============  ======================  =====  ========  ===========

(a0 = the path's axis in machine coordinates at zero, s = ``spindle``.) The two roots ±γ are
the two solution branches; on the A/C trunnion of paper 002 (Eq. 6, J_RR) they are
(A, C) and (−A, C + 180°). Where a0 lies along ωb (A ≈ 0 on an A/C trunnion, the singular
orientation: J_RR of paper 002 Eq. (6) loses rank at sin A = 0) β is free: the previous value is
kept and the pose reported. The position follows from the forward model
(:func:`.machine.tip_to_machine`).

Branch choice: of the branches within the rotary limits (a continuous axis is unwound to the
turn nearest the previous value; a limited one may use any turn inside its limits), the one
with the least rotary motion from the previous pose (from 0, 0 for the first pose). A pose out
of the limits on both branches raises :class:`.errors.ReachError` naming the pose, the axis and
the value — never clamped.

Linearization (paper 002 §2.2, Eqs. 1–3: the machine interpolates every axis linearly between
blocks, so the tip leaves the planned straight CL segment where rotaries turn): between
consecutive poses (rapids too), joint-space motion is sampled densely; where the sampled tip strays
more than the chord tolerance from the planned segment, or a rotary turns more than the step
limit, a pose is inserted at the middle (tip linear, axis slerp) and solved again, until every
piece passes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ReachError
from ..geometry.closest import segment_distance
from ..geometry.vectors import slerp, unit
from ..toolpath.types import MOVE_NAMES, MOVE_RAPID
from .description import Machine, forward, machine_axis, tip_to_machine

__all__ = ["IKResult", "LinearizeReport", "linearize", "reachable_axes", "solve_poses"]

TWO_PI = 2.0 * math.pi
#: |component of the axis across ωb| below which a pose is singular (β free)
SINGULAR_TOL = 1e-7


@dataclass
class IKResult:
    """Joint solution of poses.

    xyz : (n, 3) mm — programmed X, Y, Z (machine tip position)
    angles : (n, 2) radians — rotary 1, rotary 2 (continuous axes unwound)
    singular : (n,) bool — singular orientation (rotary kept from the previous pose)
    """

    xyz: np.ndarray
    angles: np.ndarray
    singular: np.ndarray


def _sub1(w, u, v):
    """(n,) angle turning u (n, 3) into v (n, 3) about unit w (3,) (their parts across w)."""
    up = u - np.outer(u @ w, w)
    vp = v - np.outer(v @ w, w)
    ang = np.arctan2(np.cross(up, vp) @ w, np.einsum("ij,ij->i", up, vp))
    return ang, np.linalg.norm(up, axis=1)


def _two_rotations(wa, wb, p, q):
    """Both solutions of ``exp(wa α) exp(wb β) p = q`` (unit vectors, n rows).

    Returns alpha (n, 2), beta (n, 2) radians (branch +γ, −γ), reach (n,) bool (the
    orientation can be produced), singular (n,) bool (p along wb: β free).
    """
    k = float(wa @ wb)
    c = np.cross(wa, wb)
    den = k * k - 1.0
    bp = p @ wb
    aq = q @ wa
    alpha_c = (k * bp - aq) / den
    beta_c = (k * aq - bp) / den
    g2 = (1.0 - alpha_c**2 - beta_c**2 - 2 * alpha_c * beta_c * k) / float(c @ c)
    reach = g2 > -1e-9
    g = np.sqrt(np.clip(g2, 0.0, None))
    A = np.empty((len(p), 2))
    B = np.empty((len(p), 2))
    sing = np.zeros(len(p), bool)
    for j, sgn in enumerate((1.0, -1.0)):
        cv = alpha_c[:, None] * wa + beta_c[:, None] * wb + (sgn * g)[:, None] * c
        B[:, j], nb = _sub1(wb, p, cv)
        A[:, j], _ = _sub1(wa, cv, q)
        sing |= nb < SINGULAR_TOL
    return A, B, reach, sing


def _frame(machine: Machine):
    """(wa, wb, order): order maps (α, β) → (θ1, θ2) and the sign of each."""
    w1, w2 = machine.rotaries[0].axis, machine.rotaries[1].axis
    if machine.kinematics == "table-table":
        return w1, w2, False
    if machine.kinematics == "head-table":
        return -w1, w2, False
    return -w2, -w1, True


def _candidates(machine: Machine, axis):
    """Both branches: theta (n, 2 branches, 2 joints), reach (n,), singular (n,)."""
    a0 = unit(axis, keep_zero=False) @ machine.part_rotation.T
    s = np.broadcast_to(machine.spindle, a0.shape)
    wa, wb, swap = _frame(machine)
    A, B, reach, sing = _two_rotations(wa, wb, a0, s)
    th = np.stack([B, A], axis=2) if swap else np.stack([A, B], axis=2)
    return th, reach, sing


def reachable_axes(machine: Machine, axis) -> np.ndarray:
    """(n,) bool: the rotaries can produce each unit tool axis (n, 3) (paths' frame) on at
    least one solution branch with both joints inside their limits (a limited joint at
    θ + 2πk for some k; a singular pose's free joint can take 0, which the limits hold
    when 0 lies in them). Used by collision avoidance to stay inside the machine's reach."""
    axis = np.atleast_2d(np.asarray(axis, dtype=np.float64))
    th, reach, sing = _candidates(machine, axis)
    ok = np.zeros(len(axis), bool)
    free = 0 if machine.kinematics == "head-head" else 1
    for b in range(2):
        good = reach.copy()
        for j in range(2):
            lim = machine.rotaries[j].limits
            if lim is None:
                continue
            lo, hi = lim
            t = th[:, b, j]
            k = np.ceil((lo - t) / TWO_PI - 1e-12)
            inside = t + TWO_PI * k <= hi + 1e-12
            if j == free:
                inside = np.where(sing, lo - 1e-12 <= 0.0 <= hi + 1e-12, inside)
            good &= inside
        ok |= good
    return ok


def _turns(theta, prev, lim):
    """Value of an axis ≡ theta (mod 2π) nearest prev: inside lim (None if none is)."""
    if lim is None:
        return theta + TWO_PI * round((prev - theta) / TWO_PI)
    lo, hi = lim
    best = None
    kmin = math.ceil((lo - theta) / TWO_PI - 1e-12)
    kmax = math.floor((hi - theta) / TWO_PI + 1e-12)
    for kk in range(kmin, kmax + 1):
        v = theta + TWO_PI * kk
        if best is None or abs(v - prev) < abs(best - prev):
            best = v
    return best


def _pick(th, sing, prev, limits, free):
    """Choose one pose's joints. th (2, 2) branch × joint, prev (2,), limits per joint,
    free = index of the joint kept when singular. Returns ((θ1, θ2), None) or (None,
    (joint, value)) of the smallest violation."""
    best, cost, bad = None, math.inf, None
    for b in range(2):
        vals = []
        for j in range(2):
            t = float(th[b, j])
            if sing and j == free:
                t = float(prev[j])
                lim = limits[j]
                if lim is not None and not (lim[0] - 1e-12 <= t <= lim[1] + 1e-12):
                    vals = None
                    bad = bad or (j, t)
                    break
                vals.append(t)
                continue
            v = _turns(t, float(prev[j]), limits[j])
            if v is None:
                vals = None
                w = math.remainder(t, TWO_PI)
                if bad is None:
                    bad = (j, w)
                break
            vals.append(v)
        if vals is None:
            continue
        c = abs(vals[0] - prev[0]) + abs(vals[1] - prev[1])
        if c < cost - 1e-12:
            best, cost = vals, c
    return (best, None) if best is not None else (None, bad)


def _pose_name(i, labels, moves):
    lab = int(labels[i]) if labels is not None else i
    kind = f" ({MOVE_NAMES[int(moves[i])]})" if moves is not None else ""
    return f"pose {lab}{kind}"


_HINT = (
    "; blisk blades are usually cut with the tool axis near radial (--axis-mode radial with a "
    "radial tilt), or choose a machine whose rotaries reach this orientation"
)


def solve_poses(
    machine: Machine,
    tip,
    axis,
    *,
    prev=None,
    sequential: bool = True,
    labels=None,
    moves=None,
    tool_length: float = 0.0,
) -> IKResult:
    """Inverse kinematics of poses (tip (n, 3) mm and unit axis (n, 3) in the paths' frame).

    ``sequential``: pose i's branch and turn follow pose i−1 (``prev`` (2,) radians seeds
    pose 0, default 0, 0). Otherwise ``prev`` is (n, 2): each pose follows its own row (used
    for inserted poses). ``labels`` (n,) numbers the poses in error messages, ``moves`` names
    their move types. Raises ReachError (pose, axis, value) for an unreachable pose.
    """
    tip = np.atleast_2d(np.asarray(tip, dtype=np.float64))
    n = len(tip)
    th, reach, sing = _candidates(machine, axis)
    if not np.all(reach):
        i = int(np.argmin(reach))
        raise ReachError(
            f"{_pose_name(i, labels, moves)}: the tool axis {np.round(axis[i], 4).tolist()} "
            f"cannot be produced by the rotaries {'/'.join(machine.axis_names)} of "
            f"{machine.name!r}" + _HINT
        )
    limits = [r.limits for r in machine.rotaries]
    free = 0 if machine.kinematics == "head-head" else 1
    out = np.empty((n, 2))
    if sequential:
        p = np.zeros(2) if prev is None else np.asarray(prev, dtype=np.float64)
        prevs = None
    else:
        prevs = np.asarray(prev, dtype=np.float64).reshape(n, 2)
    for i in range(n):
        pv = p if prevs is None else prevs[i]
        val, bad = _pick(th[i], bool(sing[i]), pv, limits, free)
        if val is None:
            j, v = bad
            lo, hi = (math.degrees(x) for x in limits[j])
            raise ReachError(
                f"{_pose_name(i, labels, moves)}: axis {machine.rotaries[j].name} = "
                f"{math.degrees(v):.4f}° is outside its limits [{lo:g}, {hi:g}]° on both "
                f"solution branches" + _HINT
            )
        out[i] = val
        if prevs is None:
            p = out[i]
    xyz = tip_to_machine(machine, tip, out)
    _check_linear(machine, xyz, out, labels, moves, tool_length)
    return IKResult(xyz=xyz, angles=out, singular=sing.copy())


def _check_linear(machine, xyz, angles, labels, moves, tool_length):
    pos = xyz
    if machine.kinematics != "table-table":
        pos = xyz + (machine.pivot_length + tool_length) * machine_axis(machine, angles)
    for j, name in enumerate("XYZ"):
        lim = machine.linear.get(name)
        if lim is None:
            continue
        badm = (pos[:, j] < lim[0] - 1e-9) | (pos[:, j] > lim[1] + 1e-9)
        if badm.any():
            i = int(np.argmax(badm))
            what = "" if machine.kinematics == "table-table" else " (head pivot)"
            raise ReachError(
                f"{_pose_name(i, labels, moves)}: axis {name}{what} = {pos[i, j]:.4f} mm is "
                f"outside its travel [{lim[0]:g}, {lim[1]:g}] mm; move the part origin "
                "([part] origin) or choose a larger machine"
            )


@dataclass
class LinearizeReport:
    inserted: int
    max_deviation: float  # mm, sampled, after insertion
    unresolved: int  # segments still out of tolerance after the round limit


def joint_deviation(machine, xyz0, q0, xyz1, q1, tip0, tip1, samples: int = 16):
    """(n,) largest distance (mm) of the tip, under joint-linear motion between two blocks,
    from the planned straight tip segment tip0 → tip1 (n, 3), sampled at ``samples`` points."""
    t = np.linspace(0, 1, samples + 2)[1:-1]
    n = len(xyz0)
    X = xyz0[:, None] + t[None, :, None] * (xyz1 - xyz0)[:, None]
    Q = q0[:, None] + t[None, :, None] * (q1 - q0)[:, None]
    tp, _ = forward(machine, X.reshape(-1, 3), Q.reshape(-1, 2))
    if not n:
        return np.zeros(0)
    return segment_distance(tp.reshape(n, samples, 3), tip0[:, None], tip1[:, None]).max(axis=1)


def linearize(
    machine: Machine,
    tip,
    axis,
    move,
    ik: IKResult,
    *,
    chord: float,
    max_step: float = math.radians(5.0),
    samples: int = 16,
    max_rounds: int = 30,
    tool_length: float = 0.0,
    rapids: bool = True,
    keep=None,
):
    """Insert poses between feed poses until joint-linear motion follows the planned segments.

    tip, axis (n, 3); move (n,) codes; ik the solution of every pose. ``chord`` mm,
    ``max_step`` radians (largest rotary turn between consecutive blocks). ``rapids``: also
    rapid segments (a joint-linear G0 swings the tip through the air as much as a G1 does).
    ``keep`` (n,) bool or None: poses whose incoming segment is left as it is (blocks chosen
    by :func:`.interpolation.interpolate_program`, which already bounds their error).

    Returns (tip, axis, move, xyz, angles, singular, source, LinearizeReport) with the
    inserted poses in order; ``source`` (m,) is the index of the original pose, −1 inserted.
    """
    tip = np.asarray(tip, dtype=np.float64)
    axis = unit(axis, keep_zero=False)
    move = np.asarray(move)
    n = len(tip)
    # segment (i-1 → i) per pose i
    seg = np.arange(1, n) if rapids else np.nonzero(move[1:] != MOVE_RAPID)[0] + 1
    if keep is not None:
        seg = seg[~np.asarray(keep, bool)[seg]]
    # working segments: original index, and both ends' state
    o = seg
    a_tip, b_tip = tip[o - 1], tip[o]
    a_ax, b_ax = axis[o - 1], axis[o]
    a_x, b_x = ik.xyz[o - 1], ik.xyz[o]
    a_q, b_q = ik.angles[o - 1], ik.angles[o]
    a_t, b_t = np.zeros(len(o)), np.ones(len(o))
    done_o, done_t, done = [], [], []  # inserted poses: (orig, t, tip, axis, xyz, q, sing)
    unresolved = 0
    maxdev = 0.0
    for rnd in range(max_rounds + 1):
        if len(o) == 0:
            break
        dev = joint_deviation(machine, a_x, a_q, b_x, b_q, a_tip, b_tip, samples)
        step = np.abs(b_q - a_q).max(axis=1)
        bad = (dev > chord) | (step > max_step + 1e-12)
        if rnd == max_rounds:
            unresolved = int(bad.sum())
            bad[:] = False
        ok = ~bad
        if ok.any():
            maxdev = max(maxdev, float(dev[ok].max()))
        if not bad.any():
            break
        o, a_tip, b_tip, a_ax, b_ax = o[bad], a_tip[bad], b_tip[bad], a_ax[bad], b_ax[bad]
        a_x, b_x, a_q, b_q, a_t, b_t = a_x[bad], b_x[bad], a_q[bad], b_q[bad], a_t[bad], b_t[bad]
        m_tip = 0.5 * (a_tip + b_tip)
        # unit axes renormalised once more, as the machine's slerp always did (its bits)
        m_ax = slerp(unit(a_ax, keep_zero=False), unit(b_ax, keep_zero=False),
                     np.full(len(o), 0.5))
        m_t = 0.5 * (a_t + b_t)
        res = solve_poses(
            machine, m_tip, m_ax, prev=a_q, sequential=False, labels=o, moves=move[o],
            tool_length=tool_length,
        )
        done_o.append(o)
        done_t.append(m_t)
        done.append((m_tip, m_ax, res.xyz, res.angles, res.singular))
        # split: [a, m] and [m, b]
        o = np.concatenate([o, o])
        a_tip, b_tip = np.vstack([a_tip, m_tip]), np.vstack([m_tip, b_tip])
        a_ax, b_ax = np.vstack([a_ax, m_ax]), np.vstack([m_ax, b_ax])
        a_x, b_x = np.vstack([a_x, res.xyz]), np.vstack([res.xyz, b_x])
        a_q, b_q = np.vstack([a_q, res.angles]), np.vstack([res.angles, b_q])
        a_t, b_t = np.concatenate([a_t, m_t]), np.concatenate([m_t, b_t])
    src = np.arange(n)
    if not done:
        rep = LinearizeReport(0, maxdev, unresolved)
        return tip, axis, move, ik.xyz, ik.angles, ik.singular, src, rep
    io = np.concatenate([np.arange(n)] + done_o)
    it = np.concatenate([np.ones(n)] + done_t)  # an original pose i is t = 1 of segment i
    order = np.lexsort((it, io))
    cat = lambda k, orig: np.concatenate([orig] + [d[k] for d in done])[order]  # noqa: E731
    out_tip = cat(0, tip)
    out_ax = cat(1, axis)
    out_x = cat(2, ik.xyz)
    out_q = cat(3, ik.angles)
    out_s = cat(4, ik.singular)
    out_m = np.concatenate([move] + [move[d] for d in done_o])[order]
    out_src = np.concatenate([src] + [np.full(len(d), -1) for d in done_o])[order]
    rep = LinearizeReport(int(sum(len(d) for d in done_o)), maxdev, unresolved)
    return out_tip, out_ax, out_m, out_x, out_q, out_s, out_src, rep
