"""Axes along a pass: the motion between two poses, the channel's reference axis, the turn limit
between consecutive poses, and the frame a pass's axis deviations are measured in (carried
along the pass by parallel transport) with its exponential and logarithmic maps — the geometry
the axis planner (:mod:`.axis_plan`) chooses its states in.

Lengths mm, angles radians; numpy only.
"""

from __future__ import annotations

import math

import numpy as np

from ..geometry.vectors import angle_between, unit

__all__ = ["MIN_STEP", "channel_reference", "deviation_axes", "deviation_of",
           "pass_turn_limits", "path_steps", "sample_motion", "transported_frames",
           "turn_allowance", "turn_limits"]

#: shortest step the turn limit counts, mm (see :func:`turn_limits`)
MIN_STEP = 0.05


def sample_motion(tip0, ax0, tip1, ax1, t, paired=False):
    """Poses on the motion between two poses (k rows each) at fractions ``t`` (s,) in (0, 1):
    the tip linear, the axis turned uniformly in the plane of the two (slerp). Returns
    (tips (k·s, 3), axes (k·s, 3)), pose-major; ``paired``: ``t`` (k,), one fraction per
    row (k poses returned)."""
    t = np.asarray(t, dtype=np.float64)
    om = angle_between(ax0, ax1)[:, None, None]
    so = np.sin(om)
    tt = t[:, None, None] if paired else t[None, :, None]
    small = so < 1e-9
    w0 = np.where(small, 1 - tt, np.sin((1 - tt) * om) / np.where(small, 1.0, so))
    w1 = np.where(small, tt, np.sin(tt * om) / np.where(small, 1.0, so))
    ax = unit((w0 * ax0[:, None, :] + w1 * ax1[:, None, :]).reshape(-1, 3), keep_zero=False)
    tp = ((1 - tt) * tip0[:, None, :] + tt * tip1[:, None, :]).reshape(-1, 3)
    return tp, ax


def channel_reference(cc, normal, blisk_axis, blade_count: int):
    """(k, 3) unit axes interpolated between the two blade sides of the gap at each CC point:
    the radial direction of the channel's mid-plane — the meridional plane of ``cc`` turned
    about the blisk axis by half the pitch (π/N) toward the side the normal ``normal`` faces
    (the neighbour across the channel)."""
    o = np.asarray(blisk_axis.o, dtype=np.float64)
    d = unit(np.asarray(blisk_axis.d, dtype=np.float64))
    rel = np.asarray(cc, dtype=np.float64) - o
    radial = rel - (rel @ d)[:, None] * d
    r = np.linalg.norm(radial, axis=1)
    er = radial / np.maximum(r, 1e-300)[:, None]
    et = np.cross(d, er)
    side = np.sign(np.einsum("ij,ij->i", normal, et))
    side = np.where(side == 0, 1.0, side)
    half = side * math.pi / blade_count
    return unit(np.cos(half)[:, None] * er + np.sin(half)[:, None] * et, keep_zero=False)


def path_steps(cc, normal, corner_radius):
    """(k − 1,) mm: the length of tool path between consecutive poses — the distance the turn
    limit is measured along (:func:`turn_limits`; the axis planner's arc, :mod:`.axis_plan`).

    The machine feeds along the tool's own path (with TCPM the programmed tip), and the
    rotary speed it sees is the turn ÷ (tool path length ÷ feed); round a blade edge of radius
    ~0.5 mm a Ø12 ball's centre travels ~π·6.5 ≈ 20 mm while the contact travels ~1.6 mm.
    The point measured is the **corner centre at the contact**, ``cc + r·n`` (r the cutter's
    corner radius, n the unit surface normal at the contact): for a ball its centre, for a
    bull nose the centre of the corner circle that touches, for a flat end (r = 0) the
    contact itself. It is the one point of the cutter the contact fixes whatever the axis
    (the tip is recomputed from the contact for every axis the planner tries), so the limit
    is one number per pose pair, known before the axes are chosen — the shortest path needs
    that; the programmed tip would move with the chosen axis. The tip (and the cutter's
    centre on its axis) lies within the tool radius R of it in a direction that turns with
    the axis, so its step differs from this one by at most about R × the turn. Round an edge
    with the axis held across it, the corner centre goes round at the edge radius + r, the
    cutter's axis at the edge radius + R: for a bull nose or a flat end the corner centre's
    path is the shorter one, the cautious choice (a flat end counts the contact's). Never
    less than the contact's own distance (on a concave surface the corner centre's path is
    the shorter one)."""
    cc = np.asarray(cc, dtype=np.float64)
    centre = cc + float(corner_radius) * np.asarray(normal, dtype=np.float64)
    return np.maximum(np.linalg.norm(np.diff(cc, axis=0), axis=1),
                      np.linalg.norm(np.diff(centre, axis=0), axis=1))


def turn_allowance(cc, normal, corner_radius, turn_per_mm, max_turn=None):
    """(k − 1,) rad: the turn the limit adds to the planned one between consecutive poses:
    ``turn_per_mm`` × the tool path's length between them (:func:`path_steps`, at least
    :data:`MIN_STEP` mm), capped by ``max_turn`` per pose when given."""
    added = turn_per_mm * np.maximum(path_steps(cc, normal, corner_radius), MIN_STEP)
    return added if max_turn is None else np.minimum(added, max_turn)


