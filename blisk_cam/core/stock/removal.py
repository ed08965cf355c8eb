"""Material removal by a program's moves, on the radial dexels of one sector.

Every row of a :class:`~..toolpath.types.Program` moves the tool from the previous pose to its
own (cut, link, approach, retract, rapid): the tool tip goes **linearly** and the tool axis
turns by **spherical linear interpolation** (slerp) between the two axes — a 5-axis machine
running in TCP (tool-centre-point) mode. The move is sampled at sub-poses spaced so that the
union of the sampled cutters differs from the true swept volume by less than
``sweep_tolerance`` (the scallop between two samples of a surface of curvature radius ρ is
δ²/(8ρ), so δ = √(8 ρ tol); the axis turn is bounded the same way at the flute's top); every
sub-pose removes the cutter solid from the rays it meets, exactly in r.

The solids are the **true cutter** (:class:`~..tool.cutter.Cutter`: ball, bull nose, flat,
taper — the DIN 66215 profile, the same as the verifier's) and the **body** (shank and holder,
:class:`~..tool.assembly.ToolAssembly`; by default the cutter's own shank and holder, the
same as the collision check's default). A convex solid of revolution whose meridional profile
is a convex polygon is an intersection of revolved half-planes nρ ρ + nz z ≤ c, and along a
ray every such constraint is one interval whose ends are the roots of a quadratic
(:func:`ray_solid_intervals`), so a ray meets the solid in one interval computed in closed
form. The corner arcs are inscribed polygons (error ≤ ``arc_tolerance``, material left).

A **crash** is material removed by a rapid move or by the body; it is reported with the row
(and the material is removed, so one collision is reported once).

Two functions carry the inner loop and can be swapped for compiled kernels one for one:
:func:`ray_solid_intervals` (rays × posed solids → r intervals) and
:func:`.dexels.subtract_intervals` (interval subtraction).

With the compiled kernels the flute is instead **swept per move** (``swept``, the default
there for a ball nose): every ray of the move's box gets the interval of the swept solid in
closed form — a ball nose's ball as the capsules along its centre path's chords (sagitta ≤ the sweep
tolerance), a frustum (the side of a ball nose or flat end mill) translated between knots
with the knot's mid axis (off the true poses by at most the tolerance) or at the sub-poses
when the axis turns too much for that, a bull nose's corner at the sub-poses
(:func:`cutter_primitives`). The sweep holds every sub-pose and exceeds the sub-poses' union
by the scallop between them; the numpy reference stays pose-sampled. The body goes through
the same kernel at its own sub-poses (the reference's, so the same crashes): the kernel culls
each part of a solid (the ball, each frustum, the corner polygon) by its own cylinder about
the move's mid pose, so a long holder is evaluated only on the rays whose material it can
reach.

A solid wider than the sector (a holder lying along the blades) meets several copies of a
ray — the neighbouring blades' material: every solid's candidate columns run up to a whole
turn.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import StockError
from ..kernels import stock as compiled_stock
from ..runtime import Progress, check_cancel, run_to_end, workers
from ..tool.assembly import ToolAssembly
from ..tool.cutter import Cutter, as_cutter
from ..toolpath.types import MOVE_NAMES, MOVE_RAPID, Program
from .dexels import RadialDexels, merge_intervals, subtract_intervals

__all__ = ["Crash", "RemovalResult", "body_assembly", "cutter_halfplanes", "cutter_primitives",
           "frustum_halfplanes", "halfplane_bounds", "halfplane_edges", "ray_solid_intervals",
           "remove_program", "shrink_primitives", "simulate_moves"]

_EPS = 1e-12
#: minimum volume (mm³) a rapid or the body must remove at one row to be a crash
CRASH_VOLUME = 1e-6


# ------------------------------------------------------------------------------ solids
def _polygon_halfplanes(poly) -> np.ndarray:
    """(q, 3) rows (nρ, nz, c) of a convex (ρ, z) polygon counter-clockwise from the tip on
    the axis to the top on the axis (the axis edge left out)."""
    P = np.asarray(poly, float)
    D = np.diff(P, axis=0)
    L = np.hypot(D[:, 0], D[:, 1])
    keep = L > 1e-12
    D, A = D[keep] / L[keep, None], P[:-1][keep]
    n = np.stack([D[:, 1], -D[:, 0]], 1)  # outward of a counter-clockwise polygon
    H = np.column_stack([n, np.einsum("ij,ij->i", n, A)])
    return H[H[:, 0] > -1e-12]  # an edge along the axis (ρ ≥ 0) constrains nothing


def cutter_halfplanes(cutter: Cutter, arc_tolerance: float = 1e-3) -> np.ndarray:
    """The cutting part (tip to flute length) as half-planes (q, 3); the corner arc inscribed
    with chords whose sagitta ≤ ``arc_tolerance`` mm."""
    c = as_cutter(cutter)
    r = c.r
    span = 0.5 * math.pi - c.beta - c.alpha
    prof = c.profile(2)
    if r > 0:
        # chords of angle Δ with sagitta s = r (1 − cos Δ/2) ≤ 2 tol, their vertices pushed
        # out by s/2 (a radius r (1 + cos Δ/2) / (2 cos Δ/2)): the polygon stays within ±tol
        # of the arc instead of always inside it (no bias of the removed volume)
        step = 2.0 * math.acos(max(-1.0, 1.0 - 2.0 * arc_tolerance / r))
        n = max(2, int(math.ceil(span / max(step, 1e-6))) + 1)
        th = np.linspace(c.alpha, 0.5 * math.pi - c.beta, n)
        half = 0.5 * (th[1] - th[0])
        rp = r * (1.0 + math.cos(half)) / (2.0 * math.cos(half))
        rr = np.full(n, rp)
        rr[[0, -1]] = r  # the tangent points stay: the bottom and side lines stay exact
        arc = np.stack([c.e + rr * np.sin(th), c.f - rr * np.cos(th)], 1)
        prof = np.vstack([[[0.0, 0.0]], arc, prof[-1:]])
    poly = np.vstack([prof, [[0.0, c.h]]])
    return _polygon_halfplanes(poly)


def frustum_halfplanes(z0, r0, z1, r1) -> np.ndarray:
    """A frustum of the body (ρ ≤ r(z), z0 ≤ z ≤ z1) as half-planes (3, 3)."""
    return _polygon_halfplanes([[0.0, z0], [r0, z0], [r1, z1], [0.0, z1]])


def _polygon_vertices(planes):
    """(ρ, z) vertices of the convex polygon of ``planes`` (q, 3) and ρ ≥ 0: every two edge
    lines' crossing where all constraints hold; and the (q + 1, 3) rows used."""
    H = np.vstack([np.asarray(planes, float).reshape(-1, 3), [[-1.0, 0.0, 0.0]]])  # ρ ≥ 0
    i, j = np.triu_indices(len(H), 1)
    det = H[i, 0] * H[j, 1] - H[i, 1] * H[j, 0]
    ok = np.abs(det) > 1e-12
    i, j, det = i[ok], j[ok], det[ok]
    rho = (H[i, 2] * H[j, 1] - H[i, 1] * H[j, 2]) / det
    z = (H[i, 0] * H[j, 2] - H[i, 2] * H[j, 0]) / det
    feas = (H[:, 0] * rho[:, None] + H[:, 1] * z[:, None]
            <= H[:, 2] + 1e-9 * (1.0 + np.abs(H[:, 2]))).all(axis=1)
    if not feas.any():
        raise StockError("a tool solid has no extent (its profile is empty)")
    return rho[feas], z[feas], H


