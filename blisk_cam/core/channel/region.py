"""The region of a level a roughing tool may take between blade 0 and blade 1.

Blade 1 is blade 0 turned by the pitch 2π/N. On a level the tool's tip runs at radius r(z)
on a radial axis (optionally tilted by a lead λ toward +z and a side tilt φ toward +θ); at a
height h above its tip the tool — flute, shank, holder — is a disc of radius ρ(h) about the
axis, and the disc lies, to first order, on the cylinder r = r(z) + h of the blisk, centred
at (z + h tan λ, θ + h tan φ / (r + h)). The blade's section on that cylinder is a closed
curve in (z, θ) (:func:`cylinder_sections`: blade mesh ∩ cylinder, dense points). The tool
keeps a distance a (the allowance) from the blade when every disc stays o(h) away from the
section points in the developed metric (dz, r dθ), o(h) the radius at height h of the tool
grown by a ball of radius a (the Minkowski sum, :func:`offset_table`; the body — shank and
holder — grows by a + the safety distance, since the allowance shell is still stock).

Against blade 0 (below the channel in θ) that is θ_tip ≥ max over the section points p of
θ_p + √(o² − (z − z_p)²)/r_c − h tan φ / r_c: the upper envelope of circles, exact for the
sampled curve, a lower bound per station; against blade 1 the lower envelope of the same
points turned by the pitch, an upper bound (:func:`channel_bounds`). Between two stations
the tip moves straight: the envelope of circles of radius o sags by at most δ²/(8 o) between
stations δ apart (δ = 0.5 mm, o ≥ 2 mm: ≤ 0.016 mm; the ``margin`` covers it).

Where no blade is within reach (before the leading edge, after the trailing edge, above the
tips) the bounds are free: :func:`fill_free` holds the nearest bounds for a distance and then
widens them to one full pitch (plus an overlap), so that the N gaps together clear the whole
ring there. Units mm, radians.
"""

from __future__ import annotations

import math

import numpy as np

from ..geometry.axis import Axis
from ..part.model import theta_about
from ..tool.assembly import ToolAssembly
from ..tool.cutter import Cutter

__all__ = ["Section", "channel_bounds", "cylinder_sections", "fill_free", "offset_table",
           "refined_bounds", "widest_circle"]


class Section:
    """Blade 0 ∩ the cylinder of radius ``radius`` (mm): points sorted by z (mm) with their
    θ (rad, relative to the blade's mean angle ``theta_ref`` of :func:`cylinder_sections`)."""

    __slots__ = ("radius", "z", "theta")

    def __init__(self, radius: float, z: np.ndarray, theta: np.ndarray):
        o = np.argsort(z, kind="stable")
        self.radius = float(radius)
        self.z = np.ascontiguousarray(z[o])
        self.theta = np.ascontiguousarray(theta[o])