def turn_limits(cc, normal, planned_axes, corner_radius, turn_per_mm, max_turn=None):
    """(k − 1,) largest axis turn (rad) allowed between consecutive poses of a pass (contact
    points ``cc``, unit normals ``normal``, planned axes (k, 3)): the planned turn there (the
    surface's own, which avoidance does not judge) plus :func:`turn_allowance` —
    ``turn_per_mm`` × the tool path's length between them, capped by ``max_turn`` per pose
    when given. The one definition of the limit: the planner, its verification and the
    report's "turns over the limit" all read it."""
    a = np.asarray(planned_axes, dtype=np.float64)
    return angle_between(a[:-1], a[1:]) + turn_allowance(cc, normal, corner_radius,
                                                          turn_per_mm, max_turn)


def pass_turn_limits(cc, normal, planned_axes, closed, corner_radius, turn_per_mm,
                     max_turn=None):
    """:func:`turn_limits` of one pass, aligned with
    :func:`..paths.orientation.consecutive_turn`: (k − 1,), or for a closed pass of more than
    two poses (k,) with the closing pair (last pose → first) last; the planned axes made
    unit."""
    loop = closed and len(cc) > 2
    cc, nrm, ax = (np.vstack([x, x[:1]]) if loop else x
                   for x in (np.asarray(cc, dtype=np.float64),
                             np.asarray(normal, dtype=np.float64),
                             unit(np.asarray(planned_axes, dtype=np.float64))))
    return turn_limits(cc, nrm, ax, corner_radius, turn_per_mm, max_turn)


def _transport(a, b, v):
    """v (3,) ⊥ a carried to ⊥ b by the smallest rotation taking unit a to unit b."""
    w = np.cross(a, b)
    sw, cw = float(np.linalg.norm(w)), float(a @ b)
    if sw > 1e-12:
        w = w / sw
        v = v * cw + np.cross(w, v) * sw + w * (w @ v) * (1.0 - cw)
    v = v - (v @ b) * b
    return v / np.linalg.norm(v)


def transported_frames(ref, start, arc=None):
    """(e1, e2) (k, 3): unit vectors across the reference axes ``ref`` (k, 3) of consecutive
    poses, e1 starting along ``start`` (3,) (made ⊥ ref[0]) and carried from pose to pose by
    the smallest rotation taking one reference axis to the next (parallel transport), e2 =
    ref × e1. A deviation (u, v) held in this frame (:func:`deviation_axes`) turns between two
    poses by at most the reference's own turn there. ``arc`` (k + 1,) given: the poses close a
    loop (the last followed by the first, ``arc[-1]`` the loop's length); the frame carried
    round comes back turned about the axis by the holonomy ψ, and each pose's frame is spun
    back by ψ in proportion to its arc, so the frame is continuous across the closing cut."""
    R = np.asarray(ref, dtype=np.float64)
    E = np.empty_like(R)
    e = np.asarray(start, dtype=np.float64) - (np.asarray(start) @ R[0]) * R[0]
    E[0] = e / np.linalg.norm(e)
    for j in range(1, len(R)):
        E[j] = _transport(R[j - 1], R[j], E[j - 1])
    if arc is not None and len(R) > 2:
        v = _transport(R[-1], R[0], E[-1])
        psi = math.atan2(float(np.cross(E[0], v) @ R[0]), float(E[0] @ v))
        al = -psi * np.asarray(arc[:-1], dtype=np.float64) / max(float(arc[-1]), 1e-12)
        E = np.cos(al)[:, None] * E + np.sin(al)[:, None] * np.cross(R, E)
    return E, np.cross(R, E)


def deviation_axes(ref, e1, e2, du, dv):
    """(k, 3) the reference axes ``ref`` turned by hypot(du, dv) toward du·e1 + dv·e2 (the
    exponential map; all (k, 3) / (k,))."""
    du, dv = np.asarray(du, dtype=np.float64), np.asarray(dv, dtype=np.float64)
    th = np.hypot(du, dv)
    w = du[:, None] * e1 + dv[:, None] * e2
    sc = np.where(th > 1e-12, np.sin(th) / np.maximum(th, 1e-300), 1.0)
    return unit(np.cos(th)[:, None] * ref + sc[:, None] * w, keep_zero=False)


def deviation_of(axes, ref, e1, e2):
    """(u, v) (k,) with :func:`deviation_axes` (ref, e1, e2, u, v) = ``axes`` (the
    logarithmic map; ref, e1, e2 (k, 3) or (3,))."""
    ax = np.asarray(axes, dtype=np.float64)
    c = np.clip(np.einsum("ij,ij->i", ax, np.broadcast_to(ref, ax.shape)), -1.0, 1.0)
    th = np.arccos(c)
    perp = ax - c[:, None] * ref
    sc = np.where(np.sin(th) > 1e-12, th / np.maximum(np.sin(th), 1e-300), 1.0)
    return (sc * np.einsum("ij,ij->i", perp, np.broadcast_to(e1, ax.shape)),
            sc * np.einsum("ij,ij->i", perp, np.broadcast_to(e2, ax.shape)))
