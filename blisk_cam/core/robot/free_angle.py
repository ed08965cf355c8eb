"""The free angle about the tool axis, resolved over a whole path by dynamic programming.

A 5-axis pose (tool tip and axis, the paths JSON) fixes five of the robot's six degrees of
freedom; the sixth is the angle ψ of the tool frame about its own z axis. Paper 004 (§2,
the robot polishing cell) holds the head at an angle to the flange so that this angle moves the
wrist: with the tool on the flange axis ψ only turns joint 6 and cannot steer the arm away from
a wrist singularity.

For every stroke (a PTP to its first pose, then linear moves; a stroke begins at each rapid
pose of the linked program) the angle is sampled (``samples`` values over a turn) at every
pose, each sample solved in closed form for the eight configurations (:mod:`.kinematics`), and
a shortest path is found through the layered graph (pose × angle) separately for each
configuration, keeping **one configuration per stroke**:

* a node is feasible when the arm reaches the pose, every joint fits inside its limits less
  ``limit_margin`` on some turn, and the wrist, elbow and shoulder are farther than
  ``min_wrist``, ``min_elbow``, ``min_shoulder`` from their singularities;
* an edge is feasible when no joint steps more than ``max_joint_step`` and no joint runs
  faster than its speed limit at the programmed feed (the step time is the tip's travel over
  the feed);
* the cost of an edge is the square of the worst joint speed as a fraction of its limit; of a
  node, the squared shortfall of the wrist and limit margins below twice their minimum.

Stretches where no configuration gets through are reported as ranges (stroke, first pose,
last pose, reason: ``reach``, ``limit``, ``singularity`` or ``speed``), never skipped.

Lengths mm, angles radians, feed mm/min.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..geometry.vectors import perpendicular
from ..runtime import Progress, check_cancel
from ..toolpath.types import MOVE_RAPID, ToolPath
from . import kinematics as K
from .description import Robot, RobotError

__all__ = [
    "FreeAngleOptions",
    "Infeasible",
    "RobotPlan",
    "Stroke",
    "plan_robot",
    "strokes_of",
    "tool_frames",
]

REASONS = ("reach", "limit", "singularity", "speed")
_PTP_WEIGHT = 10.0  # cost of one second of joint move to a stroke's start


@dataclass(frozen=True)
class FreeAngleOptions:
    """Settings of the free-angle search (radians, mm, mm/min)."""

    samples: int = 36
    feed: float = 600.0
    max_joint_step: float = math.radians(10.0)
    min_wrist: float = math.radians(5.0)
    min_elbow: float = math.radians(2.0)
    min_shoulder: float = 50.0
    limit_margin: float = math.radians(1.0)

    def __post_init__(self):
        if not 4 <= self.samples <= 720:
            raise RobotError(f"free angle: samples must be 4..720, got {self.samples}")
        if not self.feed > 0:
            raise RobotError(f"free angle: feed must be > 0 mm/min, got {self.feed}")
        if not self.max_joint_step > 0:
            raise RobotError("free angle: the joint step limit must be > 0°")


@dataclass(frozen=True)
class Infeasible:
    """Poses ``first``..``last`` (inclusive, indices in the stroke) of stroke ``stroke`` that
    no configuration reaches for ``reason`` (one of reach, limit, singularity, speed);
    ``program_first``/``program_last`` the same poses in the linked program."""

    stroke: int
    first: int
    last: int
    reason: str
    program_first: int
    program_last: int

    def text(self) -> str:
        return (f"stroke {self.stroke + 1} poses {self.first + 1}–{self.last + 1} "
                f"(program poses {self.program_first + 1}–{self.program_last + 1}): "
                f"{self.reason}")


@dataclass
class Stroke:
    """One stroke as the robot runs it: a PTP to pose 0, linear moves to the others.

    index : int; start : int — its first pose in the linked program; config : int (0..7,
    :mod:`.kinematics`); frame : (m, 4, 4) tool frames in the part frame (mm); q : (m, 6)
    controller joints, radians (continuous along the stroke, inside the limits);
    feed : (m,) bool — the move ending at the pose is at feed (else a PTP/rapid).
    """

    index: int
    start: int
    config: int
    frame: np.ndarray
    q: np.ndarray
    feed: np.ndarray


@dataclass
class RobotPlan:
    """The free angle resolved over a path: strokes, infeasible ranges, figures.

    stats : min_wrist_deg, min_elbow_deg, min_shoulder_mm, min_limit_margin_deg,
    max_joint_step_deg, max_speed_ratio (worst joint speed over its limit at the feed).
    """

    robot: Robot
    options: FreeAngleOptions
    strokes: list[Stroke]
    infeasible: list[Infeasible] = field(default_factory=list)
    stats: dict = field(default_factory=dict)

    @property
    def feasible(self) -> bool:
        return not self.infeasible

    @property
    def n_poses(self) -> int:
        return int(sum(len(s.q) for s in self.strokes))


def strokes_of(path: ToolPath) -> list[tuple[int, np.ndarray, np.ndarray, np.ndarray]]:
    """[(start, tip (m, 3), axis (m, 3), feed (m,) bool)] of the linked program, split before
    every rapid pose; a path without a program: one stroke per pass."""
    prog = path.program
    if prog is None or len(prog) == 0:
        out, k = [], 0
        for c in path.curves:
            tip = np.vstack([c.tip, c.tip[:1]]) if c.closed else c.tip
            axis = np.vstack([c.axis, c.axis[:1]]) if c.closed else c.axis
            feed = np.ones(len(tip), bool)
            feed[0] = False
            out.append((k, tip, axis, feed))
            k += len(tip)
        return out
    rapid = prog.move == MOVE_RAPID
    starts = np.unique(np.concatenate([[0], np.nonzero(rapid)[0]]))
    stops = np.concatenate([starts[1:], [len(prog)]])
    out = []
    for a, z in zip(starts, stops, strict=True):
        feed = ~rapid[a:z]
        feed[0] = False
        out.append((int(a), prog.tip[a:z], prog.axis[a:z], feed))
    return out


def tool_frames(tip, axis) -> np.ndarray:
    """(m, 4, 4) tool frames at ψ = 0 of a stroke: origin the tip, z = −axis (the approach,
    into the part), x carried along the stroke by parallel transport (so that a constant ψ is
    a smooth tool motion)."""
    tip = np.asarray(tip, dtype=np.float64)
    z = -np.asarray(axis, dtype=np.float64)
    z = z / np.linalg.norm(z, axis=1, keepdims=True)
    x = np.empty_like(z)
    x[0] = perpendicular(z[0])
    for j in range(1, len(z)):
        v = x[j - 1] - (x[j - 1] @ z[j]) * z[j]
        n = np.linalg.norm(v)
        x[j] = v / n if n > 1e-9 else perpendicular(z[j])
    F = np.zeros((len(z), 4, 4))
    F[:, :3, 0], F[:, :3, 2] = x, z
    F[:, :3, 1] = np.cross(z, x)
    F[:, :3, 3] = tip
    F[:, 3, 3] = 1.0
    return F


def _spin(F, psi):
    """(m, K, 4, 4) frames F (m, 4, 4) turned by each ψ (K,) about their own z."""
    c, s = np.cos(psi), np.sin(psi)
    Rz = np.zeros((len(psi), 4, 4))
    Rz[:, 0, 0], Rz[:, 0, 1], Rz[:, 1, 0], Rz[:, 1, 1] = c, -s, s, c
    Rz[:, 2, 2] = Rz[:, 3, 3] = 1.0
    return F[:, None] @ Rz[None]


def _fit_turns(robot, q, margin):
    """q (..., 6) wrapped joints → the turn q + 2πn inside the limits less ``margin`` nearest
    the middle of the range, and whether one exists (..., 6)."""
    lo, hi = robot.limits[:, 0] + margin, robot.limits[:, 1] - margin
    mid = 0.5 * (lo + hi)
    best = np.full(q.shape, np.nan)
    for n in (-1, 0, 1):
        v = q + 2.0 * np.pi * n
        inside = (v >= lo) & (v <= hi)
        better = inside & (np.isnan(best) | (np.abs(v - mid) < np.abs(best - mid)))
        best = np.where(better, v, best)
    return best, ~np.isnan(best)


def _nodes(robot, frames, opt):
    """Joints (m, K, 8, 6) and node states of a stroke: code (m, K, 8) 0 feasible, else the
    index+1 of the reason (REASONS) that rules it out; node cost (m, K, 8)."""
    psi = np.linspace(0.0, 2.0 * np.pi, opt.samples, endpoint=False)
    T = _spin(frames, psi)  # (m, K, 4, 4) in the part frame
    flange = robot.flange_of(T)
    m, k = T.shape[:2]
    q, ok = K.inverse(robot, flange.reshape(-1, 4, 4))
    q, in_lim = _fit_turns(robot, q, opt.limit_margin)
    s = K.singularity(robot, np.nan_to_num(q))
    sing_ok = ((s["wrist"] >= opt.min_wrist) & (s["elbow"] >= opt.min_elbow)
               & (s["shoulder"] >= opt.min_shoulder))
    lim_all = in_lim.all(-1)
    code = np.where(~ok, 1, np.where(~lim_all, 2, np.where(~sing_ok, 3, 0)))
    margin = K.limit_margin(robot, np.nan_to_num(q)).min(-1)
    cost = (np.clip(1.0 - s["wrist"] / (2 * opt.min_wrist), 0, None) ** 2
            + np.clip(1.0 - margin / math.radians(10.0), 0, None) ** 2)
    shape = (m, k, 8)
    return q.reshape(m, k, 8, 6), code.reshape(shape), cost.reshape(shape), psi


def _edge(robot, qa, qb, dt, opt):
    """Edge cost (8, K', K) between joints qa (6, 8, K') and qb (6, 8, K): inf where a joint
    steps over the limit or runs over its speed (NaN joints: out of the limits). A joint whose
    range spans more than a turn steps by the shorter way round (its turn is fitted after)."""
    step = np.zeros(qa.shape[1:] + qb.shape[-1:])
    ratio = np.zeros_like(step)
    multi = _multi_turn(robot)
    for i in range(6):
        d = np.abs(qb[i][:, None, :] - qa[i][:, :, None])
        if multi[i]:  # turns fitted nearest the middle of the range: |d| ≤ 2π
            np.minimum(d, 2.0 * np.pi - d, out=d)
        np.maximum(step, d, out=step)
        np.maximum(ratio, d * (1.0 / (robot.speeds[i] * max(dt, 1e-9))), out=ratio)
    bad = (step > opt.max_joint_step) | (ratio > 1.0) | ~np.isfinite(step)
    return np.where(bad, np.inf, ratio * ratio)


def _multi_turn(robot):
    """(6,) bool — joints whose range spans more than one turn."""
    return (robot.limits[:, 1] - robot.limits[:, 0]) > 2.0 * np.pi


def _unwrap_fit(robot, qs, margin):
    """Joints (m, 6) of a stroke made continuous on the multi-turn joints and shifted by whole
    turns into the limits less ``margin``; also (m,) bool of poses left outside."""
    qs = qs.copy()
    lo, hi = robot.limits[:, 0] + margin, robot.limits[:, 1] - margin
    out = np.zeros(len(qs), bool)
    for i in np.nonzero(_multi_turn(robot))[0]:
        steps = np.mod(np.diff(qs[:, i]) + np.pi, 2.0 * np.pi) - np.pi
        v = qs[0, i] + np.concatenate([[0.0], np.cumsum(steps)])
        best = None
        for n in (0, -1, 1, -2, 2):
            w = v + 2.0 * np.pi * n
            bad = (w < lo[i]) | (w > hi[i])
            if best is None or bad.sum() < best[1].sum():
                best = (w, bad)
        qs[:, i] = best[0]
        out |= best[1]
    return qs, out


def _runs(mask):
    """[(first, last)] inclusive runs of True in a 1-D bool array."""
    m = np.concatenate([[False], np.asarray(mask, bool), [False]])
    d = np.diff(m.astype(np.int8))
    return list(zip(np.nonzero(d == 1)[0], np.nonzero(d == -1)[0] - 1, strict=True))


def _solve_stroke(robot, index, start, tip, axis, feed, opt, prev_q=None):
    """One stroke → (Stroke or None, [Infeasible]). ``prev_q`` (6,): the joints the previous
    stroke ended at; the time of the joint move from there is added to the start's cost (so
    the arm keeps its configuration across strokes when it can)."""
    frames = tool_frames(tip, axis)
    q, code, node_cost, psi = _nodes(robot, frames, opt)
    m, k = code.shape[:2]
    seg = np.r_[0.0, np.linalg.norm(np.diff(tip, axis=0), axis=1)]
    dt = seg / (opt.feed / 60.0)
    feasible = code == 0
    # forward pass, all eight configurations at once: cost (8, K)
    start_cost = node_cost[0].T
    if prev_q is not None:
        ptp = np.abs(np.nan_to_num(q[0], nan=1e3) - prev_q) / robot.speeds  # (K, 8, 6) s
        start_cost = start_cost + _PTP_WEIGHT * ptp.max(-1).T
    cost = np.where(feasible[0].T, start_cost, np.inf)
    back = np.zeros((m, 8, k), dtype=np.int64)
    died = np.full(8, -1)
    qc = np.moveaxis(q, 2, 1)  # (m, 8, K, 6)
    qj = np.ascontiguousarray(np.moveaxis(q, 3, 1).swapaxes(2, 3))  # (m, 6, 8, K)
    for j in range(1, m):
        if j % 256 == 0:
            check_cancel()
        if feed[j]:
            e = _edge(robot, qj[j - 1], qj[j], dt[j], opt)  # (8, K', K)
        else:  # a PTP: any joint motion
            e = np.zeros((8, k, k))
        tot = cost[:, :, None] + e
        back[j] = np.argmin(tot, axis=1)
        new = np.take_along_axis(tot, back[j][:, None, :], 1)[:, 0, :]
        new = np.where(feasible[j].T, new + node_cost[j].T, np.inf)
        gone = ~np.isfinite(new).any(1) & (died < 0)
        died[gone] = j
        cost = new
    best = int(np.argmin(cost.min(1)))
    if np.isfinite(cost[best]).any():
        kk = np.empty(m, dtype=np.int64)
        kk[-1] = int(np.argmin(cost[best]))
        for j in range(m - 1, 0, -1):
            kk[j - 1] = back[j, best, kk[j]]
        qs, outside = _unwrap_fit(robot, qc[np.arange(m), best, kk], opt.limit_margin)
        if not outside.any():
            return Stroke(index, start, best, _spin(frames, psi)[np.arange(m), kk], qs, feed), []
        return None, [Infeasible(index, int(a), int(z), "limit", start + int(a), start + int(z))
                      for a, z in _runs(outside)]
    # no configuration gets through: report where the best-placed one fails, and why
    node_any = feasible.any(1)  # (m, 8)
    c = int(np.argmax(node_any.sum(0) * (m + 1) + np.where(died < 0, m, died)))
    out = []
    bad = ~node_any[:, c]
    for a, z in _runs(bad):
        codes = code[a:z + 1, :, c]
        reason = REASONS[int(codes.min()) - 1] if codes.min() > 0 else "speed"
        # the reason of a stretch: the one that rules out most of it
        vals, counts = np.unique(codes[codes > 0], return_counts=True)
        if len(vals):
            reason = REASONS[int(vals[np.argmax(counts)]) - 1]
        out.append(Infeasible(index, int(a), int(z), reason, start + int(a), start + int(z)))
    # between poses it can reach, the joints step too far or too fast: follow configuration c
    # and start again after every break, so that each such step is reported
    alive = None
    for j in range(m):
        ok_j = feasible[j, :, c]
        if not ok_j.any():
            alive = None
            continue
        if alive is None or not feed[j]:
            alive = np.where(ok_j, 0.0, np.inf)
            continue
        e = _edge(robot, qj[j - 1][:, c:c + 1], qj[j][:, c:c + 1], dt[j], opt)[0]
        new = np.where(ok_j, (alive[:, None] + e).min(0), np.inf)
        if not np.isfinite(new).any():
            out.append(Infeasible(index, j - 1, j, "speed", start + j - 1, start + j))
            new = np.where(ok_j, 0.0, np.inf)
        alive = new
    if not out:  # every configuration died somewhere, each at a different place
        j = int(died[c]) if died[c] > 0 else m - 1
        out.append(Infeasible(index, j - 1, j, "speed", start + j - 1, start + j))
    return None, _merged(sorted(out, key=lambda b: b.first))


def _merged(ranges):
    """Touching or overlapping ranges of one reason as one range."""
    out = []
    for b in ranges:
        if out and out[-1].reason == b.reason and b.first <= out[-1].last + 1:
            a = out[-1]
            last = max(a.last, b.last)
            out[-1] = Infeasible(a.stroke, a.first, last, a.reason, a.program_first,
                                 a.program_first + last - a.first)
        else:
            out.append(b)
    return out


def plan_robot(robot: Robot, path: ToolPath, options: FreeAngleOptions | None = None,
               progress=None) -> RobotPlan:
    """Resolve the free angle over ``path`` for ``robot`` (module docstring).

    Parameters
    ----------
    robot : Robot; path : ToolPath (its linked program, else its passes)
    options : FreeAngleOptions; progress : callable taking a :class:`..runtime.Progress`
    after every stroke, or None. Cancellable (:func:`..runtime.cancellable`).

    Returns
    -------
    RobotPlan — strokes (None of them where a stroke is infeasible), infeasible ranges, stats
    """
    opt = options or FreeAngleOptions()
    parts = strokes_of(path)
    if not parts:
        raise RobotError("the path has no poses to program")
    strokes, bad = [], []
    prev = None
    for i, (start, tip, axis, feed) in enumerate(parts):
        check_cancel()
        s, infeasible = _solve_stroke(robot, i, start, tip, axis, feed, opt, prev)
        bad.extend(infeasible)
        if s is not None:
            strokes.append(s)
            prev = s.q[-1]
        if progress is not None:
            progress(Progress((i + 1) / len(parts), f"free angle: stroke {i + 1} of "
                              f"{len(parts)} ({len(tip)} poses)"))
    plan = RobotPlan(robot, opt, strokes, bad)
    plan.stats = _stats(robot, strokes, opt)
    return plan


def _stats(robot, strokes, opt) -> dict:
    if not strokes:
        return {}
    q = np.vstack([s.q for s in strokes])
    sing = K.singularity(robot, q)
    steps, ratio = [0.0], [0.0]
    for s in strokes:
        if len(s.q) < 2:
            continue
        d = np.abs(np.diff(s.q, axis=0))[s.feed[1:]]
        if len(d):
            steps.append(float(d.max()))
            tip = s.frame[:, :3, 3]
            dt = np.linalg.norm(np.diff(tip, axis=0), axis=1)[s.feed[1:]] / (opt.feed / 60.0)
            ratio.append(float((d / (robot.speeds * np.maximum(dt, 1e-9)[:, None])).max()))
    return {
        "min_wrist_deg": math.degrees(float(sing["wrist"].min())),
        "min_elbow_deg": math.degrees(float(sing["elbow"].min())),
        "min_shoulder_mm": float(sing["shoulder"].min()),
        "min_limit_margin_deg": math.degrees(float(K.limit_margin(robot, q).min())),
        "max_joint_step_deg": math.degrees(max(steps)),
        "max_speed_ratio": max(ratio),
    }
