"""The rows of a linked program and the rapids through the clearance surface.

:class:`ProgramRows` collects a program's rows (tips, axes, moves, pass and pose ids, flags)
as :mod:`.linking` builds it. A rapid leaves a pose for the clearance surface (r = R + slope ·
(z − z0) about the blisk axis, :class:`.linking.Clearance`) along its tool axis when the axis
is within 60° of radial (:func:`clearance_point`: the tool body stays on its own line, as the
collision check saw it), else radially; on the surface the angle about the blisk axis and the
height are linear and the tool axis is slerped (:func:`via_clearance`, :func:`via_axis_exits`).
Lengths mm, angles radians.
"""

from __future__ import annotations

import math

import numpy as np

from ..geometry.axis import Axis, cylindrical, from_cylindrical, meridional
from ..geometry.vectors import slerp
from ..toolpath.types import MOVE_RAPID, MOVE_RETRACT, Program

__all__ = ["AXIS_EXIT_MIN_RADIAL", "ProgramRows", "axis_exit", "clearance_point",
           "via_axis_exits", "via_clearance"]


class ProgramRows:
    """The growing rows of a program: tips, axes, moves, pass and pose ids, flags."""

    def __init__(self):
        self.tips, self.axs, self.moves, self.cidx, self.pidx, self.flags = [], [], [], [], [], []

    def emit(self, t, a, m, ci=-1, pi=None, fl=None):
        """Append rows: tips t (k, 3), axes a, move(s) m, pass ci, pose ids pi, flags fl."""
        t = np.atleast_2d(t)
        a = np.broadcast_to(np.atleast_2d(a), t.shape)
        k = len(t)
        self.tips.append(t)
        self.axs.append(a)
        self.moves.append(np.full(k, m, dtype=np.int8) if np.ndim(m) == 0
                          else np.asarray(m, np.int8))
        self.cidx.append(np.full(k, ci, dtype=np.int64))
        self.pidx.append(np.full(k, -1, dtype=np.int64) if pi is None
                         else np.asarray(pi, np.int64))
        self.flags.append(np.zeros(k, dtype=np.uint8) if fl is None else np.asarray(fl, np.uint8))

    def extend(self, other: ProgramRows):
        """Append the rows of ``other``."""
        for name in ("tips", "axs", "moves", "cidx", "pidx", "flags"):
            getattr(self, name).extend(getattr(other, name))

    def program(self) -> Program:
        """The rows as a Program."""
        return Program(
            tip=np.vstack(self.tips),
            axis=np.vstack(self.axs),
            move=np.concatenate(self.moves),
            curve=np.concatenate(self.cidx),
            index=np.concatenate(self.pidx),
            flags=np.concatenate(self.flags),
        )


#: the least radial growth (mm per mm along the tool axis, the cosine of the axis's angle
#: from the radial direction) for a planned rapid to leave along the tool axis: within 60° of
#: radial the way out is at most twice the radial rise; an axis leaning further (down the
#: blisk axis at the leading and trailing edges) would run far below or above the blisk, where
#: the fixture and the table are, so the rapid goes radially as before (collision avoidance
#: re-routes it along the axis, :mod:`..collision.reroute`, when that one collides)
AXIS_EXIT_MIN_RADIAL = 0.5


def clearance_point(p, a, clear, axis: Axis, along_axis: bool = True):
    """Where a rapid from (or down to) the point ``p`` with tool axis ``a`` meets the
    clearance surface: along the tool axis when it leads out of the blisk (the tool body then
    stays on its own line, as the collision check saw it), else radially at p's angle and
    height (an axis leaning more than 60° from the radial direction, or ``along_axis``
    False)."""
    _, th, z, fr = cylindrical(p[None, :], axis)
    radial = from_cylindrical(clear.r_at(z), th, z, axis, fr)[0]
    if not along_axis:
        return radial
    q = p - axis.o
    qz, az = float(q @ axis.d), float(a @ axis.d)
    qp, ap = q - qz * axis.d, a - az * axis.d
    rq = float(np.linalg.norm(qp))
    if rq <= 0 or float(qp @ ap) / rq < AXIS_EXIT_MIN_RADIAL:
        return radial
    reach = 4.0 * float(clear.r_at(z[0])) + 4.0 * rq
    t = axis_exit(p, a, clear, axis, reach)
    return radial if t is None else p + t * a