def halfplane_bounds(planes) -> tuple:
    """(z_lo, z_hi, ρ_max) mm of the convex solid ``planes`` (q, 3) with ρ ≥ 0, from its
    polygon's vertices, widened by 1 µm — a cylinder about the tool axis that holds the
    solid (the compiled kernel skips the rays whose stretch inside it meets no material)."""
    rho, z, _ = _polygon_vertices(planes)
    return float(z.min()) - 1e-3, float(z.max()) + 1e-3, float(rho.max()) + 1e-3


def halfplane_edges(planes):
    """(q, 2) the ρ range (mm) of each plane's edge of the solid's polygon, when the boundary
    below the top rises with ρ (every plane but a top ``nz z ≤ c`` faces down or sideways:
    the cutters' profiles); None otherwise (a body frustum narrowing upward). The compiled
    kernel then evaluates on a ray only the edges its ρ range meets."""
    P = np.asarray(planes, float).reshape(-1, 3)
    top = (np.abs(P[:, 0]) < 1e-12) & (P[:, 1] > 0)
    if len(P) <= 3 or np.any(~top & (P[:, 1] > 1e-12)):
        return None
    rho, z, _ = _polygon_vertices(P)
    on = np.abs(P[:, 0, None] * rho + P[:, 1, None] * z - P[:, 2, None]) \
        <= 1e-9 * (1.0 + np.abs(P[:, 2, None]))
    if not on.any(axis=1).all():
        return None
    big = np.where(on, rho, -np.inf).max(axis=1)
    small = np.where(on, rho, np.inf).min(axis=1)
    return np.stack([small - 1e-9, big + 1e-9], 1)


def cutter_primitives(cutter: Cutter, arc_tolerance: float = 1e-3):
    """The flute as the compiled sweep takes it: (prims, planes) — ``prims`` (p, 5) rows swept
    exactly, (0, zc, radius, 0, 0) a ball centred zc mm up the axis and (1, z1, r1, z2, r2) a
    frustum; ``planes`` (q, 3) half-planes of the part swept by sampled poses, or None.

    A ball nose (no corner offset) is its ball and the frustum from the side's tangent circle
    to the flute top (the ball's cap above the tangent circle lies inside that frustum); a
    flat end mill is its side frustum (and its bottom cone when α > 0); a bull nose or a
    taper with a corner offset has the side frustum exact and the corner (tip to the side's
    tangent height: :func:`cutter_halfplanes` cut there) as the polygon."""
    c = as_cutter(cutter)
    e, f, r, al, be, h = c.e, c.f, c.r, c.alpha, c.beta, c.h
    s_rho, s_z = e + r * math.cos(be), f - r * math.sin(be)
    side = [1.0, s_z, s_rho, h, c.max_radius]
    tol = 1e-9 * max(c.d, 1.0)
    if r > 0 and e <= tol and al == 0.0 and f + r <= h:
        return np.array([[0.0, f, r, 0.0, 0.0], side]), None
    if r == 0:
        if f > tol:
            return np.array([[1.0, 0.0, 0.0, f, e], side]), None
        return np.array([[1.0, 0.0, e, h, c.max_radius]]), None
    planes = cutter_halfplanes(c, arc_tolerance).copy()
    top = (np.abs(planes[:, 0]) < _EPS) & (planes[:, 1] > 0)
    planes[top, 2] = s_z * planes[top, 1]
    return np.array([side]), planes


def shrink_primitives(prims, delta: float) -> np.ndarray:
    """The primitives (p, 5) each shrunk by ``delta`` mm (the crash measure's inner solid):
    a ball's radius, a frustum's ends and its side (normal offset); emptied ones dropped."""
    out = []
    for kind, a, b, c, d in np.asarray(prims, float).reshape(-1, 5):
        if kind == 0:
            if b - delta > 0:
                out.append([0.0, a, b - delta, 0.0, 0.0])
            continue
        k = (d - b) / (c - a) if c > a else 0.0
        n = math.hypot(1.0, k)
        z1, z2 = a + delta, c - delta
        r1, r2 = b + k * delta - delta * n, d - k * delta - delta * n
        if z2 > z1 and max(r1, r2) > 0:
            out.append([1.0, z1, max(r1, 0.0), z2, max(r2, 0.0)])
    return np.array(out, float).reshape(-1, 5)


def body_assembly(cutter: Cutter) -> ToolAssembly:
    """The cutter's own shank (Ø shank_diameter for 2 d + neck above the flute) and holder
    (Ø holder_diameter for holder_length) — the collision check's default assembly."""
    fl = cutter.h
    rs, rh = 0.5 * cutter.shank_diameter, 0.5 * cutter.holder_diameter
    z1 = fl + 2.0 * cutter.d + cutter.neck_length
    return ToolAssembly(fl, ((fl, rs), (z1, rs), (z1, rh), (z1 + cutter.holder_length, rh)))


