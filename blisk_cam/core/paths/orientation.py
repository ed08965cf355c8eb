"""Tool axis per pose: lead/tilt in the local frame, blisk-axis tilt, fixed axes, smoothing.

Local frame (paper 003 §II, Fig. 1)
-----------------------------------
At every CC point: ``n`` the unit surface normal (out of the material, toward the tool),
``f`` the unit feed direction (the pass direction projected into the tangent plane) and the
side direction ``k = f × n`` (to the right of the feed when the normal points up)::

                 n (up)      a = tool axis (tip → spindle)
                 ^          /
                 |  lead > 0: the spindle leans *forward*, toward the feed f
                 | /
                 |/ lead
       ----------o----------> f (feed)          seen from the side (k into the page)
                CC

                 n
                 ^   a
                 |  /   tilt > 0: the spindle leans to the *right* of the feed, toward
                 | /              k = f × n (looking along f with n up)
                 |/ tilt
       <---------o---------->  k (right)        seen from behind (f into the page)

The axis is ``a = normalize(n + tan(lead) f + tan(tilt) k)``: lead is the angle between n and
a's projection on the (f, n) plane, tilt the angle between n and its projection on the
(k, n) plane, and the inclination between n and a is ``φ = atan(sqrt(tan² lead + tan² tilt))``
(paper 003 Eq. 1; the paper's Eq. for t uses the same tangents with its y_p = n × f = −k, so
its "positive tilt drives the tool to the right" is our ``+k``). |lead|, |tilt| < 90°.

Other strategies (``AxisStrategy.mode``)
---------------------------------------
* ``"local"`` — lead/tilt as above, each constant or linear in the morph ratio s from the
  hub (s = 0) to the tip (s = 1): give ``lead=(lead_hub, lead_tip)``.
* ``"radial"`` — lead as above, and instead of tilt an angle ``radial`` between n and the
  axis toward the outward radial direction of the blisk axis (its projection on the tangent
  plane): ``radial > 0`` leans the spindle *away from* the blisk axis, ``< 0`` toward it.
  Where the normal is itself radial (no tangent component) that term vanishes.
* ``"toward_point"`` / ``"from_point"`` — the axis is the line through the CC point and a
  fixed point P: ``a = normalize(P − cc)`` (spindle toward P) or ``normalize(cc − P)``.
* ``"toward_line"`` / ``"from_line"`` — the same with the nearest point of a fixed line.
  Lead/tilt must be 0 with a fixed axis (they would contradict it).

Smoothing: :func:`smooth_axes` limits the angle between consecutive axes to ``max_turn``
(never flipping: every step is a rotation by less than 90°); where the surface turns faster
than the limit allows, the deviation is centred on the turn (half before, half after) rather
than lagging behind it. Zero cutting speed: :func:`zero_speed_mask`.

Angles are radians, lengths mm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import OrientationError
from ..geometry.axis import Axis
from ..geometry.vectors import unit

__all__ = [
    "AXIS_MODES",
    "AxisStrategy",
    "OrientationError",
    "axes_for_curve",
    "consecutive_turn",
    "feed_directions",
    "lead_tilt_axes",
    "lead_tilt_of",
    "local_frames",
    "smooth_axes",
    "zero_speed_mask",
]

AXIS_MODES = ("local", "radial", "toward_point", "from_point", "toward_line", "from_line")
#: largest |lead|, |tilt|, |radial| accepted (just below 90°: at 90° the tool lies on the surface)
MAX_ANGLE = math.radians(89.0)


def _as_range(name, value):
    """(hub, tip) radians from a scalar or a pair; refuses NaN and |angle| ≥ 89°."""
    if np.ndim(value) == 0:
        pair = (float(value), float(value))
    else:
        vals = [float(x) for x in np.asarray(value, dtype=np.float64).ravel()]
        if len(vals) != 2:
            raise OrientationError(f"{name} must be one angle or a (hub, tip) pair, got {value!r}")
        pair = (vals[0], vals[1])
    for x in pair:
        if not math.isfinite(x):
            raise OrientationError(f"{name} is not a number ({value!r}); give an angle in radians")
        if abs(x) > MAX_ANGLE:
            raise OrientationError(
                f"{name} = {math.degrees(x):.1f}° is not below 89° in magnitude: "
                "the tool would lie "
                f"on or behind the surface; use an angle between −89° and 89° (typically 0–15°)"
            )
    return pair


@dataclass(frozen=True)
class AxisStrategy:
    """How the tool axis is chosen (see the module docstring for the conventions).

    Attributes
    ----------
    mode : one of ``AXIS_MODES``
    lead, tilt : float or (hub, tip) pair, radians — linear in s between hub and tip
    radial : float or (hub, tip), radians — mode "radial": > 0 away from the blisk axis
    point : (3,) mm — the fixed point (``*_point``) or a point of the fixed line (``*_line``)
    direction : (3,) — the fixed line's direction (``*_line``)
    max_turn : float, radians, or None — smoothing: largest angle between consecutive axes
    """

    mode: str = "local"
    lead: float | tuple = 0.0
    tilt: float | tuple = 0.0
    radial: float | tuple = 0.0
    point: tuple | None = None
    direction: tuple | None = None
    max_turn: float | None = None

    def __post_init__(self):
        if self.mode not in AXIS_MODES:
            raise OrientationError(
                f"unknown tool-axis mode {self.mode!r}; use one of {', '.join(AXIS_MODES)}"
            )
        lead = _as_range("lead", self.lead)
        tilt = _as_range("tilt", self.tilt)
        radial = _as_range("radial tilt", self.radial)
        fixed = self.mode.endswith(("_point", "_line"))
        if fixed and any(x != 0.0 for x in lead + tilt + radial):
            raise OrientationError(
                f"tool-axis mode {self.mode!r} fixes the axis through a point or line; lead, tilt "
                "and radial tilt would contradict it: set them to 0 or use mode 'local'"
            )
        if self.mode == "radial" and any(x != 0.0 for x in tilt):
            raise OrientationError(
                "mode 'radial' replaces tilt by the radial tilt; set tilt to 0 or use mode 'local'"
            )
        if self.mode == "local" and any(x != 0.0 for x in radial):
            raise OrientationError(
                "radial tilt needs mode 'radial'; set it to 0 or change the mode"
            )
        if fixed:
            if (
                self.point is None
                or not np.all(np.isfinite(np.asarray(self.point, float)))
                or np.asarray(self.point, float).shape != (3,)
            ):
                raise OrientationError(f"mode {self.mode!r} needs a finite 3-D point (mm)")
            if self.mode.endswith("_line"):
                d = np.asarray(
                    self.direction if self.direction is not None else (np.nan,) * 3, float
                )
                if d.shape != (3,) or not np.all(np.isfinite(d)) or np.linalg.norm(d) < 1e-12:
                    raise OrientationError(f"mode {self.mode!r} needs a non-zero line direction")
        if self.max_turn is not None:
            m = float(self.max_turn)
            if not (math.isfinite(m) and 0.0 < m < math.pi / 2):
                raise OrientationError(
                    f"axis smoothing limit {self.max_turn!r} rad must lie in (0, 90°); "
                    "e.g. 2° per pose (0.035 rad), or None for no smoothing"
                )
        object.__setattr__(self, "lead", lead)
        object.__setattr__(self, "tilt", tilt)
        object.__setattr__(self, "radial", radial)

    @property
    def has_inclination(self) -> bool:
        """True when the axis is meant to differ from the normal (non-zero lead/tilt/radial)."""
        return any(x != 0.0 for x in self.lead + self.tilt + self.radial) or self.mode != "local"

    def at(self, which: str, s):
        """(k,) angle ``which`` ('lead', 'tilt', 'radial') at morph ratios ``s`` (clipped to
        [0, 1])."""
        lo, hi = getattr(self, which)
        s = np.clip(np.asarray(s, dtype=np.float64), 0.0, 1.0)
        return lo + s * (hi - lo)

    def angle_bounds(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """((lead_min, lead_max), (tilt_min, tilt_max)) over the path (radial counts as tilt)."""
        lead = (min(self.lead), max(self.lead))
        t = self.tilt if self.mode != "radial" else self.radial
        return lead, (min(t), max(t))


# ============================================================================ local frame
def feed_directions(cc, normal, closed: bool):
    """Unit feed directions f (k, 3): the pass tangent (central differences; one-sided at the
    ends of an open pass) projected into the tangent plane of the unit ``normal`` (k, 3).

    A pose whose neighbours coincide with it (zero tangent) gets the nearest defined one."""
    P = np.asarray(cc, dtype=np.float64)
    N = unit(np.asarray(normal, dtype=np.float64))
    k = len(P)
    if k < 2:
        raise OrientationError("a pass needs at least two CC points to define a feed direction")
    if closed and k > 2:
        t = np.roll(P, -1, axis=0) - np.roll(P, 1, axis=0)
    else:
        t = np.empty_like(P)
        t[1:-1] = P[2:] - P[:-2]
        t[0] = P[1] - P[0]
        t[-1] = P[-1] - P[-2]
    t = t - np.einsum("ij,ij->i", t, N)[:, None] * N
    ln = np.linalg.norm(t, axis=1)
    bad = ln <= 1e-12 * max(1.0, float(np.abs(P).max()))
    if np.all(bad):
        raise OrientationError("the pass has no length (all CC points coincide); no feed direction")
    if np.any(bad):
        good = np.nonzero(~bad)[0]
        near = good[np.clip(np.searchsorted(good, np.arange(k)), 0, len(good) - 1)]
        t[bad] = t[near[bad]]
        t = t - np.einsum("ij,ij->i", t, N)[:, None] * N
        ln = np.linalg.norm(t, axis=1)
    return t / np.where(ln > 0, ln, 1.0)[:, None]


def local_frames(cc, normal, closed: bool):
    """(f, n, k), each (k, 3) unit: feed, normal, side ``k = f × n``."""
    n = unit(np.asarray(normal, dtype=np.float64))
    f = feed_directions(cc, n, closed)
    return f, n, np.cross(f, n)


def lead_tilt_axes(f, n, k, lead, tilt):
    """Unit tool axes ``normalize(n + tan(lead) f + tan(tilt) k)`` (k, 3); lead/tilt (k,) or
    scalar."""
    tl = np.tan(np.asarray(lead, dtype=np.float64))
    tt = np.tan(np.asarray(tilt, dtype=np.float64))
    a = n + np.atleast_1d(tl)[..., None] * f + np.atleast_1d(tt)[..., None] * k
    return unit(a)


def lead_tilt_of(axis, f, n, k):
    """Inverse of :func:`lead_tilt_axes`: (lead, tilt) (k,) radians of unit axes in frames f, n, k.

    Only defined where ``axis · n > 0`` (NaN elsewhere)."""
    a = np.asarray(axis, dtype=np.float64)
    an = np.einsum("ij,ij->i", a, n)
    with np.errstate(divide="ignore", invalid="ignore"):
        lead = np.where(an > 0, np.arctan(np.einsum("ij,ij->i", a, f) / an), np.nan)
        tilt = np.where(an > 0, np.arctan(np.einsum("ij,ij->i", a, k) / an), np.nan)
    return lead, tilt


def axes_for_curve(
    cc, normal, closed: bool, s, strategy: AxisStrategy, blisk_axis: Axis | None = None
):
    """Tool axes (k, 3) of one pass before smoothing.

    Parameters
    ----------
    cc, normal : (k, 3) — CC points (mm) and unit normals, in machining order
    closed : bool
    s : float or (k,) — morph ratio of each pose (for lead/tilt varying hub → tip)
    strategy : AxisStrategy
    blisk_axis : Axis — needed by mode "radial"

    Raises
    ------
    OrientationError where a fixed axis would reach a pose from behind the surface.
    """
    cc = np.asarray(cc, dtype=np.float64)
    f, n, k = local_frames(cc, normal, closed)
    s = np.broadcast_to(np.asarray(s, dtype=np.float64), (len(cc),))
    mode = strategy.mode
    if mode == "local":
        return lead_tilt_axes(f, n, k, strategy.at("lead", s), strategy.at("tilt", s))
    if mode == "radial":
        if blisk_axis is None:
            raise OrientationError("mode 'radial' needs the blisk axis")
        d = blisk_axis.d
        rel = cc - blisk_axis.o
        er = rel - (rel @ d)[:, None] * d
        w = er - np.einsum("ij,ij->i", er, n)[:, None] * n
        lw = np.linalg.norm(w, axis=1)
        w = np.where(
            (lw > 1e-9 * np.maximum(np.linalg.norm(er, axis=1), 1.0))[:, None],
            w / np.where(lw > 0, lw, 1.0)[:, None],
            0.0,
        )
        a = (
            n
            + np.tan(strategy.at("lead", s))[:, None] * f
            + np.tan(strategy.at("radial", s))[:, None] * w
        )
        return unit(a)
    P = np.asarray(strategy.point, dtype=np.float64)
    if mode.endswith("_line"):
        d = unit(np.asarray(strategy.direction, dtype=np.float64))
        rel = cc - P
        target = P + (rel @ d)[:, None] * d
    else:
        target = np.broadcast_to(P, cc.shape)
    a = target - cc if mode.startswith("toward") else cc - target
    ln = np.linalg.norm(a, axis=1)
    if np.any(ln < 1e-9):
        raise OrientationError(
            f"mode {mode!r}: a CC point lies on the fixed {mode.split('_')[1]}; "
            "the axis through it "
            "is undefined — move the point/line off the blade"
        )
    a = a / ln[:, None]
    behind = np.einsum("ij,ij->i", a, n) <= math.cos(MAX_ANGLE)
    if np.any(behind):
        raise OrientationError(
            f"mode {mode!r}: at {int(behind.sum())} of {len(cc)} poses the fixed axis reaches the "
            "surface from behind or at ≥ 89° to the normal (e.g. the other blade side); use a "
            "fixed point/line only for surfaces that face it, or mode 'local'"
        )
    return a


# ============================================================================ smoothing
def consecutive_turn(axes, closed: bool):
    """(k−1,) or, closed, (k,) angles (radians) between consecutive unit axes (the closing
    pair last)."""
    a = unit(np.asarray(axes, dtype=np.float64))
    b = np.roll(a, -1, axis=0) if closed and len(a) > 2 else a[1:]
    a = a if closed and len(a) > 2 else a[:-1]
    return np.arccos(np.clip(np.einsum("ij,ij->i", a, b), -1.0, 1.0))


def clamp_turn(ref, want, delta, hint):
    """``want`` turned toward ``ref`` until it is within ``delta`` of it (tuples of 3 floats).
    ``hint`` picks the rotation plane when ``want`` is opposite to ``ref``."""
    c = ref[0] * want[0] + ref[1] * want[1] + ref[2] * want[2]
    c = -1.0 if c < -1.0 else (1.0 if c > 1.0 else c)
    th = math.acos(c)
    if th <= delta:
        return want
    s = math.sin(th)
    if s > 1e-9:
        wa = math.sin(th - delta) / s
        wb = math.sin(delta) / s
        v = (wa * ref[0] + wb * want[0], wa * ref[1] + wb * want[1], wa * ref[2] + wb * want[2])
    else:  # opposite: rotate ref by delta in the plane of (ref, hint)
        hd = hint[0] * ref[0] + hint[1] * ref[1] + hint[2] * ref[2]
        u = (hint[0] - hd * ref[0], hint[1] - hd * ref[1], hint[2] - hd * ref[2])
        lu = math.sqrt(u[0] ** 2 + u[1] ** 2 + u[2] ** 2)
        if lu < 1e-12:
            u = (ref[1], -ref[0], 0.0) if abs(ref[2]) < 0.9 else (0.0, ref[2], -ref[1])
            lu = math.sqrt(u[0] ** 2 + u[1] ** 2 + u[2] ** 2)
        cd, sd = math.cos(delta), math.sin(delta)
        v = tuple(cd * ref[i] + sd * u[i] / lu for i in range(3))
    ln = math.sqrt(v[0] ** 2 + v[1] ** 2 + v[2] ** 2)
    return (v[0] / ln, v[1] / ln, v[2] / ln)


def _clamp_sweeps(want, hint, delta: float, closed: bool):
    """One forward and one backward clamp sweep (lists of 3-tuples in, list out).

    A forward pass turns each axis toward its predecessor until within ``delta``, a backward
    pass does the same toward the successor; closed passes repeat the backward sweep around
    the loop until the closing pair holds. The result *lags*: where the wanted axis turns
    faster than ``delta`` per pose the whole deficit ends up on one side of the turn."""
    k = len(want)
    out = list(want)
    for i in range(1, k):
        out[i] = clamp_turn(out[i - 1], want[i], delta, hint[i])
    for i in range(k - 2, -1, -1):
        out[i] = clamp_turn(out[i + 1], out[i], delta, hint[i])
    if closed and k > 2:
        for _ in range(8 * k):
            turn = consecutive_turn(np.asarray(out), True)
            if np.all(turn <= delta * (1 + 1e-9)):
                break
            j = int(np.argmax(turn))  # the pair (j, j+1) breaks: sweep backward from j
            for step in range(k - 1):
                i = (j - step) % k
                out[i] = clamp_turn(out[(i + 1) % k], out[i], delta, hint[i])
    return out


def _centred_smoothing(A, N, delta: float, closed: bool):
    """(k, 3) unit axes within ``delta`` of their neighbours, the deficit centred on the turn.

    The clamp sweeps run forward-then-backward (the axis lags behind a fast turn of the
    surface) and, on the reversed pass, backward-then-forward (it anticipates the turn); their
    normalised mean splits the deviation evenly before and after the turn (in one dimension,
    a ramp of slope σ > δ over an angle Θ: the lag is Θ (1 − δ/σ) at one end for either sweep,
    half of it at both ends for the mean — a mean of two δ-Lipschitz sequences is δ-Lipschitz).
    On the sphere the mean is only nearly within the limit, so a last clamp sweep enforces it.
    """
    want = [tuple(x) for x in A.tolist()]
    hint = [tuple(x) for x in N.tolist()]
    fwd = np.asarray(_clamp_sweeps(want, hint, delta, closed))
    bwd = np.asarray(_clamp_sweeps(want[::-1], hint[::-1], delta, closed))[::-1]
    both = fwd + bwd  # the bisector of the two (undefined only where they are opposite)
    mid = np.where((np.linalg.norm(both, axis=1) > 1e-3)[:, None], unit(both), fwd)
    return np.asarray(_clamp_sweeps([tuple(x) for x in mid.tolist()], hint, delta, closed))


def smooth_axes(axes, normals, max_turn: float, closed: bool = False):
    """Limit the angle between consecutive tool axes to ``max_turn`` (radians).

    Clamp sweeps turn each axis toward its neighbours until every consecutive pair is within
    the limit (every change is a rotation by less than 90° toward a neighbour, so the axis
    never flips); where the surface turns faster than the limit allows (around a thin edge)
    the deviation from the wanted axis is split evenly before and after the turn
    (:func:`_centred_smoothing`) instead of lagging behind it — a lagging axis carries the whole
    deficit on one side of the turn, a centred one half of it on each side (issue #4: the lag
    put the tool ≥ 89° from the normal around the demo blade's edges). The sweeps loop over
    poses in Python; they only run on passes that exceed the limit.

    Parameters
    ----------
    axes : (k, 3) unit — wanted axes
    normals : (k, 3) unit — surface normals (rotation plane when two axes are opposite, and the
        check that the smoothed axis still reaches the surface from the tool side)
    max_turn : float, radians in (0, π/2)
    closed : bool

    Returns
    -------
    (k, 3) unit axes

    Raises
    ------
    OrientationError where the smoothed axis would lie ≥ 89° from the normal (the limit is
    too tight for how fast the surface turns per pose); the message gives the smallest limit
    that works on this pass.
    """
    A = unit(np.asarray(axes, dtype=np.float64)).copy()
    N = unit(np.asarray(normals, dtype=np.float64))
    delta = float(max_turn)
    if not (math.isfinite(delta) and 0.0 < delta < math.pi / 2):
        raise OrientationError(f"axis smoothing limit {max_turn!r} rad must lie in (0, 90°)")
    k = len(A)
    if k < 2 or np.all(consecutive_turn(A, closed) <= delta):
        return A
    out = _centred_smoothing(A, N, delta, closed)
    if np.any(consecutive_turn(out, closed) > delta * (1 + 1e-9)):  # pragma: no cover - guard
        raise OrientationError("axis smoothing did not converge; raise the smoothing limit")
    bad = np.einsum("ij,ij->i", out, N) <= math.cos(MAX_ANGLE)
    if np.any(bad):
        need = _smallest_feasible_limit(A, N, delta, closed)
        raise OrientationError(
            f"axis smoothing to {math.degrees(delta):.2f}° per pose leaves the tool ≥ 89° from the "
            f"normal at {int(bad.sum())} of {k} poses (the surface turns by up to "
            f"{math.degrees(consecutive_turn(N, closed).max()):.1f}° per pose there, e.g. around "
            f"a thin edge); raise the smoothing limit to at least {math.degrees(need):.2f}° "
            "or switch smoothing off"
        )
    return out


def _smallest_feasible_limit(A, N, delta: float, closed: bool) -> float:
    """Smallest limit (radians, to 1 %) above ``delta`` for which :func:`_centred_smoothing`
    keeps every axis below 89° from its normal (bisection; at most the largest wanted turn)."""

    def ok(d):
        out = _centred_smoothing(A, N, d, closed)
        return bool(np.all(np.einsum("ij,ij->i", out, N) > math.cos(MAX_ANGLE)))

    lo, hi = delta, max(float(consecutive_turn(A, closed).max()), delta)
    hi = min(hi, math.pi / 2 - 1e-6)
    if not ok(hi):
        return hi
    while hi - lo > 0.01 * hi:
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if ok(mid) else (mid, hi)
    return hi


# ============================================================================ zero speed
def zero_speed_mask(normal, axis, tol: float = math.radians(1.0)):
    """(k,) bool: the axis within ``tol`` radians of the normal — a ball or bull-nose tool then
    touches at (or, for a bull nose, across) its tip where the cutting speed is zero (paper 003
    §I). Cutters with their own rule provide ``zero_speed`` (see :mod:`..tool.cutter`)."""
    c = np.einsum("ij,ij->i", unit(np.asarray(normal, float)), unit(np.asarray(axis, float)))
    return c >= math.cos(tol)