def via_clearance(rows: ProgramRows, clear, axis: Axis, rapid_step, p_from, a_from, p_to,
                   a_to, first=False, along_axis=True):
    """Rapids: out from p_from to the clearance surface, along it, in to p_to; out and in
    along the tool axes where they lead out of the blisk (:func:`clearance_point`), else
    radially; along the surface the angle about the blisk axis and the height are linear and
    the tool axis is slerped. ``first``: the program's first approach (nothing before
    p_from; the tool arrives on the clearance surface with ``a_to``). ``along_axis`` False:
    out and in radially."""
    up = clearance_point(p_from, a_to if first else a_from, clear, axis, along_axis)
    down = clearance_point(p_to, a_to, clear, axis, along_axis)
    _, th1, z1, fr = cylindrical(up[None, :], axis)
    _, th2, z2, _ = cylindrical(down[None, :], axis)
    dth = float((th2[0] - th1[0] + math.pi) % (2 * math.pi) - math.pi)
    n = max(1, int(math.ceil(abs(dth) / rapid_step)))
    t = np.arange(1, n + 1) / n
    zz = z1[0] + t * (z2[0] - z1[0])
    along = from_cylindrical(clear.r_at(zz), th1[0] + t * dth, zz, axis, fr)
    a_up = a_to if first else a_from
    rows.emit(up, a_up, MOVE_RAPID)
    a_along = (
        slerp(np.asarray(a_from), np.asarray(a_to), t)
        if not first
        else np.broadcast_to(a_to, along.shape)
    )
    rows.emit(along[:-1], a_along[:-1], MOVE_RAPID) if n > 1 else None
    # the first pass starts straight below its clearance point: ``down`` is ``up`` again
    if n > 1 or not (np.allclose(down, up, rtol=0, atol=1e-9) and np.array_equal(a_to, a_up)):
        rows.emit(down, a_to, MOVE_RAPID)
    rows.emit(p_to, a_to, MOVE_RAPID)


def axis_exit(p, a, clear, axis: Axis, reach: float):
    """Length t (mm) where ``p + t a`` first reaches the clearance surface, or None when it
    does not within ``reach`` mm (the axis does not lead out of the blisk)."""
    t = np.linspace(0.0, reach, max(2, int(math.ceil(reach)) + 1))
    r, z = meridional(p[None, :] + t[:, None] * a[None, :], axis)
    out = np.flatnonzero(r >= clear.r_at(z))
    if not len(out) or out[0] == 0:
        return None
    lo, hi = float(t[out[0] - 1]), float(t[out[0]])
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        rm, zm = meridional((p + mid * a)[None, :], axis)
        lo, hi = (lo, mid) if rm[0] >= clear.r_at(zm[0]) else (mid, hi)
    return hi


def via_axis_exits(rows: ProgramRows, clear, axis, rapid_step, d_app, pt, pa, t0, a0) -> bool:
    """Retract up ``pa`` to the clearance surface, rapids on it to where ``a0``'s line from
    ``t0`` meets it (angle about the blisk axis and height linear, the tool axis slerped), a
    rapid down ``a0`` to the approach point (as :mod:`..collision.reroute` builds its routes).
    False (nothing emitted) when an axis does not lead out of the blisk."""
    reach = 4.0 * float(clear.radius) + 4.0 * float(np.linalg.norm(pt - t0))
    ta, tb = axis_exit(pt, pa, clear, axis, reach), axis_exit(t0, a0, clear, axis, reach)
    if ta is None or tb is None or tb <= d_app:
        return False
    ea, eb = pt + ta * pa, t0 + tb * a0
    _, th1, z1, fr = cylindrical(ea[None, :], axis)
    _, th2, z2, _ = cylindrical(eb[None, :], axis)
    dth = float((th2[0] - th1[0] + math.pi) % (2 * math.pi) - math.pi)
    ang = math.acos(max(-1.0, min(1.0, float(np.dot(pa, a0)))))
    n = max(1, int(math.ceil(max(abs(dth), ang) / rapid_step)))
    u = np.arange(1, n + 1) / n
    zz = z1[0] + u * (z2[0] - z1[0])
    along = from_cylindrical(clear.r_at(zz), th1[0] + u * dth, zz, axis, fr)
    along[-1] = eb
    au = slerp(np.asarray(pa), np.asarray(a0), u) if n > 1 else np.atleast_2d(a0)
    rows.emit(ea, pa, MOVE_RETRACT)
    rows.emit(along, au, MOVE_RAPID)
    rows.emit(t0 + d_app * a0, a0, MOVE_RAPID)
    return True