def ray_solid_intervals(origin, u, tip, axis, planes):
    """Where rays meet posed convex solids of revolution: one interval of the ray parameter
    per pair.

    Parameters
    ----------
    origin : (k, 3) float, mm — ray origins (on the blisk axis)
    u : (k, 3) float — unit ray directions (radial)
    tip : (k, 3) float, mm; axis : (k, 3) float, unit — the solid's pose for each ray
    planes : (q, 3) float — the solid's meridional half-planes (nρ, nz, c): nρ ρ + nz z ≤ c
        in the tool frame (ρ from the axis, z from the tip)

    Returns
    -------
    lo, hi : (k,) float, mm — the interval [lo, hi] along each ray (lo ≥ hi: no contact;
        lo ≥ 0, the ray starts at the axis)
    """
    k = len(origin)
    out_lo = np.zeros(k)
    out_hi = np.full(k, -np.inf)
    live = np.arange(k)
    dv = origin - tip
    z0 = np.einsum("ij,ij->i", dv, axis)
    zu = np.einsum("ij,ij->i", u, axis)
    A = np.maximum(1.0 - zu * zu, 0.0)
    B = 2.0 * (np.einsum("ij,ij->i", dv, u) - z0 * zu)
    C = np.maximum(np.einsum("ij,ij->i", dv, dv) - z0 * z0, 0.0)
    lo = np.zeros(k)
    hi = np.full(k, np.inf)
    sA = np.sqrt(A)
    # the widest constraints first (top, side: they empty most pairs), then drop the pairs
    # already empty every few constraints
    planes = np.asarray(planes, float)
    order = np.r_[len(planes) - 1, len(planes) - 2, np.arange(len(planes) - 2)] \
        if len(planes) > 2 else np.arange(len(planes))
    for step, (nr, nz, c) in enumerate(planes[order]):
        if step % 3 == 2:
            alive = hi > lo
            if len(alive) and alive.mean() < 0.8:
                live, lo, hi = live[alive], lo[alive], hi[alive]
                z0, zu, A, B, C, sA = z0[alive], zu[alive], A[alive], B[alive], C[alive], \
                    sA[alive]
        if abs(nr) < _EPS:  # nz z ≤ c: linear in r
            s = nz * zu
            rhs = c - nz * z0
            with np.errstate(divide="ignore", invalid="ignore"):
                root = rhs / s
            pos = s > _EPS
            neg = s < -_EPS
            hi = np.where(pos, np.minimum(hi, root), hi)
            lo = np.where(neg, np.maximum(lo, root), lo)
            never = ~pos & ~neg & (rhs < 0)
            hi = np.where(never, -np.inf, hi)
            continue
        # nρ ρ ≤ M(r) = m0 + m1 r: the set where the convex g = nρ ρ − M ≤ 0 is one
        # interval, its ends roots of q = nρ² ρ² − M² with M ≥ 0 (undivided: a small nρ,
        # a nearly flat bottom, stays well conditioned)
        m0 = c - nz * z0
        m1 = -nz * zu
        a2 = nr * nr * A - m1 * m1
        a1 = nr * nr * B - 2.0 * m0 * m1
        a0 = nr * nr * C - m0 * m0
        disc = a1 * a1 - 4.0 * a2 * a0
        sq = np.sqrt(np.maximum(disc, 0.0))
        lin = np.abs(a2) < 1e-12
        with np.errstate(divide="ignore", invalid="ignore"):
            qq = -0.5 * (a1 + np.where(a1 >= 0, sq, -sq))
            r1 = np.where(lin, -a0 / a1, qq / a2)
            r2 = np.where(lin, np.nan, a0 / qq)
        real = (disc >= 0) | lin
        tol = 1e-9 * (1.0 + np.abs(m0))
        with np.errstate(invalid="ignore"):
            v1 = real & np.isfinite(r1) & (m0 + m1 * r1 >= -tol)
            v2 = real & np.isfinite(r2) & (m0 + m1 * r2 >= -tol)
        rlo = np.where(v1 & v2, np.minimum(r1, r2), np.nan)
        rhi = np.where(v1 & v2, np.maximum(r1, r2), np.nan)
        one = v1 ^ v2
        v = np.where(v1, r1, r2)
        plus = (nr * sA - m1) < 0  # inside toward +∞
        rlo = np.where(one & plus, v, rlo)
        rhi = np.where(one & plus, np.inf, rhi)
        rlo = np.where(one & ~plus, -np.inf, rlo)
        rhi = np.where(one & ~plus, v, rhi)
        none = ~v1 & ~v2
        inside0 = nr * np.sqrt(C) - m0 <= 0
        rlo = np.where(none, np.where(inside0, -np.inf, np.inf), rlo)
        rhi = np.where(none, np.where(inside0, np.inf, -np.inf), rhi)
        lo = np.maximum(lo, rlo)
        hi = np.minimum(hi, rhi)
    out_lo[live] = lo
    out_hi[live] = hi
    return out_lo, out_hi


# ------------------------------------------------------------------------------ results
@dataclass
class Crash:
    """Material removed where it must not be: by a rapid move or by the body (shank/holder)."""

    row: int  # program row (the pose the move ends at)
    kind: str  # "rapid" or "body"
    move: str  # the row's move type
    volume: float  # mm³ removed in the sector
    depth: float  # mm, the longest stretch removed along one ray (radial)
    where: tuple  # (x, y, z) mm of the tool tip at the row
    resolution: float | None = None  # mm: found by :mod:`.fine_check` at this resolution

    def as_dict(self) -> dict:
        return {"row": self.row, "kind": self.kind, "move": self.move,
                "volume_mm3": round(self.volume, 6), "depth_mm": round(self.depth, 4),
                "tip_mm": [round(float(x), 4) for x in self.where],
                **({"found_at_resolution_mm": self.resolution} if self.resolution else {})}


@dataclass
class RemovalResult:
    """What a program removed: volume per move type (mm³, in the sector), the crashes, the
    sub-poses and ray–solid pairs computed, and the number of rows."""

    removed: dict = field(default_factory=dict)
    crashes: list = field(default_factory=list)
    rows: int = 0
    sub_poses: int = 0
    pairs: int = 0

    @property
    def volume(self) -> float:
        return float(sum(self.removed.values()))


# ------------------------------------------------------------------------------ sweeping
def _slerp_rows(a0, a1, t):
    """Unit axes between a0 and a1 (k, 3) at fractions t (k,)."""
    dot = np.clip(np.einsum("ij,ij->i", a0, a1), -1.0, 1.0)
    om = np.arccos(dot)
    so = np.sin(om)
    small = so < 1e-9
    with np.errstate(invalid="ignore", divide="ignore"):
        w0 = np.where(small, 1.0 - t, np.sin((1.0 - t) * om) / so)
        w1 = np.where(small, t, np.sin(t * om) / so)
    out = w0[:, None] * a0 + w1[:, None] * a1
    return out / np.linalg.norm(out, axis=1)[:, None]


