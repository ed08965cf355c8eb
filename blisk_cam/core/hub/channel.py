"""The channel between two blades at the hub and its boundary-conformed passes (paper 003
§5, Figs. 8–10: hub finishing from the leading to the trailing edge between blade i's one
side and blade i+1's other side).

Geometry, in the hub's (m, θ) parameters (:class:`.surface.HubSurface`):

* **Root loop.** Blade 0's boundary loop nearest the hub: where the blade (with its fillet)
  meets the hub. Its meridional extent is [m_LE, m_TE].
* **Clearance boundaries.** At each meridional station m the ball (radius ρ) touching the hub
  at S(m, θ) has its centre at C = S + ρ n. Walking θ from blade 0 toward blade 1 (blade 0
  turned by the pitch), θ_A(m) is the last angle where C comes closer than ρ + allowance to
  blade 0 (signed distance to the blade mesh, so a centre inside the blade counts as close),
  θ_B(m) the first where it comes that close to blade 1; each refined by bisection. Where the
  blade has a fillet the ball stops where it touches it — the boundary follows the fillet's
  edge (hub side) for a ball smaller than the fillet, or the ball touching the fillet for a
  larger one — and always keeps ρ + allowance from the blade surface.
* **Leading and trailing edges.** Around the edges the boundary wraps the nose; from
  ``nose`` mm inside the chord outward each boundary is the straight continuation
  (tangent, fitted in the developed plane over the next few mm) of its side, kept clear of
  the nose (θ_A = max(tangent, θ_A) on blade 0's side, min on blade 1's), and extended past
  the edges by the user's length.
* **Passes.** Pass t ∈ [0, 1] is θ_t(m) = (1 − t) θ_A(m) + t θ_B(m) (the first pass follows
  blade 0's boundary, the last blade 1's: boundary-conformed like the LMC layers on the
  blade, paper 001). The ratios are spaced per region (the main hub and the ring of
  ``ring_width`` mm beside each blade, paper 003 Fig. 10) so that the distance between
  neighbouring passes, r Δt (θ_B − θ_A) |cos β| (β the pass's angle from the meridian), never
  exceeds the region's stepover or the stepover that leaves its scallop height on the hub's
  normal curvature across the passes (:func:`.surface.stepover_for_scallop`).

Units mm and radians.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import ToleranceError, ToolError
from ..geometry.distance import MeshDistance
from ..geometry.mesh import TriMesh
from ..runtime import Progress
from .surface import HubSurface, stepover_for_scallop

__all__ = ["Channel", "Region", "TipChannel", "channel_boundaries", "chord_indices",
           "pass_ratios", "root_loop", "sample_pass", "side_distance"]

#: θ samples across one pitch when searching the clearance boundaries: every quarter ball
#: radius of arc at the hub, within these bounds
_THETA_SAMPLES = (32, 400)
_BISECT = 24
#: extra clearance of the boundaries, mm (beside the interpolation's sagitta)
_MARGIN = 0.005


def root_loop(blade: TriMesh, hub: HubSurface) -> np.ndarray:
    """(k, 3) the blade's boundary loop nearest the hub (its root: where blade or fillet meets
    the hub), mm. ToleranceError when the blade mesh has no open boundary."""
    loops = [lp for lp in blade.boundary_loops() if len(lp) >= 3]
    if not loops:
        raise ToleranceError("the blade mesh has no open boundary loop at the hub (a closed "
                             "mesh?): hub and fillet finishing need the blade's root loop; "
                             "give the blade open at the hub")
    best = min(loops, key=lambda lp: float(np.mean(np.abs(hub.coordinates(blade.V[lp])[2]))))
    return blade.V[best]


@dataclass(frozen=True)
class Region:
    """One hub region's spacing: ``stepover`` mm, or ``scallop`` mm (the stepover then follows
    the hub curvature). Exactly one is set."""

    stepover: float | None = None
    scallop: float | None = None

    def width(self, rho: float, kappa) -> np.ndarray:
        """(k,) the largest distance between passes (mm) at normal curvatures ``kappa``."""
        if self.stepover is not None:
            return np.full(np.shape(kappa), float(self.stepover))
        return stepover_for_scallop(rho, float(self.scallop), kappa)


@dataclass
class Channel:
    """The channel at the hub between blade 0 and blade 1.

    Attributes
    ----------
    hub : HubSurface
    m : (s,) float — meridional stations, mm (the passes' extent, extension included)
    theta_a, theta_b : (s,) float, rad — boundaries on blade 0's and blade 1's side
    m_le, m_te : float — the blade root's meridional extent, mm
    rho, allowance : float — ball radius and the distance kept from the blades, mm
    clipped : bool — the extension was cut at the end of the hub profile
    min_width : float — the narrowest developed width r (θ_B − θ_A) between the boundaries
        (the room the ball centre has), mm; min_width_m its station
    notes : list of str — for the user
    """

    hub: HubSurface
    m: np.ndarray
    theta_a: np.ndarray
    theta_b: np.ndarray
    m_le: float
    m_te: float
    rho: float
    allowance: float
    clipped: bool = False
    min_width: float = 0.0
    min_width_m: float = 0.0
    notes: list = field(default_factory=list)

    def theta(self, t) -> np.ndarray:
        """(s,) θ of pass ratio ``t`` at the stations."""
        return self.theta_a + float(t) * (self.theta_b - self.theta_a)

    def width(self) -> np.ndarray:
        """(s,) developed width r (θ_B − θ_A), mm."""
        return self.hub.rz(self.m)[:, 0] * (self.theta_b - self.theta_a)


def _circ_mean(th):
    return math.atan2(float(np.sin(th).mean()), float(np.cos(th).mean()))


def _wrap(x):
    return np.mod(x + math.pi, 2.0 * math.pi) - math.pi


def _chains(m, th):
    """The loop split at its meridional extremes (LE, TE) into two chains, each as
    (m increasing, θ) arrays: (upper side, lower side) by mean θ."""
    i_le, i_te = int(np.argmin(m)), int(np.argmax(m))
    k = len(m)
    a = (np.arange(i_le, i_le + ((i_te - i_le) % k) + 1) % k)
    b = (np.arange(i_te, i_te + ((i_le - i_te) % k) + 1) % k)[::-1]
    out = []
    for idx in (a, b):
        mm, tt = m[idx], th[idx]
        order = np.argsort(mm, kind="stable")
        mm, tt = mm[order], tt[order]
        keep = np.concatenate([[True], np.diff(mm) > 1e-9])
        out.append((mm[keep], tt[keep]))
    if np.mean(out[0][1]) < np.mean(out[1][1]):
        out = out[::-1]
    return out[0], out[1]


def side_distance(q) -> np.ndarray:
    """(k,) the distance of :class:`~..geometry.closest.ClosestPoints` ``q``, negative where
    the point lies inside the material by a face's own normal (the nearest point inside a
    face); a nearest point on an edge or corner (the open root loop) gives no reliable side
    and reads as outside."""
    inside = (q.feature == 0) & (q.sign < 0)
    return np.where(inside, -q.distance, q.distance)


class _Clearance:
    """Signed distance of ball centres above hub points to blade 0 and to blade 1."""

    def __init__(self, blade: TriMesh, hub: HubSurface, pitch: float, rho: float):
        self.dist = MeshDistance(blade)
        self.hub, self.pitch, self.rho = hub, pitch, rho

    def centres(self, m, th, height=None):
        h = self.rho if height is None else height
        return self.hub.point(m, th) + np.asarray(h)[..., None] * self.hub.normal(m, th)

    def signed(self, m, th, blade: int, height=None) -> np.ndarray:
        """Distance of the centres to the blade, negative inside it (:func:`side_distance`)."""
        c = self.centres(m, np.asarray(th) - blade * self.pitch, height)
        return side_distance(self.dist.query(c))


def _boundary(clear: _Clearance, m, th_grid, blade: int, target: float, last: bool):
    """(s,) θ per station where the clearance to ``blade`` crosses ``target`` (NaN where the
    ball never comes that close): the last close sample (blade 0) or the first (blade 1),
    refined by bisection toward the next sample."""
    s, J = th_grid.shape
    d = clear.signed(np.repeat(m, J), th_grid.ravel(), blade).reshape(s, J)
    close = d < target
    has = close.any(axis=1)
    if last:
        j = J - 1 - np.argmax(close[:, ::-1], axis=1)
        nxt = np.minimum(j + 1, J - 1)
    else:
        j = np.argmax(close, axis=1)
        nxt = np.maximum(j - 1, 0)
    rows = np.arange(s)
    lo, hi = th_grid[rows, j], th_grid[rows, nxt]  # lo: close, hi: clear
    for _ in range(_BISECT):
        mid = 0.5 * (lo + hi)
        c = clear.signed(m, mid, blade) < target
        lo, hi = np.where(c, mid, lo), np.where(c, hi, mid)
    return np.where(has, hi, np.nan)


def _repaired(clear: _Clearance, m, th_a, th_b, target: float):
    """The boundaries moved toward the channel's middle where their ball still comes closer
    than ``target`` to its blade (a nose the θ samples stepped over, a tangent continuation
    passing an edge): bisection between the boundary and the middle, per station."""
    mid = 0.5 * (th_a + th_b)
    out = []
    for th, blade in ((th_a, 0), (th_b, 1)):
        bad = clear.signed(m, th, blade) < target
        if bad.any():
            lo, hi = th[bad].copy(), mid[bad].copy()  # lo close, hi (the middle) clear or not
            for _ in range(_BISECT):
                c = 0.5 * (lo + hi)
                close = clear.signed(m[bad], c, blade) < target
                lo, hi = np.where(close, c, lo), np.where(close, hi, c)
            th = th.copy()
            th[bad] = hi
        out.append(th)
    return out[0], out[1]


def _tangent_line(m, th, r, lo, hi):
    """Slope and intercept of θ(m) fitted in the developed plane (r θ) over stations
    [lo, hi] (r held at the mean radius there); None when fewer than two stations."""
    sel = (m >= lo) & (m <= hi) & np.isfinite(th)
    if sel.sum() < 2:
        return None
    rr = float(np.mean(r[sel]))
    A = np.stack([m[sel], np.ones(int(sel.sum()))], 1)
    coef, *_ = np.linalg.lstsq(A, rr * th[sel], rcond=None)
    return coef / rr


def channel_boundaries(blade: TriMesh, hub: HubSurface, pitch: float, rho: float, *,
                       allowance: float = 0.0, extend: float = 5.0, step: float = 0.5,
                       fine: float = 0.1, nose: float | None = None, tool_name: str = "ball"):
    """Generator: the :class:`Channel` between blade 0 and blade 1 (blade 0 turned by
    ``pitch`` rad) for a ball of radius ``rho`` mm keeping ``allowance`` mm from the blades,
    the passes extended ``extend`` mm past the leading and trailing edges; the boundaries
    searched at stations ``step`` mm apart, then interpolated onto stations ``fine`` mm apart
    and checked (and moved clear) there. Yields Progress, returns the Channel.

    Raises
    ------
    ToolError — the ball does not fit the gap at the hub (the clearance boundaries cross),
        naming the narrowest gap and the ball
    """
    loop = root_loop(blade, hub)
    m_l, th_l, _ = hub.coordinates(loop)
    th0 = _circ_mean(th_l)
    th_l = th0 + _wrap(th_l - th0)
    m_le, m_te = float(m_l.min()), float(m_l.max())
    chord = m_te - m_le
    # 5 µm more, so that the passes between the fine stations (θ interpolated) keep it too
    target = rho + allowance + _MARGIN
    notes = []
    lo_m, hi_m = m_le - extend, m_te + extend
    clipped = False
    if lo_m < 0.0 or hi_m > hub.length:
        clipped = True
        notes.append(f"the extension past the edges was cut at the end of the hub profile "
                     f"(asked {extend:g} mm; the profile reaches {m_le - max(lo_m, 0.0):.1f} mm "
                     f"before the leading edge and {min(hi_m, hub.length) - m_te:.1f} mm past "
                     "the trailing edge): give a longer hub profile to extend further")
        lo_m, hi_m = max(lo_m, 0.0), min(hi_m, hub.length)
    n = max(8, int(math.ceil((hi_m - lo_m) / step)) + 1)
    m = np.linspace(lo_m, hi_m, n)
    (mu, tu), (ml, tl) = _chains(m_l, th_l)
    mid = 0.5 * (np.interp(m, mu, tu) + np.interp(m, ml, tl))
    r_hub = float(np.max(hub.rz(m)[:, 0]))
    J = int(np.clip(math.ceil(pitch * r_hub / (0.25 * rho)), *_THETA_SAMPLES))
    grid = mid[:, None] + pitch * (np.arange(J + 1) / J)[None, :]
    clear = _Clearance(blade, hub, pitch, rho)
    yield Progress(0.1, "hub: the ball's clearance from blade 0")
    th_a = _boundary(clear, m, grid, 0, target, last=True)
    yield Progress(0.5, "hub: the ball's clearance from blade 1")
    th_b = _boundary(clear, m, grid, 1, target, last=False)
    yield Progress(0.9, "hub: the channel's ends")
    r = hub.rz(m)[:, 0]
    both = np.isfinite(th_a) & np.isfinite(th_b)
    width = r * (th_b - th_a)
    crossed = both & (width <= 0.0)
    inside = (m >= m_le) & (m <= m_te)
    if crossed.any() or (inside & ~both).any():
        bad = crossed | (inside & ~both)
        i = int(np.flatnonzero(bad)[0])
        z = float(hub.rz(m[i:i + 1])[0, 1])
        raise ToolError(f"the {tool_name} (radius {rho:g} mm + {allowance:g} mm allowance) does "
                        f"not fit the gap between the blades at the hub: at z = {z:.2f} mm "
                        f"(m = {m[i]:.2f} mm along the hub) the ball touching the hub cannot "
                        f"keep {target:g} mm from both blades; use a smaller ball")
    # the edges: straight continuations of the sides beyond ``nose`` mm inside the chord
    nose = float(nose) if nose is not None else max(2.0 * target, 0.08 * chord)
    nose = min(nose, 0.3 * chord)
    fit = max(3.0, 0.1 * chord)
    out = []
    for th, lo_side in ((th_a, True), (th_b, False)):
        th = th.copy()
        for end in ("le", "te"):
            if end == "le":
                a_, b_ = m_le + nose, m_le + nose + fit
                region = m < a_
            else:
                a_, b_ = m_te - nose - fit, m_te - nose
                region = m > b_
            coef = _tangent_line(m, th, r, a_, b_)
            if coef is None:
                continue
            line = coef[0] * m[region] + coef[1]
            old = th[region]
            th[region] = np.where(np.isfinite(old),
                                  np.maximum(line, old) if lo_side else np.minimum(line, old),
                                  line)
        out.append(th)
    th_a, th_b = out
    if not (np.all(np.isfinite(th_a)) and np.all(np.isfinite(th_b))):
        raise ToolError(f"the channel between the blades at the hub could not be traced for the "
                        f"{tool_name} (radius {rho:g} mm): check the blade count and the hub "
                        "profile")
    # the passes' own stations (``fine`` mm apart): the boundaries interpolated onto them and
    # repaired there, so every CC point of the first and last pass keeps the clearance
    nf = max(len(m), int(math.ceil((m[-1] - m[0]) / fine)) + 1)
    mf = np.linspace(m[0], m[-1], nf)
    th_a, th_b = np.interp(mf, m, th_a), np.interp(mf, m, th_b)
    m, r = mf, hub.rz(mf)[:, 0]
    th_a, th_b = _repaired(clear, m, th_a, th_b, target)
    width = r * (th_b - th_a)
    if np.any(width <= 0):
        i = int(np.argmin(width))
        raise ToolError(f"the {tool_name} (radius {rho:g} mm + {allowance:g} mm allowance) does "
                        f"not fit the gap between the blades at the hub near m = {m[i]:.2f} mm "
                        "(the boundaries beside the two blades cross); use a smaller ball or a "
                        "shorter extension")
    i = int(np.argmin(width))
    return Channel(hub, m, th_a, th_b, m_le, m_te, rho, allowance, clipped,
                   float(width[i]), float(m[i]), notes)


def pass_ratios(ch: Channel, main: Region, ring: Region | None = None,
                ring_width: float = 0.0) -> np.ndarray:
    """(p,) pass ratios t in [0, 1], increasing, 0 and 1 included: the main region spaced by
    ``main``; with ``ring_width`` > 0 the bands of that width (mm, at the narrowest point)
    beside each blade spaced by ``ring`` (paper 003 Fig. 10)."""
    hub, m = ch.hub, ch.m
    r = hub.rz(m)[:, 0]
    dth = ch.theta_b - ch.theta_a
    dm = np.gradient(m)

    def need(t0, t1, region: Region) -> int:
        worst = 0.0
        for t in np.linspace(t0, t1, 7):
            th = ch.theta_a + t * dth
            beta = np.arctan2(r * np.gradient(th), dm)  # pass angle from the meridian
            sep = r * np.abs(dth) * np.abs(np.cos(beta))  # ⊥ distance per unit t
            kappa = hub.normal_curvature(m, beta + 0.5 * math.pi)
            w = region.width(ch.rho, kappa)
            if np.any(w <= 0):
                raise ToleranceError("the hub curves tighter than the ball across the passes "
                                     "(a concave hub radius ≤ the ball radius); use a "
                                     "smaller ball")
            worst = max(worst, float(np.max(sep / w)))
        return max(1, int(math.ceil((t1 - t0) * worst - 1e-9)))

    if ring is None or ring_width <= 0.0:
        return np.linspace(0.0, 1.0, need(0.0, 1.0, main) + 1)
    tr = min(0.5, float(ring_width) / max(ch.min_width, 1e-9))
    if tr >= 0.5:
        return np.linspace(0.0, 1.0, need(0.0, 1.0, ring) + 1)
    n_ring = need(0.0, tr, ring)
    n_main = need(tr, 1.0 - tr, main)
    n_ring2 = need(1.0 - tr, 1.0, ring)
    return np.unique(np.concatenate([np.linspace(0.0, tr, n_ring + 1),
                                     np.linspace(tr, 1.0 - tr, n_main + 1),
                                     np.linspace(1.0 - tr, 1.0, n_ring2 + 1)]))


def chord_indices(P, chord: float, max_step: float) -> np.ndarray:
    """Indices into the dense polyline ``P`` (k, 3) of the points to keep so that every
    dropped point lies within ``chord`` mm of the segment that replaces it and no segment is
    longer than ``max_step`` mm (greedy, longest step first by bisection)."""
    k = len(P)
    keep = [0]
    i = 0
    seg = np.linalg.norm(np.diff(P, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])

    def ok(i, j):
        if s[j] - s[i] > max_step + 1e-12:
            return False
        if j <= i + 1:
            return True
        a, b = P[i], P[j]
        ab = b - a
        L2 = float(ab @ ab)
        q = P[i + 1:j] - a
        t = np.clip(q @ ab / max(L2, 1e-300), 0.0, 1.0)
        dev = np.linalg.norm(q - t[:, None] * ab, axis=1)
        return bool(dev.max() <= chord)

    while i < k - 1:
        lo, hi = i + 1, k - 1
        if ok(i, hi):
            j = hi
        else:
            while hi - lo > 1:
                mid = (lo + hi) // 2
                if ok(i, mid):
                    lo = mid
                else:
                    hi = mid
            j = lo
        keep.append(j)
        i = j
    return np.asarray(keep, dtype=np.int64)


def sample_pass(ch: Channel, t: float, chord: float, max_step: float = 2.0,
                dense: float = 0.1):
    """The CC points of pass ``t``: (cc (k, 3), normal (k, 3), m (k,), θ (k,)), sampled
    from a dense polyline (``dense`` mm apart along m) so that the chord error stays within
    ``chord`` mm and no step exceeds ``max_step`` mm. The points lie on the hub surface."""
    m = ch.m
    n = max(len(m), int(math.ceil((m[-1] - m[0]) / dense)) + 1)
    if n == len(m):  # the channel's own stations (where its boundaries were checked)
        md, th = m, ch.theta(t)
    else:
        md = np.linspace(m[0], m[-1], n)
        th = np.interp(md, m, ch.theta(t))
    P = ch.hub.point(md, th)
    idx = chord_indices(P, chord, max_step)
    return P[idx], ch.hub.normal(md[idx], th[idx]), md[idx], th[idx]


class TipChannel:
    """The channel between blade 0 and blade 1 at the blade tips: blade 0's boundary loop
    farthest from the hub, split at its axial extremes into its two sides, read as
    θ(z) (rad) and r(z) (mm) per side; blade 1's side is blade 0's other side turned by the
    pitch. :meth:`point` gives the point at ratio ``t`` across that gap (0 beside blade 0,
    1 beside blade 1) at axial position z, ``margin`` mm inside each side — the tool axis of
    a hub pose aims there so that the tool leans with the channel (its twist and lean) instead
    of standing on the hub normal into the blades' overhang."""

    def __init__(self, blade: TriMesh, hub: HubSurface, pitch: float):
        loops = [lp for lp in blade.boundary_loops() if len(lp) >= 3]
        if len(loops) < 2:
            raise ToleranceError("the blade mesh needs an open tip as well as an open root "
                                 "to aim the tool axis through the channel; use --axis normal")
        far = max(loops, key=lambda lp: float(np.mean(hub.coordinates(blade.V[lp])[2])))
        P = blade.V[far] - hub.axis.o
        x, y, z = P @ hub.e1, P @ hub.e2, P @ hub.d
        r, th = np.hypot(x, y), np.arctan2(y, x)
        th0 = _circ_mean(th)
        th = th0 + _wrap(th - th0)
        (zu, tu), (zl, tl) = _chains(z, th)
        ru = np.hypot(x, y)
        self.pitch = float(pitch)
        self.hub = hub
        self.zu, self.tu = zu, tu
        self.zl, self.tl = zl, tl
        self.r_mean = float(ru.mean())
        self._rz = (np.sort(z), r[np.argsort(z)])

    def point(self, z, t, margin: float) -> np.ndarray:
        """(k, 3) points at the tip radius, axial position ``z`` (k,), ratio ``t`` (k,) across
        the gap, kept ``margin`` mm from each side; beyond the tip's axial extent the point
        at its end, moved axially by the overshoot (the aim keeps its direction past the
        edges)."""
        z = np.asarray(z, dtype=np.float64)
        zc = np.clip(z, max(self.zu[0], self.zl[0]), min(self.zu[-1], self.zl[-1]))
        a = np.interp(zc, self.zu, self.tu)
        b = np.interp(zc, self.zl, self.tl) + self.pitch
        r = np.interp(zc, *self._rz)
        gap = np.maximum(r * (b - a), 1e-9)
        f = np.clip(margin / gap, 0.0, 0.45)
        tt = f + np.asarray(t) * (1.0 - 2.0 * f)
        th = a + tt * (b - a)
        h = self.hub
        return (h.axis.o + z[:, None] * h.d
                + r[:, None] * (np.cos(th)[:, None] * h.e1 + np.sin(th)[:, None] * h.e2))
