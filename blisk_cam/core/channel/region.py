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

__all__ = ["Section", "channel_bounds", "cylinder_sections", "fill_free", "offset_table"]


class Section:
    """Blade 0 ∩ the cylinder of radius ``radius`` (mm): points sorted by z (mm) with their
    θ (rad, relative to the blade's mean angle ``theta_ref`` of :func:`cylinder_sections`)."""

    __slots__ = ("radius", "z", "theta")

    def __init__(self, radius: float, z: np.ndarray, theta: np.ndarray):
        o = np.argsort(z, kind="stable")
        self.radius = float(radius)
        self.z = np.ascontiguousarray(z[o])
        self.theta = np.ascontiguousarray(theta[o])


def cylinder_sections(V, F, axis: Axis, radii, theta_ref: float, spacing: float = 0.15):
    """[Section] of the mesh (V, F) with the cylinders r = ``radii`` (mm) about ``axis``:
    every triangle crossing a cylinder gives a segment between its two edge crossings (z and
    θ linear along the edge), sampled every ``spacing`` mm in (z, r θ)."""
    r, th, z = theta_about(V, axis)
    th = np.mod(th - theta_ref + math.pi, 2 * math.pi) - math.pi
    F = np.asarray(F, np.int64)
    rf = r[F]
    rmin, rmax = rf.min(axis=1), rf.max(axis=1)
    out = []
    for c in np.asarray(radii, float):
        sel = np.nonzero((rmin < c) & (rmax > c))[0]
        if len(sel) == 0:
            out.append(Section(c, np.zeros(0), np.zeros(0)))
            continue
        f = F[sel]
        d = r[f] - c
        d = np.where(d == 0.0, 1e-12, d)
        pts = []
        for i, j in ((0, 1), (1, 2), (2, 0)):
            a, b = d[:, i], d[:, j]
            t = a / (a - b)
            cross = (a > 0) != (b > 0)
            pz = z[f[:, i]] + t * (z[f[:, j]] - z[f[:, i]])
            pt = th[f[:, i]] + t * (th[f[:, j]] - th[f[:, i]])
            pts.append((cross, pz, pt))
        # the two crossing edges of each triangle: first and second in edge order
        cr = np.stack([p[0] for p in pts], 1)
        PZ = np.stack([p[1] for p in pts], 1)
        PT = np.stack([p[2] for p in pts], 1)
        first = np.argmax(cr, axis=1)
        second = 2 - np.argmax(cr[:, ::-1], axis=1)
        ok = cr.sum(axis=1) == 2
        k = np.arange(len(f))[ok]
        z0, t0 = PZ[k, first[ok]], PT[k, first[ok]]
        z1, t1 = PZ[k, second[ok]], PT[k, second[ok]]
        n = np.maximum(1, np.ceil(np.hypot(z1 - z0, c * (t1 - t0)) / spacing).astype(int))
        seg = np.repeat(np.arange(len(z0)), n + 1)
        s = (np.arange(int((n + 1).sum())) - np.repeat(np.cumsum(n + 1) - (n + 1), n + 1)) \
            / np.repeat(n, n + 1)
        out.append(Section(c, z0[seg] + s * (z1 - z0)[seg], t0[seg] + s * (t1 - t0)[seg]))
    return out


def offset_table(cutter: Cutter, assembly: ToolAssembly, allowance: float, safety: float,
                 margin: float, step: float = 0.02, tilt: float = 0.0):
    """(h, o): heights h (mm, from −allowance below the tip up to the body's top) and the
    distance o(h) (mm) a section point at that height must keep from the tool's axis: the
    cutter's radius (flute) or the body's radius + ``safety`` (shank, holder), grown by a
    ball of radius ``allowance`` (the Minkowski sum of the solid of revolution), plus
    ``margin``. A tool tilted by ``tilt`` (rad) from radial reaches up to ρ sin(tilt) higher
    and lower in radius than its axial height: the table then takes the largest distance
    within that band (conservative)."""
    a = float(allowance)
    top = float(max(assembly.top, cutter.h))
    w = float(max(cutter.max_radius, assembly.max_radius + safety)) * math.sin(abs(tilt))
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
    if w > 0:
        n = max(3, int(math.ceil(2 * w / step)) | 1)
        best = np.full(len(h), -np.inf)
        for dlt in np.linspace(-w, w, n):
            best = np.maximum(best, np.interp(h + dlt, h, rho, left=-np.inf, right=-np.inf))
        rho = best
    return h, np.where(np.isfinite(rho), rho + margin, rho)


def channel_bounds(sections, pitch: float, z, r_tip, table, *, lead: float = 0.0,
                   side: float = 0.0):
    """Lower and upper θ bounds (rad, relative to the blade's mean angle) of the tip at the
    stations ``z`` (n,) with tip radii ``r_tip`` (n,): the tool clear of blade 0 (below) and
    blade 1 (above) at every height of ``table`` (:func:`offset_table`). ``lead`` and
    ``side`` are the axis tilts (rad). ±inf where no section is within reach."""
    z = np.asarray(z, float)
    r_tip = np.asarray(r_tip, float)
    hs, os_ = table
    h_lo, h_hi = float(hs[np.isfinite(os_)].min()), float(hs[np.isfinite(os_)].max())
    lo = np.full(len(z), -np.inf)
    hi = np.full(len(z), np.inf)
    tl, ts = math.tan(lead), math.tan(side)
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
        shift = (h[st] * ts / rc)[grp]
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