def _sub_poses(tip, axis, rows, first: bool, step: float, reach: float):
    """Sub-poses of the moves ending at ``rows`` (tip linear, axis slerp), t in (0, 1] (and
    the first row's own pose when ``first``): (tips, axes, row of each)."""
    prev = np.maximum(rows - 1, 0)
    d = np.linalg.norm(tip[rows] - tip[prev], axis=1)
    ang = np.arccos(np.clip(np.einsum("ij,ij->i", axis[rows], axis[prev]), -1.0, 1.0))
    n = np.maximum(1, np.ceil(np.maximum(d, reach * ang) / step).astype(np.int64))
    if first:
        n = np.where(rows == 0, 1, n)
    rr = np.repeat(rows, n)
    k = np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)
    t = (k + 1) / np.repeat(n, n)
    t = np.where(rr == 0, 1.0, t)
    p0 = np.maximum(rr - 1, 0)
    tips = tip[p0] + t[:, None] * (tip[rr] - tip[p0])
    axes = _slerp_rows(axis[p0], axis[rr], t)
    return tips, axes, rr


def _candidate_boxes(dex: RadialDexels, tips, axes, z_lo, z_hi, radius, r_cap=np.inf):
    """For each solid (its axis segment tip + [z_lo, z_hi] · axis, radius ``radius``): the
    (θ, z) box of rays that can meet it — unwrapped columns c0..c1, rows w0..w1 — the radii
    (r_lo, r_hi) it can reach and its number of candidate rays (0 beyond ``r_cap``). Up to a
    whole turn of columns: a solid wider than the sector (a holder along the blades) meets
    several copies of a ray — the neighbouring blades."""
    e1, e2, d = dex.axis.angular_frame()
    P0 = tips + z_lo * axes - dex.axis.o
    P1 = tips + z_hi * axes - dex.axis.o
    za, zb = P0 @ d, P1 @ d
    ta = np.arctan2(P0 @ e2, P0 @ e1)
    tb = ta + np.mod(np.arctan2(P1 @ e2, P1 @ e1) - ta + math.pi, 2 * math.pi) - math.pi
    # the segment's nearest approach to the axis bounds the angular half-width
    seg = P1 - P0
    segp = seg - (seg @ d)[:, None] * d
    p0p = P0 - (P0 @ d)[:, None] * d
    den = np.einsum("ij,ij->i", segp, segp)
    s = np.clip(-np.einsum("ij,ij->i", p0p, segp) / np.maximum(den, 1e-300), 0.0, 1.0)
    rmin = np.linalg.norm(p0p + s[:, None] * segp, axis=1)
    with np.errstate(invalid="ignore"):
        w = np.where(rmin > radius, np.arcsin(np.minimum(radius / np.maximum(rmin, 1e-300), 1.0)),
                     math.pi)
    th_lo = np.minimum(ta, tb) - w
    th_hi = np.maximum(ta, tb) + w
    # rays in columns whose centre angle lies in [th_lo, th_hi] (unwrapped about θ0)
    base = np.floor((ta - dex.theta0) / dex.pitch) * dex.pitch
    c0 = np.ceil((th_lo - dex.theta0 - base) / dex.d_theta - 0.5).astype(np.int64)
    c1 = np.floor((th_hi - dex.theta0 - base) / dex.d_theta - 0.5).astype(np.int64)
    full = (th_hi - th_lo) >= 2 * math.pi
    span = dex.n_theta * dex.blade_count
    c1 = np.where(full, c0 + span - 1, np.minimum(c1, c0 + span - 1))
    shift = np.round(base / dex.d_theta).astype(np.int64)
    c0, c1 = c0 + shift, c1 + shift
    zl = np.minimum(za, zb) - radius
    zh = np.maximum(za, zb) + radius
    w0 = np.maximum(np.ceil((zl - dex.z0) / dex.dz - 0.5).astype(np.int64), 0)
    w1 = np.minimum(np.floor((zh - dex.z0) / dex.dz - 0.5).astype(np.int64), dex.n_z - 1)
    nc = np.maximum(c1 - c0 + 1, 0)
    nw = np.maximum(w1 - w0 + 1, 0)
    # the radii the solid can reach: the axis segment's nearest and farthest ± the radius
    r_far = np.maximum(np.linalg.norm(p0p, axis=1), np.linalg.norm(p0p + segp, axis=1))
    r_lo = np.maximum(rmin - radius, 0.0)
    r_hi = r_far + radius
    cnt = np.where(r_lo <= r_cap, nc * nw, 0)
    return c0, c1, w0, w1, r_lo, r_hi, nc, cnt


def _candidate_rays(dex: RadialDexels, tips, axes, z_lo, z_hi, radius, r_cap=np.inf):
    """The candidate rays of :func:`_candidate_boxes`, one by one: (solid, col, row) and the
    radii (r_lo, r_hi) per solid."""
    c0, c1, w0, w1, r_lo, r_hi, nc, cnt = _candidate_boxes(dex, tips, axes, z_lo, z_hi, radius,
                                                           r_cap)
    tot = int(cnt.sum())
    solid = np.repeat(np.arange(len(tips)), cnt)
    k = np.arange(tot) - np.repeat(np.cumsum(cnt) - cnt, cnt)
    ncs = np.maximum(nc[solid], 1)
    return solid, c0[solid] + k % ncs, w0[solid] + k // ncs, r_lo, r_hi


def _cut(dex: RadialDexels, tips, axes, planes, z_lo, z_hi, radius, chunk: int = 400_000,
         group: int = 4):
    """Intervals (ray, a, b, solid) of the rays meeting each posed solid: the candidates of
    ``group`` solids at a time (bounded memory), their pairs in chunks."""
    out = []
    n_pairs = 0
    r_cap = float(dex.hi.max()) if dex.hi.size else 0.0
    for g in range(0, len(tips), group):
        res = _cut_group(dex, tips[g:g + group], axes[g:g + group], planes, z_lo, z_hi, radius,
                         chunk, r_cap)
        if res[-1]:
            out.append((res[0], res[1], res[2], res[3] + g))
            n_pairs += res[-1]
    if not out:
        z = np.zeros(0)
        return np.zeros(0, np.int64), z, z, np.zeros(0, np.int64), n_pairs
    return (*(np.concatenate([o[i] for o in out]) for i in range(4)), n_pairs)


