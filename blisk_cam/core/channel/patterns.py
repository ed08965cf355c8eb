"""Roughing patterns on a level and the linked program of a channel.

**Zig-zag** (:func:`zigzag_passes`): passes that follow the blades along the channel, from
before the leading edge to beyond the trailing edge (both ends outside the blank, so the
tool enters and leaves the material from the side), at fractions w_i = i/(n − 1) of the
channel's width between the two bounds of :mod:`.region` — the first and last pass follow
the two blades' offset walls exactly; n is chosen so that no step across exceeds the
stepover at the widest station. Consecutive passes run in opposite directions; the next level
starts where the previous one ended.

**Plunge** (:func:`plunge_points`): the same fractions across, stations every stepover
along: at each point the tool feeds down its axis from the level above to this level and
back (low radial force: the usual choice for narrow titanium channels).

Where a station cannot be reached (the bounds cross: the tool or its body does not fit) the
pass is split; :func:`link_program` joins the pieces: a feed link in the air beyond the
blank's faces when two pieces end and start there, otherwise a retract along the axis to the
safe radius, a rapid there and an approach down the axis; between two plunges across the
channel at one station the tool moves over the level above (already cut) at feed. A plunge
is safe all the way down when its bottom pose is: the tool higher up its own axis occupies
less than the flute and body above the lower tip already cover. Units mm, radians.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..geometry.axis import Axis
from ..toolpath.types import MOVE_APPROACH, MOVE_CUT, MOVE_LINK, MOVE_RAPID, MOVE_RETRACT

__all__ = ["Piece", "drop_straight", "link_program", "machining_time", "pass_count", "runs_of",
           "pass_pieces",
           "plunge_points", "pose_frame", "zigzag_passes"]


@dataclass
class Piece:
    """A run of cutting poses: tips (k, 3) mm, axes (k, 3) unit, the level's index,
    ``outside`` (2,) bool: its first / last pose lies beyond the blank's faces (air),
    ``plunge`` True for a plunge (approach, cut down, retract in one), ``contour`` True for a
    pass along a wall with its own axis, ``band`` True for a surface-driven pass of the floor
    band (:mod:`.floor_band`)."""

    tip: np.ndarray
    axis: np.ndarray
    level: int
    outside: tuple
    plunge: bool = False
    station: int = -1
    contour: bool = False
    band: bool = False


def pose_frame(axis: Axis, theta, z, r, theta_ref: float, lead: float, side: float):
    """Tips (n, 3) and unit axes (n, 3) of tool poses at (θ + theta_ref, z, r): the radial
    direction tilted by ``lead`` toward +z and ``side`` toward +θ (rad; scalars or (n,))."""
    e1, e2, d = axis.angular_frame()
    th = np.asarray(theta, float) + theta_ref
    u = np.cos(th)[:, None] * e1 + np.sin(th)[:, None] * e2
    t = -np.sin(th)[:, None] * e1 + np.cos(th)[:, None] * e2
    tip = axis.o + np.asarray(z, float)[:, None] * d + np.asarray(r, float)[:, None] * u
    ts = np.reshape(np.tan(np.asarray(side, float)), (-1, 1))
    tl = np.reshape(np.tan(np.asarray(lead, float)), (-1, 1))
    a = u + ts * t + tl * d
    return tip, a / np.linalg.norm(a, axis=1)[:, None]


def runs_of(mask):
    """[(start, stop)] of the True runs of a bool array."""
    m = np.concatenate([[False], np.asarray(mask, bool), [False]])
    d = np.diff(m.astype(np.int8))
    return list(zip(np.nonzero(d == 1)[0], np.nonzero(d == -1)[0], strict=True))


def drop_straight(tip, axis, tol: float = 1e-7):
    """Indices of the poses to keep: interior poses on the straight line of their neighbours
    with the same axis (a pass in the open, before or after the blades) are dropped — exactly,
    the tool moves the same way without them."""
    k = len(tip)
    if k < 3:
        return np.arange(k)
    a, b, c = tip[:-2], tip[1:-1], tip[2:]
    ab = c - a
    L = np.linalg.norm(ab, axis=1)
    t = np.einsum("ij,ij->i", b - a, ab) / np.maximum(L * L, 1e-300)
    off = np.linalg.norm(a + t[:, None] * ab - b, axis=1)
    same = (np.abs(axis[:-2] - axis[1:-1]).max(axis=1) < 1e-12) & \
        (np.abs(axis[2:] - axis[1:-1]).max(axis=1) < 1e-12)
    drop = (off < tol) & same & (t > 0) & (t < 1)
    keep = np.ones(k, bool)
    keep[1:-1] = ~drop
    return np.nonzero(keep)[0]


def pass_count(width_mm, stepover: float) -> int:
    """Passes across so that no step exceeds ``stepover`` at the widest reachable station."""
    w = np.asarray(width_mm, float)
    w = w[np.isfinite(w) & (w >= 0)]
    top = float(w.max()) if len(w) else 0.0
    return max(2, int(math.ceil(top / stepover - 1e-9)) + 1)


def zigzag_passes(level: int, z, r, lo, hi, reach, outside, stepover: float, frame,
                  forward: bool, start_low: bool):
    """[Piece] of one level: passes at fractions of the width (lo, hi) (rad) over stations
    ``z`` with tip radii ``r``; ``reach`` (n,) bool the reachable stations, ``outside``
    (n,) bool the stations beyond the blank; ``frame(theta, z, r)`` → (tips, axes).
    Returns (pieces, forward, start_low) for the next level to continue from."""
    width = (hi - lo) * r
    n = pass_count(np.where(reach, width, np.nan), stepover)
    ws = np.linspace(0.0, 1.0, n)
    if not start_low:
        ws = ws[::-1]
    pieces = []
    fwd = forward
    for w in ws:
        theta = lo + w * (hi - lo)
        tips, axes = frame(theta, z, r)
        pieces.extend(pass_pieces(level, tips, axes, reach, outside, fwd))
        fwd = not fwd
    return pieces, fwd, not start_low


def pass_pieces(level: int, tips, axes, reach, outside, forward: bool) -> list:
    """[Piece] of one pass along the channel: poses (n, 3) ``tips`` and ``axes`` over the
    stations, split where ``reach`` (n,) is False, run toward +z when ``forward``."""
    runs = runs_of(reach)
    if not forward:
        runs = [(b, a) for a, b in runs[::-1]]
    pieces = []
    for a, b in runs:
        sl = slice(a, b) if forward else slice(a - 1, b - 1 if b > 0 else None, -1)
        idx = np.arange(len(tips))[sl]
        if len(idx) < 2:
            continue
        idx = idx[drop_straight(tips[idx], axes[idx])]
        pieces.append(Piece(tips[idx], axes[idx], level,
                            (bool(outside[idx[0]]), bool(outside[idx[-1]]))))
    return pieces


def plunge_points(level: int, z, r, r_above, lo, hi, reach, stepover: float, frame,
                  radius: float | None = None, fractions=None):
    """[Piece] of plunges on one level: fractions across as the zig-zag's (or
    ``fractions``), stations along z at most s_z apart; each piece goes from the level above
    (``r_above``) down to the level and back up. The plunges of a rectangular grid with steps
    s_x across and s_z along leave no island between four holes of the tool's ``radius`` R
    when (s_x/2)² + (s_z/2)² ≤ R²: s_z = min(stepover, R, 2 √(R² − (s_x/2)²)) (at least a
    quarter of the stepover; ``radius`` None: s_z = stepover)."""
    width = (hi - lo) * r
    n = pass_count(np.where(reach, width, np.nan), stepover)
    ws_all = np.linspace(0.0, 1.0, n) if fractions is None else np.asarray(fractions, float)
    w = width[reach & np.isfinite(width)]
    s_x = float(w.max()) / (n - 1) if len(w) and fractions is None else 0.0
    s_z = stepover
    if radius is not None:
        # and at most the radius: the walls between two plunges keep a scallop of at most
        # R − √(R² − R²/4) = 0.13 R
        s_z = min(stepover, radius, max(0.25 * stepover, 2.0 * math.sqrt(
            max(radius * radius - 0.25 * s_x * s_x, 0.0))))
    # the stations: greedy, each the last within s_z of the one before, a new start at
    # every run of reachable stations
    pick = []
    for a, b in runs_of(reach):
        i = a
        pick.append(i)
        while i < b - 1:
            j = int(np.searchsorted(z[i:b], z[i] + s_z + 1e-9, "right")) + i - 1
            i = max(j, i + 1)
            pick.append(i)
    pieces = []
    for j, i in enumerate(pick):
        ws = ws_all
        if j % 2:
            ws = ws[::-1]
        for w in ws:
            th = np.full(2, lo[i] + w * (hi[i] - lo[i]))
            tips, axes = frame(th, np.full(2, z[i]), np.array([r_above[i], r[i]]))
            # down the bottom pose's own axis (a tilted axis is not radial)
            tips[0] = tips[1] + float((tips[0] - tips[1]) @ axes[1]) * axes[1]
            axes[0] = axes[1]
            pieces.append(Piece(tips, axes, level, (False, False), plunge=True, station=int(i)))
    return pieces


def link_program(pieces, axis: Axis, r_safe: float):
    """The linked program of ``pieces`` in order: (tip, axis, move, curve, index) arrays and
    the [start, stop) rows of each level. ``r_safe`` (mm): the radius above the blank where
    rapids run."""
    e1, e2, d = axis.angular_frame()

    def safe(p, a):
        # along the tool axis out to the safe radius (a radial-ish axis: solve |p + t a|⊥ = r)
        q = p - axis.o
        qp = q - (q @ d) * d
        ap = a - (a @ d) * d
        A, B, C = ap @ ap, 2 * (qp @ ap), qp @ qp - r_safe * r_safe
        t = (-B + math.sqrt(max(B * B - 4 * A * C, 0.0))) / (2 * A) if A > 1e-12 else 0.0
        return p + max(t, 0.0) * a

    tips, axes, moves, curve, index = [], [], [], [], []
    level_rows: dict = {}

    def add(p, a, m, c=-1, i=-1):
        tips.append(p)
        axes.append(a)
        moves.append(m)
        curve.append(c)
        index.append(i)

    prev = None
    for k, pc in enumerate(pieces):
        first = len(tips)
        p0, a0 = pc.tip[0], pc.axis[0]
        if prev is None:
            add(safe(p0, a0), a0, MOVE_RAPID)
            add(p0, a0, MOVE_APPROACH)
        elif prev.outside[1] and pc.outside[0] and not pc.plunge and not prev.plunge:
            add(p0, a0, MOVE_LINK)
        elif pc.plunge and prev.plunge and (pc.level, pc.station) == (prev.level, prev.station):
            # across the channel at one station, over the level above (already cut): the
            # tool's room there is one interval of θ, so the straight move stays inside it
            add(p0, a0, MOVE_LINK)
        else:
            add(safe(prev.tip[-1], prev.axis[-1]), prev.axis[-1], MOVE_RETRACT)
            add(safe(p0, a0), a0, MOVE_RAPID)
            add(p0, a0, MOVE_APPROACH)
        for j in range(1, len(pc.tip)):
            add(pc.tip[j], pc.axis[j], MOVE_CUT, k, j)
        if pc.plunge:  # back up to where it came down from
            add(pc.tip[0], pc.axis[0], MOVE_RETRACT)
        lo_, _ = level_rows.get(pc.level, (first, first))
        level_rows[pc.level] = (min(lo_, first), len(tips))
        prev = pc
    if prev is not None:
        add(safe(prev.tip[-1] if not prev.plunge else prev.tip[0], prev.axis[-1]),
            prev.axis[-1], MOVE_RETRACT)
    rows = dict(level_rows)
    return (np.asarray(tips, float).reshape(-1, 3), np.asarray(axes, float).reshape(-1, 3),
            np.asarray(moves, np.int8), np.asarray(curve, np.int64),
            np.asarray(index, np.int64), rows)


def machining_time(tip, move, feed: float, plunge_feed: float, rapid_feed: float) -> dict:
    """Estimated time (minutes) and lengths (mm) of a program's moves at the feeds (mm/min):
    cut and link at ``feed``, approach and retract at ``plunge_feed``, rapids at
    ``rapid_feed`` (acceleration not modelled)."""
    seg = np.linalg.norm(np.diff(np.asarray(tip, float), axis=0), axis=1)
    m = np.asarray(move)[1:]
    lengths = {}
    for name, codes in (("cut", (MOVE_CUT,)), ("link", (MOVE_LINK,)),
                        ("approach_retract", (MOVE_APPROACH, MOVE_RETRACT)),
                        ("rapid", (MOVE_RAPID,))):
        lengths[name] = float(seg[np.isin(m, codes)].sum())
    minutes = ((lengths["cut"] + lengths["link"]) / feed
               + lengths["approach_retract"] / plunge_feed + lengths["rapid"] / rapid_feed)
    return {"minutes": minutes, "lengths_mm": lengths}