def _to_cylinder(q, m, axis: Axis, c: float):
    """The point q + t m (rows) on the cylinder of radius ``c`` about ``axis`` with the
    smallest |t| (the root of a quadratic in t); q where there is none."""
    d = axis.d
    qp = (q - axis.o) - ((q - axis.o) @ d)[:, None] * d
    mp = m - (m @ d)[:, None] * d
    A = np.einsum("ij,ij->i", mp, mp)
    B = 2.0 * np.einsum("ij,ij->i", qp, mp)
    C = np.einsum("ij,ij->i", qp, qp) - c * c
    disc = np.sqrt(np.maximum(B * B - 4 * A * C, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = (-B + disc) / (2 * A)
        t2 = (-B - disc) / (2 * A)
        lin = -C / B
    t = np.where(np.abs(t1) <= np.abs(t2), t1, t2)
    t = np.where(A > 1e-14 * np.maximum(np.einsum("ij,ij->i", m, m), 1e-300), t, lin)
    t = np.where(np.isfinite(t), t, 0.0)
    return q + t[:, None] * m


def cylinder_sections(V, F, axis: Axis, radii, theta_ref: float, spacing: float = 0.15):
    """[Section] of the mesh (V, F) with the cylinders r = ``radii`` (mm) about ``axis``:
    every triangle crossing a cylinder gives the arc between its two edge crossings (the
    exact crossings of the straight edges), sampled every ``spacing`` mm in (z, r θ), each
    sample the point of the triangle's plane on the cylinder (moved within the plane,
    across the chord, onto it: exact however large the triangle)."""
    V = np.asarray(V, float)
    r, _, _ = theta_about(V, axis)
    F = np.asarray(F, np.int64)
    rf = r[F]
    rmin, rmax = rf.min(axis=1), rf.max(axis=1)
    out = []
    for c in np.asarray(radii, float):
        sel = np.nonzero((rmin < c) & (rmax > c))[0]
        if len(sel) == 0:
            out.append([c, [np.zeros(0)], [np.zeros(0)]])
            continue
        f = F[sel]
        d = r[f] - c
        d = np.where(d == 0.0, 1e-12, d)
        cross = np.stack([(d[:, i] > 0) != (d[:, j] > 0) for i, j in ((0, 1), (1, 2), (2, 0))],
                         1)
        ok = cross.sum(axis=1) == 2
        f, cross = f[ok], cross[ok]
        first = np.argmax(cross, axis=1)
        second = 2 - np.argmax(cross[:, ::-1], axis=1)
        ends = []
        for e in (first, second):
            A = V[f[np.arange(len(f)), e]]
            B = V[f[np.arange(len(f)), (e + 1) % 3]]
            ends.append(_to_cylinder(A, B - A, axis, c))
        P0, P1 = ends
        nrm = np.cross(V[f[:, 1]] - V[f[:, 0]], V[f[:, 2]] - V[f[:, 0]])
        chord = P1 - P0
        m = np.cross(nrm, chord)
        m /= np.maximum(np.linalg.norm(m, axis=1), 1e-300)[:, None]
        L = np.linalg.norm(chord, axis=1)
        n = np.maximum(1, np.ceil(L / spacing).astype(int))
        seg = np.repeat(np.arange(len(f)), n + 1)
        s = (np.arange(int((n + 1).sum())) - np.repeat(np.cumsum(n + 1) - (n + 1), n + 1)) \
            / np.repeat(n, n + 1)
        q = P0[seg] + s[:, None] * chord[seg]
        inner = (s > 0) & (s < 1)
        q[inner] = _to_cylinder(q[inner], m[seg][inner], axis, c)
        _, th, z = theta_about(q, axis)
        th = np.mod(th - theta_ref + math.pi, 2 * math.pi) - math.pi
        out.append([c, [z], [th]])
    # the mesh's edges, sampled, each sample on the next cylinder above it: a blade's open
    # end or its tip face between two cylinders would otherwise be seen only by the lower
    # one, up to a cylinder spacing too low (the assignment upward only overstates the
    # height, and the distance kept grows with the height)
    radii = np.asarray(radii, float)
    E = np.unique(np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1),
                  axis=0)
    A, B = V[E[:, 0]], V[E[:, 1]]
    n = np.maximum(1, np.ceil(np.linalg.norm(B - A, axis=1) / spacing).astype(int))
    seg = np.repeat(np.arange(len(E)), n + 1)
    t = (np.arange(int((n + 1).sum())) - np.repeat(np.cumsum(n + 1) - (n + 1), n + 1)) \
        / np.repeat(n, n + 1)
    P = A[seg] + t[:, None] * (B - A)[seg]
    pr, pth, pz = theta_about(P, axis)
    pth = np.mod(pth - theta_ref + math.pi, 2 * math.pi) - math.pi
    k = np.searchsorted(radii, pr, "left")
    gap = np.diff(radii).max() if len(radii) > 1 else 0.0
    use = (k < len(radii)) & (k > 0)
    use[use] &= radii[k[use]] - pr[use] <= gap + 1e-12
    order = np.argsort(k[use], kind="stable")
    kk, zz, tt = k[use][order], pz[use][order], pth[use][order]
    bounds = np.searchsorted(kk, np.arange(len(radii) + 1))
    sections = []
    for i, (c, zs, ts) in enumerate(out):
        a, b = bounds[i], bounds[i + 1]
        sections.append(Section(c, np.concatenate(zs + [zz[a:b]]),
                                np.concatenate(ts + [tt[a:b]])))
    return sections


def offset_table(cutter: Cutter, assembly: ToolAssembly, allowance: float, safety: float,
                 margin: float, step: float = 0.02, tilt: float = 0.0):
    """(h, o): heights h (mm, from −allowance below the tip up to the body's top) and the
    distance o(h) (mm) a section point at that height must keep from the tool's axis: the
    cutter's radius (flute) or the body's radius + ``safety`` (shank, holder), grown by a
    ball of radius ``allowance`` (the Minkowski sum of the solid of revolution), plus
    ``margin``. A tool tilted by ``tilt`` (rad) from radial: its disc of radius ρ at axial
    height h reaches the radial heights h cos(tilt) ± ρ sin(tilt), and a cylinder cuts the
    tilted solid of revolution in a curve within ρ / cos(tilt) of the axis; the table at
    height y then takes, over the heights h whose band holds y, the largest ρ(h) / cos(tilt)
    (per height: a wide holder far up the axis does not widen the band at the flute)."""
    a = float(allowance)
    top = float(max(assembly.top, cutter.h))
    w = float(max(cutter.max_radius, assembly.max_radius + safety) + a) * math.sin(abs(tilt))
    h = np.arange(-a - w - step, top + a + w + step, step)
    prof = cutter.profile(128)
    # the flute: the radius of the outline at each height (the largest at a height)
    zp, rp = prof[:, 1], prof[:, 0]
    order = np.lexsort((-rp, zp))
    zp, rp = zp[order], rp[order]
    keep = np.ones(len(zp), bool)
    keep[1:] = np.diff(zp) > 1e-12
    rho = np.where((h >= 0) & (h <= cutter.h), np.interp(h, zp[keep], rp[keep]), -np.inf)
    body = assembly.radius_at(h)
    on_body = (h >= assembly.flute_length) & (h <= assembly.top)
    rho = np.maximum(rho, np.where(on_body, body + safety, -np.inf))
    if a > 0:
        n = max(3, int(math.ceil(2 * a / step)) | 1)
        best = np.full(len(h), -np.inf)
        for dlt in np.linspace(-a, a, n):
            shifted = np.interp(h + dlt, h, rho, left=-np.inf, right=-np.inf)
            best = np.maximum(best, shifted + math.sqrt(max(a * a - dlt * dlt, 0.0)))
        rho = best
    if tilt != 0.0:
        c, s_ = math.cos(abs(tilt)), math.sin(abs(tilt))
        fin = np.nonzero(np.isfinite(rho))[0]
        best = np.full(len(h), -np.inf)
        # each height's band on the grid of h (rounded outward by a step)
        centre = np.round((h[fin] * c - h[0]) / step).astype(np.int64)
        half = np.ceil(rho[fin] * s_ / step).astype(np.int64) + 1
        for k in range(-int(half.max()), int(half.max()) + 1):
            m = np.abs(k) <= half
            j = centre[m] + k
            ok = (j >= 0) & (j < len(h))
            np.maximum.at(best, j[ok], rho[fin][m][ok] / c)
        rho = best
    return h, np.where(np.isfinite(rho), rho + margin, rho)


def channel_bounds(sections, pitch: float, z, r_tip, table, *, lead: float = 0.0,
                   side: float = 0.0):
    """Lower and upper θ bounds (rad, relative to the blade's mean angle) of the tip at the
    stations ``z`` (n,) with tip radii ``r_tip`` (n,): the tool clear of blade 0 (below) and
    blade 1 (above) at every height of ``table`` (:func:`offset_table`). ``lead`` and
    ``side`` are the axis tilts (rad; ``side`` a scalar or (n,) per station). ±inf where no
    section is within reach."""
    z = np.asarray(z, float)
    r_tip = np.asarray(r_tip, float)
    hs, os_ = table
    h_lo, h_hi = float(hs[np.isfinite(os_)].min()), float(hs[np.isfinite(os_)].max())
    lo = np.full(len(z), -np.inf)
    hi = np.full(len(z), np.inf)
    tl = math.tan(lead)
    ts = np.broadcast_to(np.tan(np.asarray(side, float)), z.shape)
    for sec in sections:
        if len(sec.z) == 0:
            continue
        rc = sec.radius
        h = rc - r_tip
        st = np.nonzero((h >= h_lo) & (h <= h_hi))[0]
        if len(st) == 0:
            continue
        o = np.interp(h[st], hs, os_)
        live = np.isfinite(o) & (o > 0)
        st, o = st[live], o[live]
        if len(st) == 0:
            continue
        zq = z[st] + h[st] * tl
        a = np.searchsorted(sec.z, zq - o, "left")
        b = np.searchsorted(sec.z, zq + o, "right")
        cnt = b - a
        has = cnt > 0
        if not has.any():
            continue
        st, o, zq, a, cnt = st[has], o[has], zq[has], a[has], cnt[has]
        idx = np.repeat(a - np.cumsum(cnt) + cnt, cnt) + np.arange(int(cnt.sum()))
        grp = np.repeat(np.arange(len(st)), cnt)
        dz = sec.z[idx] - zq[grp]
        s = np.sqrt(np.maximum(o[grp] ** 2 - dz * dz, 0.0)) / rc
        shift = (h[st] * ts[st] / rc)[grp]
        starts = np.cumsum(cnt) - cnt
        up = np.maximum.reduceat(sec.theta[idx] + s - shift, starts)
        dn = np.minimum.reduceat(sec.theta[idx] - s - shift, starts) + pitch
        lo[st] = np.maximum(lo[st], up)
        hi[st] = np.minimum(hi[st], dn)
    return lo, hi


def fill_free(z, lo, hi, pitch: float, overlap, hold: float, blend: float,
              centre_default: float):
    """Bounds where no blade is within reach (±inf): the nearest defined bounds held for
    ``hold`` mm, then blended over ``blend`` mm to one full pitch about the nearest defined
    centre, widened by ``overlap`` (rad, (n,) or scalar) each side; ``centre_default`` (rad)
    when nothing is defined."""
    z = np.asarray(z, float)
    lo, hi = lo.copy(), hi.copy()
    defined = np.isfinite(lo) & np.isfinite(hi)
    overlap = np.broadcast_to(np.asarray(overlap, float), z.shape)
    if not defined.any():
        return centre_default - 0.5 * pitch - overlap, centre_default + 0.5 * pitch + overlap
    idx = np.nonzero(defined)[0]
    pos = np.searchsorted(idx, np.arange(len(z)))
    left = idx[np.clip(pos - 1, 0, len(idx) - 1)]
    right = idx[np.clip(pos, 0, len(idx) - 1)]
    near = np.where(np.abs(z[left] - z) <= np.abs(z[right] - z), left, right)
    dist = np.abs(z - z[near])
    und = ~defined
    nl, nh = lo[near], hi[near]
    c = 0.5 * (nl + nh)
    f = np.clip((dist - hold) / max(blend, 1e-9), 0.0, 1.0)
    tl = c - 0.5 * pitch - overlap
    th = c + 0.5 * pitch + overlap
    lo[und] = ((1 - f) * nl + f * tl)[und]
    hi[und] = ((1 - f) * nh + f * th)[und]
    return lo, hi


def refined_bounds(sections, pitch, z, r, outside, table, lead: float, side, chord: float = 0.5,
                    rounds: int = 8):
    """Stations and bounds of one level, refined where a bound moves more than ``chord`` mm
    between two stations: a straight move of length L between two points of the envelope
    of circles of radius o (≥ the tool's radius) leaves it by at most L²/(8 o), so chords of
    ≤ 0.5 mm stay within the margin — also where the envelope turns round a leading or
    trailing edge and its slope in z is unbounded (there halving the z step is what shortens
    the chord). ``side`` (n,) the side tilt per station (rad), interpolated linearly at the
    inserted stations; ``lead`` the axis's lead (rad). Returns (z, r, outside, lo, hi, side)."""
    lo, hi = channel_bounds(sections, pitch, z, r, table, lead=lead, side=side)
    for _ in range(rounds):
        both = np.isfinite(lo[:-1]) & np.isfinite(lo[1:]) & np.isfinite(hi[:-1]) & \
            np.isfinite(hi[1:])
        rm = 0.5 * (r[:-1] + r[1:])
        with np.errstate(invalid="ignore"):
            jump = np.maximum(np.abs(np.diff(lo)), np.abs(np.diff(hi))) * rm
        bad = np.nonzero(both & (jump > chord))[0]
        if len(bad) == 0:
            break
        zm = 0.5 * (z[bad] + z[bad + 1])
        r_m = 0.5 * (r[bad] + r[bad + 1])
        out_m = outside[bad] & outside[bad + 1]
        s_m = 0.5 * (side[bad] + side[bad + 1])
        lo_m, hi_m = channel_bounds(sections, pitch, zm, r_m, table, lead=lead, side=s_m)
        order = np.argsort(np.concatenate([z, zm]), kind="stable")
        z = np.concatenate([z, zm])[order]
        r = np.concatenate([r, r_m])[order]
        outside = np.concatenate([outside, out_m])[order]
        side = np.concatenate([side, s_m])[order]
        lo = np.concatenate([lo, lo_m])[order]
        hi = np.concatenate([hi, hi_m])[order]
    return z, r, outside, lo, hi, side


def widest_circle(part, sections, z, r_floor, band) -> tuple[float, float]:
    """(widest, narrowest) at the hub (mm): the diameter of the widest circle between blade 0
    and blade 1 on the band of cylinders ``band`` mm above the floor that lies axially within
    the blade row (a circle beyond the leading or trailing edge is not in the channel), and
    the narrowest circumferential gap between the blades there."""
    hs = np.array([band[0] - 1e-6, band[0], band[1], band[1] + 1e-6])
    zs = np.concatenate([s.z for s in sections if len(s.z)])
    if len(zs) == 0:
        return math.inf, math.inf
    z_lo, z_hi = float(zs.min()), float(zs.max())

    def fits(o):
        lo, hi = channel_bounds(sections, part.pitch, z, r_floor,
                                (hs, np.array([-np.inf, o, o, -np.inf])))
        d = np.isfinite(lo) & np.isfinite(hi) & (z >= z_lo + o) & (z <= z_hi - o)
        return d, (hi - lo)

    d0, w0 = fits(0.5)  # (a disc, not a point: the section points lie 0.3 mm apart)
    if not d0.any():
        return math.inf, math.inf
    lo_o, hi_o = 0.5, 0.5 * (z_hi - z_lo)
    for _ in range(30):
        mid = 0.5 * (lo_o + hi_o)
        d, w = fits(mid)
        if (d & (w >= 0)).any():
            lo_o = mid
        else:
            hi_o = mid
    throat = float((w0[d0] * r_floor[d0]).min()) + 1.0
    return 2.0 * lo_o, throat