def _cut_group(dex: RadialDexels, tips, axes, planes, z_lo, z_hi, radius, chunk: int, r_cap):
    e1, e2, d = dex.axis.angular_frame()
    solid, col, row, r_lo, r_hi = _candidate_rays(dex, tips, axes, z_lo, z_hi, radius, r_cap)
    out = []
    for s in range(0, len(solid), chunk):
        so, co, ro = solid[s:s + chunk], col[s:s + chunk], row[s:s + chunk]
        ray = ro * dex.n_theta + np.mod(co, dex.n_theta)
        # skip rays without material within the solid's reach (the common case: air)
        L, H = dex.lo[ray], dex.hi[ray]
        has = ((H > L) & (L < r_hi[so, None]) & (H > r_lo[so, None])).any(axis=1)
        so, co, ro, ray = so[has], co[has], ro[has], ray[has]
        ang = dex.ray_theta(co)
        u = np.cos(ang)[:, None] * e1 + np.sin(ang)[:, None] * e2
        O = dex.axis.o + dex.ray_z(ro)[:, None] * d
        lo, hi = ray_solid_intervals(O, u, tips[so], axes[so], planes)
        hit = hi > lo
        out.append((ray[hit], lo[hit], hi[hit], so[hit]))
    if not out:
        z = np.zeros(0)
        return np.zeros(0, np.int64), z, z, np.zeros(0, np.int64), 0
    n_pairs = len(solid)
    return (*(np.concatenate([o[i] for o in out]) for i in range(4)), n_pairs)


def _overlap(dex: RadialDexels, rays, a, b):
    """(k,) material volume term Σ (min(H, b)² − max(L, a)²)/2 (mm²) and length (mm) of
    [a, b] on each ray, before removal."""
    L, H = dex.lo[rays], dex.hi[rays]
    x0 = np.maximum(L, a[:, None])
    x1 = np.minimum(H, b[:, None])
    ok = x1 > x0
    vol = 0.5 * np.where(ok, x1 * x1 - x0 * x0, 0.0).sum(axis=1)
    ln = np.where(ok, x1 - x0, 0.0).sum(axis=1)
    return vol, ln


def _apply(dex: RadialDexels, rays, a, b) -> float:
    """Remove the union of (rays, a, b) from the stock; returns the volume removed (mm³)."""
    rays, a, b, rank = merge_intervals(rays, a, b)
    total = 0.0
    for k in range(int(rank.max()) + 1 if len(rank) else 0):
        sel = rank == k
        dex.lo, dex.hi, removed = subtract_intervals(dex.lo, dex.hi, rays[sel], a[sel], b[sel])
        total += float(removed.sum())
    return total * dex.d_theta * dex.dz


def _shrink(planes, delta: float):
    """The half-planes ``planes`` (unit normals) moved inward by ``delta`` mm: the solid
    shrunk by ``delta`` everywhere (a convex polygon offset)."""
    P = np.array(planes, float)
    P[:, 2] -= delta
    return P


def _job_numpy(dex: RadialDexels, tips, axes, group, n_groups, planes, z_lo, z_hi, radius,
               measure, planes_in=None):
    """One solid's removal by the batch's sub-poses, numpy (the reference): (removed mm³,
    per group — the batch's rows — the material its own union met (mm³) and the material
    the union of the shrunk solid ``planes_in`` met (mm³; the crash decision), the longest
    stretch met along a ray (mm) — those three only when ``measure`` —, the candidate
    pairs)."""
    per = np.zeros(n_groups)
    per_in = np.zeros(n_groups)
    deep = np.zeros(n_groups)
    rays, a, b, so, n_pairs = _cut(dex, tips, axes, planes, z_lo, z_hi, radius)
    if len(rays) == 0:
        return 0.0, per, per_in, deep, n_pairs
    if measure:
        vol, _ = _overlap(dex, rays, a, b)
        row = group[so]
        hit = vol > 0
        # each hit row's own volume: the union of its sub-poses' intervals
        for j in np.unique(row[hit]):
            sel = row == j
            mr, ma, mb, _ = merge_intervals(rays[sel], a[sel], b[sel])
            v, ln = _overlap(dex, mr, ma, mb)
            per[j] = float(v.sum()) * dex.d_theta * dex.dz
            deep[j] = float(ln.max()) if len(ln) else 0.0
        if planes_in is not None and hit.any():
            sel = np.isin(group, np.unique(row[hit]))
            ri, ai, bi, si, _ = _cut(dex, tips[sel], axes[sel], planes_in, z_lo, z_hi, radius)
            gi = group[sel][si]
            for j in np.unique(gi):
                mr, ma, mb, _ = merge_intervals(ri[gi == j], ai[gi == j], bi[gi == j])
                per_in[j] = float(_overlap(dex, mr, ma, mb)[0].sum()) * dex.d_theta * dex.dz
    return _apply(dex, rays, a, b), per, per_in, deep, n_pairs


def _job_compiled(dex: RadialDexels, tips, axes, group, n_groups, planes, z_lo, z_hi, radius,
                  measure, planes_in, bounds, r_cap):
    """:func:`_job_numpy` by the compiled kernel (same candidate boxes, same figures);
    ``bounds``: the solid's (:func:`halfplane_bounds`, :func:`halfplane_edges`)."""
    c0, c1, w0, w1, _, _, _, cnt = _candidate_boxes(dex, tips, axes, z_lo, z_hi, radius, r_cap)
    none = cnt == 0
    boxes = np.stack([c0, np.where(none, c0 - 1, c1), w0, w1], 1)
    e1, e2, d = dex.axis.angular_frame()
    frame = np.array([dex.axis.o, e1, e2, d], float)
    out = compiled_stock.remove_solids(
        dex.lo, dex.hi, dex.n_theta, (dex.theta0, dex.d_theta, dex.z0, dex.dz), frame, tips,
        axes, group, n_groups, boxes, planes, bounds[0], measure, workers(), rho=bounds[1],
        planes_in=planes_in if measure else None)
    dex.lo, dex.hi, removed, vol, vol_in, depth, _ = out
    cell = dex.d_theta * dex.dz
    return removed * cell, vol * cell, vol_in * cell, depth, int(cnt.sum())


@dataclass
class _SweptSolid:
    """A solid as the compiled sweep takes it (see :func:`cutter_primitives`)."""

    prims: np.ndarray
    prims_in: np.ndarray
    planes: np.ndarray | None
    rho: np.ndarray | None
    planes_in: np.ndarray | None
    bounds: tuple  # (z_lo, z_hi, radius) mm: a cylinder about the axis holding the solid
    step: float  # mm, the samples' spacing (at the solid's reach)
    tol: float  # mm, the sweep tolerance the knots keep
    # the body: its frustums by the reference's sub-poses (t ∈ (0, 1], spaced ``step`` at
    # ``sample_reach``: the whole body's), no translational knots
    posed: bool = False
    sample_reach: float | None = None

    @property
    def reach(self) -> float:
        z_lo, z_hi, rad = self.bounds
        return math.hypot(max(abs(z_lo), abs(z_hi)), rad)


def _split_frustums(prims) -> np.ndarray:
    """The frustums of ``prims`` (p, 5) cut into slices at most one diameter tall (the same
    solid; each slice's own reach and bounding cylinder cull the rays tighter)."""
    out = []
    for row in np.asarray(prims, float).reshape(-1, 5):
        kind, z1, r1, z2, r2 = row
        n = int(math.ceil((z2 - z1) / max(2.0 * max(r1, r2), 1.0))) if kind == 1 else 1
        if n <= 1:
            out.append(row)
            continue
        z = np.linspace(z1, z2, n + 1)
        r = np.linspace(r1, r2, n + 1)
        out += [[1.0, z[i], r[i], z[i + 1], r[i + 1]] for i in range(n)]
    return np.array(out, float).reshape(-1, 5)


def _flute_solid(cutter, arc_tolerance, ctol, step, tol) -> _SweptSolid:
    prims, planes = cutter_primitives(cutter, arc_tolerance)
    prims = _split_frustums(prims)
    bounds = halfplane_bounds(cutter_halfplanes(cutter, arc_tolerance))
    return _SweptSolid(prims, shrink_primitives(prims, ctol), planes,
                       None if planes is None else halfplane_edges(planes),
                       None if planes is None else _shrink(planes, ctol), bounds, step, tol)


def _body_solids(body: ToolAssembly, step: float, ctol: float) -> list:
    """The body's frustums as the compiled sweep takes them (one solid each: the crash
    measure is per frustum, as the posed reference's), swept by the reference's sub-poses."""
    reach = math.hypot(body.top, body.max_radius)
    out = []
    for f in body.frustums():
        prims = np.array([[1.0, f[0], f[1], f[2], f[3]]])
        out.append(_SweptSolid(prims, shrink_primitives(prims, ctol), None, None, None,
                               halfplane_bounds(frustum_halfplanes(*f)), step, step,
                               posed=True, sample_reach=reach))
    return out


def _divisor_at_least(n, q):
    """Per element the smallest divisor of n (≥ 1) that is ≥ q (n itself at most)."""
    out = np.array(n, np.int64)
    for j, (nn, qq) in enumerate(zip(n.tolist(), q.tolist(), strict=True)):
        out[j] = next((d for d in range(max(int(qq), 1), nn) if nn % d == 0), nn)
    return out


def _job_swept(dex: RadialDexels, tip, axis, rows, first: bool, solid: _SweptSolid, measure,
               r_cap):
    """The moves ending at ``rows`` (from the previous row's pose; the first row of the
    program from its own) swept by the compiled kernel: (removed mm³, per row the material
    met by its sweep and by its inner sweep (mm³) and the longest stretch (mm), ray–move
    pairs, poses per move)."""
    prev = np.maximum(rows - 1, 0)
    if first:
        prev = np.where(rows == 0, rows, prev)
    t0, a0, t1, a1 = tip[prev], axis[prev], tip[rows], axis[rows]
    ang = np.arccos(np.clip(np.einsum("ij,ij->i", a0, a1), -1.0, 1.0))
    dist = np.linalg.norm(t1 - t0, axis=1)
    reach = solid.reach
    # a long move in pieces (each its own box: a rapid across the sector does not make every
    # ray a candidate); the pieces of a slerp are slerps of its sub-arcs
    n = np.maximum(1, np.ceil(np.maximum(dist, reach * ang) / max(solid.bounds[2], 1.0))
                   ).astype(np.int64)
    if solid.posed:
        # the reference's sub-poses (:func:`_sub_poses`), each piece an equal share of them
        posed = np.maximum(1, np.ceil(np.maximum(dist, solid.sample_reach * ang) / solid.step)
                           ).astype(np.int64)
        n = _divisor_at_least(posed, n)
        posed = np.repeat(posed // n, n)
    group = np.repeat(np.arange(len(rows)), n)
    if (n > 1).any():
        k = np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)
        nn = np.repeat(n, n)
        ta, tb = k / nn, (k + 1) / nn
        a0r, a1r = np.repeat(a0, n, axis=0), np.repeat(a1, n, axis=0)
        dl = np.repeat(t1 - t0, n, axis=0)
        base = np.repeat(t0, n, axis=0)
        t0, t1 = base + ta[:, None] * dl, base + tb[:, None] * dl
        a0, a1 = _slerp_rows(a0r, a1r, ta), _slerp_rows(a0r, a1r, tb)
        ang = np.arccos(np.clip(np.einsum("ij,ij->i", a0, a1), -1.0, 1.0))
        dist = np.linalg.norm(t1 - t0, axis=1)
    P = solid.prims
    ball, fr = P[P[:, 0] == 0], P[P[:, 0] == 1]
    # a ball's centre path: chords of sagitta zc (Δφ)² / 8 ≤ tol
    zc = float(ball[:, 1].max()) if len(ball) else 0.0
    knots = np.maximum(1, np.ceil(ang * math.sqrt(zc / (8.0 * solid.tol)))).astype(np.int64)
    samples = np.maximum(1, np.ceil(np.maximum(dist, reach * ang) / solid.step)).astype(np.int64)
    # a frustum translated with the mid axis of a knot is off the true poses by its reach
    # times half the knot's turn; where that needs more knots than samples: the samples
    f_reach = float(np.hypot(fr[:, 3], fr[:, [2, 4]].max(axis=1)).max()) if len(fr) else 0.0
    fknots = np.maximum(1, np.ceil(f_reach * ang / (2.0 * solid.tol))).astype(np.int64)
    fknots = np.where(fknots > samples, 0, fknots)
    if solid.posed:
        samples, fknots = posed, np.zeros_like(fknots)
    # every pose of the move is the mid pose moved by at most half the tip's travel and
    # turned by at most half the axis turn about the tip
    grow = 0.5 * (dist + reach * ang) + 1e-6
    z_lo, z_hi, rad = solid.bounds
    c0, c1, w0, w1, _, _, _, cnt = _candidate_boxes(
        dex, 0.5 * (t0 + t1), _slerp_rows(a0, a1, np.full(len(a0), 0.5)),
        (z_lo - grow)[:, None], (z_hi + grow)[:, None], rad + grow, r_cap)
    none = cnt == 0
    boxes = np.stack([c0, np.where(none, c0 - 1, c1), w0, w1], 1)
    e1, e2, d = dex.axis.angular_frame()
    frame = np.array([dex.axis.o, e1, e2, d], float)
    out = compiled_stock.sweep_moves(
        dex.lo, dex.hi, dex.n_theta, (dex.theta0, dex.d_theta, dex.z0, dex.dz), frame, t0, a0,
        t1, a1, group, len(rows), boxes, knots, fknots, samples, solid.prims,
        solid.prims_in, solid.bounds, measure, workers(), planes=solid.planes, rho=solid.rho,
        planes_in=solid.planes_in if measure else None, open_start=solid.posed)
    dex.lo, dex.hi, removed, vol, vol_in, depth, pairs = out
    cell = dex.d_theta * dex.dz
    if solid.posed:
        return removed * cell, vol * cell, vol_in * cell, depth, pairs, int(samples.sum())
    sampled = solid.planes is not None or bool((fknots == 0).any())
    poses = int((knots + 1).sum() + fknots.sum() + (samples + 1).sum() * sampled)
    return removed * cell, vol * cell, vol_in * cell, depth, pairs, poses


def _note_crashes(crash_rows: dict, rows, per, per_in, deep, kind, move, tip, row_offset,
                  near=None, snap=None):
    """Record the rows whose solid (and its inner solid) met material as crashes; with a
    ``near`` list, those whose inner solid did not, ``(row, kind, snap)`` (``snap``: the
    stock's (lo, hi) before the batch, float32: it only bounds the region)."""
    crash = (per_in > CRASH_VOLUME) & (per > CRASH_VOLUME)
    if near is not None:
        near += [(int(rows[j]) + row_offset, "body" if kind == "body" else "rapid", snap)
                 for j in np.nonzero(~crash & (per > CRASH_VOLUME))[0]]
    for j in np.nonzero(crash)[0]:
        key = (int(rows[j]), "body" if kind == "body" else "rapid")
        c = crash_rows.get(key)
        if c is None:
            crash_rows[key] = Crash(int(rows[j]) + row_offset, key[1],
                                    MOVE_NAMES[int(move[rows[j]])], float(per[j]),
                                    float(deep[j]), tuple(tip[rows[j]]))
        else:
            c.volume += float(per[j])
            c.depth = max(c.depth, float(deep[j]))


def _posed_bodies(body: ToolAssembly, ctol: float) -> list:
    return [(fp, (halfplane_bounds(fp), halfplane_edges(fp)), f[0], f[2], max(f[1], f[3]),
             _shrink(fp, ctol)) for f in body.frustums() for fp in [frustum_halfplanes(*f)]]


def _near_body(scratch, tip, axis, rows, solids, step, reach, compiled, r_cap, crash_rows,
               near, snap, row_offset):
    """Add to ``near`` the ``rows`` (no crash) whose grown body ``solids`` meets ``scratch``."""
    per = np.zeros(len(rows))
    if isinstance(solids[0], _SweptSolid):
        for solid in solids:
            per += _job_swept(scratch, tip, axis, rows, True, solid, True, r_cap)[1]
    else:
        tips, axes, rr = _sub_poses(tip, axis, rows, True, step, reach)
        group = np.searchsorted(rows, rr)
        for planes, bounds, z0, z1, rad in solids:
            args = (scratch, tips, axes, group, len(rows), planes, z0, z1, rad, True, None)
            per += (_job_compiled(*args, bounds, r_cap) if compiled else _job_numpy(*args))[1]
    near += [(int(rows[j]) + row_offset, "body", snap) for j in np.nonzero(per > CRASH_VOLUME)[0]
             if (int(rows[j]), "body") not in crash_rows]


def simulate_moves(dex: RadialDexels, program: Program, cutter, assembly: ToolAssembly | None
                   = None, *, sweep_tolerance: float | None = None,
                   arc_tolerance: float = 1e-3, check_body: bool = True, row_offset: int = 0,
                   batch: int = 64, crash_tolerance: float | None = None,
                   swept: bool | None = None, moving=None, near: list | None = None,
                   near_margin: float | None = None):
    """Remove the material of every row of ``program`` from ``dex`` (in place); a generator
    yielding :class:`~..runtime.Progress` and returning a :class:`RemovalResult`.

    Parameters
    ----------
    dex : RadialDexels — the stock (changed)
    program : Program — tips (mm) and unit axes in the part's frame, move codes per row
    cutter : Cutter (or a paths-JSON tool dict)
    assembly : ToolAssembly or None — the body (default :func:`body_assembly`)
    sweep_tolerance : float, mm — the sampled sweep's largest deviation from the true one
        (default 2 % of the stock's resolution: 1 µm at 0.05 mm; the removed volume of a
        ball of radius ρ mm is then short by about 0.13 %/ρ)
    check_body : bool — report the body's removal as crashes (and remove it)
    row_offset : int — added to the rows reported (programs run one after another)
    batch : int — rows per batch: within a batch the flute's removal is applied before the
        body and rapids are checked, so a crash the flute would clear later in the same
        batch could be missed; small batches keep the order of the machine
    crash_tolerance : float, mm — a rapid or the body is a crash when the solid shrunk by
        this much still meets material (default half the stock's resolution: the stock
        knows its surface between rays to about that, and a tool grazing it closer is not
        told from one passing by). The crash's volume and depth are the whole solid's. The
        body is swept at half this tolerance (its own sub-poses: it only decides crashes),
        the flute at ``sweep_tolerance``.
    swept : bool or None — the compiled kernel's swept volumes per move (None: for a ball
        nose when the compiled kernel has them) of the flute, per ray in closed form: a ball
        (the ball nose) as the capsules along its centre path's chords (sagitta ≤
        ``sweep_tolerance``); a frustum (a flat end mill's side, a ball nose's side above the
        ball) translated between knots with the knot's mid axis (off the true poses by at most
        the tolerance) or, when the axis turns so much that more knots than sub-poses would
        be needed, at the sub-poses; a bull nose's corner at the sub-poses. The swept
        removal holds every sub-pose's and exceeds it by at most the sampling scallop
        (``sweep_tolerance``) — more on a ray grazing a sweep's flank, which a sub-pose
        misses. False: the sub-poses (the numpy reference's arithmetic, which the numpy
        kernels always run). The body (crash check only) is always removed at its
        sub-poses (t ∈ (0, 1], the same as the reference's, so the same crashes); unless
        ``swept`` is False, with a compiled kernel that can, per move by the sweep kernel:
        each frustum culled by its own bounding cylinder about the move's mid pose, the
        sub-poses evaluated only on rays whose material that cylinder meets.
    moving : (m,) bool or None — the rows that move (False: only the next move's start);
    near : list or None — the rows whose rapid, or body grown by ``near_margin`` (default
        ``crash_tolerance``), met material without a crash, for :mod:`.fine_check`
    """
    cutter = as_cutter(cutter)
    body = assembly or body_assembly(cutter)
    tol = float(sweep_tolerance) if sweep_tolerance is not None else 0.02 * dex.resolution
    if not tol > 0:
        raise StockError(f"sweep tolerance must be > 0 mm, got {sweep_tolerance}")
    # a sharp-edged flat end mill: also bound the steps a ramping bottom disc leaves
    rho = cutter.r if cutter.r > 0 else 0.5 * cutter.d
    step = math.sqrt(8.0 * rho * tol)
    if cutter.r <= 0:
        step = min(step, dex.resolution)
    flute = cutter_halfplanes(cutter, arc_tolerance)
    reach = math.hypot(cutter.h, cutter.max_radius)
    ctol = 0.5 * dex.resolution if crash_tolerance is None else float(crash_tolerance)
    if not ctol >= 0:
        raise StockError(f"crash tolerance must be ≥ 0 mm, got {crash_tolerance}")
    flute_in = _shrink(flute, ctol)
    bodies = _posed_bodies(body, ctol)
    body_reach = math.hypot(body.top, body.max_radius)
    radii = [r for f in body.frustums() for r in (f[1], f[3]) if r > 0]
    body_step = max(step, math.sqrt(8.0 * min(radii, default=rho) * max(0.5 * ctol, tol)))
    tip = np.asarray(program.tip, float)
    axis = np.asarray(program.axis, float)
    axis = axis / np.linalg.norm(axis, axis=1)[:, None]
    move = np.asarray(program.move)
    result = RemovalResult(removed={name: 0.0 for name in MOVE_NAMES}, rows=len(tip))
    crash_rows: dict = {}
    compiled = compiled_stock.available()
    flute_bounds = (halfplane_bounds(flute), halfplane_edges(flute))
    # removal only lowers the largest radius of material: one bound serves the whole run
    r_cap = float(dex.hi.max()) if dex.hi.size else 0.0
    runs = [(m, a, z) for m, a, z in program.runs()]
    # the body's frustums by the kernel's sweep (the same sub-poses, culled per move)
    body_by_sweep = (swept is not False and compiled and compiled_stock.sweep_body_available())
    if swept is None:  # a ball nose (a bull nose's swept flute, though faster with the
        # per-part culling, reads differently on coarse grids where a ray grazes the sweep's
        # flank: left to the sub-poses until judged)
        swept = (compiled and compiled_stock.sweep_available() and cutter.type == "ball"
                 and cutter_primitives(cutter, arc_tolerance)[1] is None)
    if swept and not compiled_stock.sweep_available():
        raise StockError("the swept-volume removal needs the compiled kernels (make kernels)")
    flute_swept = _flute_solid(cutter, arc_tolerance, ctol, step, tol) if swept else None
    body_swept = _body_solids(body, body_step, ctol) if body_by_sweep else []
    # near: the body grown by the crash tolerance in radius (on a scratch copy)
    g = ctol if near_margin is None else float(near_margin)
    grown = ToolAssembly(body.flute_length, tuple((z, r + g) for z, r in body.profile))
    near_body = [] if near is None or not check_body or g <= 0 else _body_solids(
        grown, body_step, ctol) if body_by_sweep else [(p, pb, z0, z1, rad) for p, pb, z0, z1,
                                                        rad, _ in _posed_bodies(grown, 0.0)]
    done = 0
    for m, start, stop in runs:
        for s in range(start, stop, batch):
            check_cancel()
            rows = np.arange(s, min(stop, s + batch))
            done += len(rows)
            if moving is not None:
                rows = rows[moving[rows]]
                if not len(rows):
                    continue
            snap = None if near is None else (dex.lo.astype(np.float32), dex.hi.astype(np.float32))
            jobs = []
            if swept:
                removed, per, per_in, deep, n_pairs, n_poses = _job_swept(
                    dex, tip, axis, rows, True, flute_swept, m == MOVE_RAPID, r_cap)
                result.pairs += n_pairs
                result.sub_poses += n_poses
                _note_crashes(crash_rows, rows, per, per_in, deep, "flute", move, tip,
                              row_offset, near, snap)
                result.removed[MOVE_NAMES[m]] += removed
            else:
                poses = _sub_poses(tip, axis, rows, True, step, reach)
                result.sub_poses += len(poses[0])
                jobs = [("flute", poses, flute, flute_bounds, 0.0, cutter.h, cutter.max_radius,
                         flute_in)]
            if check_body and bodies and not body_swept:
                bposes = _sub_poses(tip, axis, rows, True, body_step, body_reach)
                result.sub_poses += len(bposes[0])
                jobs += [("body", bposes, p, pb, z0, z1, rad, pin)
                         for p, pb, z0, z1, rad, pin in bodies]
            for kind, (tips, axes, rr), planes, bounds, z0, z1, rad, p_in in jobs:
                measure = kind == "body" or m == MOVE_RAPID
                args = (dex, tips, axes, np.searchsorted(rows, rr), len(rows), planes, z0, z1,
                        rad, measure, p_in)
                out = _job_compiled(*args, bounds, r_cap) if compiled else _job_numpy(*args)
                removed, per, per_in, deep, n_pairs = out
                result.pairs += n_pairs
                _note_crashes(crash_rows, rows, per, per_in, deep, kind, move, tip, row_offset,
                              near if measure else None, snap)
                if kind == "flute":
                    result.removed[MOVE_NAMES[m]] += removed
            if check_body and body_swept:  # after the flute, as the posed body
                for solid in body_swept:
                    _, per, per_in, deep, n_pairs, n_poses = _job_swept(
                        dex, tip, axis, rows, True, solid, True, r_cap)
                    result.pairs += n_pairs
                    _note_crashes(crash_rows, rows, per, per_in, deep, "body", move, tip,
                                  row_offset, near, snap)
                result.sub_poses += n_poses
            if near_body:
                _near_body(dex.copy(), tip, axis, rows, near_body, body_step, body_reach,
                           compiled, r_cap, crash_rows, near, snap, row_offset)
            yield Progress(done / max(len(tip), 1),
                           f"simulating row {done} of {len(tip)}")
    result.crashes = sorted(crash_rows.values(), key=lambda c: (c.row, c.kind))
    return result


def remove_program(dex: RadialDexels, program: Program, cutter, assembly=None, **kw):
    """Run :func:`simulate_moves` to the end (no progress); returns the RemovalResult."""
    return run_to_end(simulate_moves(dex, program, cutter, assembly, **kw))
