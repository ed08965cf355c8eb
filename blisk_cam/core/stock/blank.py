"""The blank the program starts from, as radial dexels (:mod:`.dexels`):

* :func:`stock_from_profile` — a revolved (r, z) polygon (a forging or turned blank; CSV);
* :func:`stock_from_envelope` — the part's envelope plus a margin (the default blank);
* :func:`stock_from_allowance` — the part plus a uniform allowance (to check a finishing or
  semi-finishing program on its own, paper 003 §5: 0.5 mm after roughing, 0.1 mm after
  semi-finishing);
* :func:`stock_from_mesh` — a closed mesh of the blank (the whole ring, or one sector).

A closed surface is turned into intervals by casting the sector's rays through it
(:func:`mesh_crossings`: every triangle is rasterised onto the (θ, z) grid and each ray it
covers is intersected with its plane; the crossings of a ray, sorted, alternate in/out).

Units: mm, radians.
"""

from __future__ import annotations

import math
import os

import numpy as np

from ..errors import StockError
from ..geometry.axis import Axis
from ..geometry.mesh import triangle_normals
from ..geometry.mesh_io import MESH_SUFFIXES, read_mesh
from ..part.model import BliskPart, read_rz_csv, theta_about
from .dexels import RadialDexels, merge_intervals

__all__ = ["mesh_crossings", "stock_from_allowance", "stock_from_envelope", "stock_from_mesh",
           "stock_from_profile", "stock_from_spec", "is_part_based"]


def _fill(dex: RadialDexels, rays, a, b) -> RadialDexels:
    """Put the union of intervals (rays, a, b) into ``dex`` (replacing its material)."""
    rays, a, b, rank = merge_intervals(np.asarray(rays, np.int64), np.maximum(a, 0.0), b)
    K = max(2, int(rank.max()) + 1 if len(rank) else 1)
    lo = np.zeros((dex.n_rays, K))
    hi = np.zeros((dex.n_rays, K))
    lo[rays, rank] = a
    hi[rays, rank] = b
    dex.lo, dex.hi = lo, hi
    return dex


def _polygon_intervals(polygon, z):
    """Even-odd intervals of r where the horizontal lines ``z`` (k,) cross the closed (r, z)
    polygon: (row, a, b) arrays."""
    P = np.asarray(polygon, float)
    Q = np.roll(P, -1, axis=0)
    z = np.asarray(z, float)[:, None]
    z1, z2 = P[:, 1][None], Q[:, 1][None]
    cross = ((z1 <= z) & (z < z2)) | ((z2 <= z) & (z < z1))
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (z - z1) / (z2 - z1)
    r = np.where(cross, P[:, 0][None] + t * (Q[:, 0] - P[:, 0])[None], np.inf)
    r.sort(axis=1)
    n = cross.sum(axis=1)
    rows, a, b = [], [], []
    for k in range(0, r.shape[1] - 1, 2):
        ok = n >= k + 2
        rows.append(np.nonzero(ok)[0])
        a.append(r[ok, k])
        b.append(r[ok, k + 1])
    if not rows:
        return np.zeros(0, np.int64), np.zeros(0), np.zeros(0)
    return np.concatenate(rows), np.concatenate(a), np.concatenate(b)


def _checked_polygon(polygon) -> np.ndarray:
    P = np.asarray(polygon, float)
    if P.ndim != 2 or P.shape[1] != 2 or len(P) < 3 or not np.all(np.isfinite(P)):
        raise StockError(f"a blank profile must be a closed polygon of at least three (r, z) "
                         f"points in mm, got shape {P.shape}")
    if np.any(P[:, 0] < 0):
        raise StockError(f"blank profile: r must be ≥ 0 mm, got {P[:, 0].min():g}")
    if np.allclose(P[0], P[-1]):
        P = P[:-1]
    area = 0.5 * float(np.sum(P[:, 0] * np.roll(P[:, 1], -1) - np.roll(P[:, 0], -1) * P[:, 1]))
    if abs(area) < 1e-9:
        raise StockError("blank profile encloses no area; give the blank's closed outline "
                         "(r, z) in mm, e.g. bore, hub face, rim, other face")
    return P


def stock_from_profile(polygon, axis: Axis, blade_count: int, theta0: float,
                       resolution: float) -> RadialDexels:
    """The revolution of a closed (r, z) polygon (mm) as the stock of one sector."""
    P = _checked_polygon(polygon)
    z_lo, z_hi = float(P[:, 1].min()), float(P[:, 1].max())
    dex = RadialDexels.empty(axis, blade_count, theta0, (z_lo, z_hi), float(P[:, 0].max()),
                             resolution)
    rows, a, b = _polygon_intervals(P, dex.ray_z(np.arange(dex.n_z)))
    i = np.arange(dex.n_theta)
    rays = (rows[:, None] * dex.n_theta + i[None]).ravel()
    return _fill(dex, rays, np.repeat(a, dex.n_theta), np.repeat(b, dex.n_theta))


def envelope_with_margin(part: BliskPart, margin: float) -> np.ndarray:
    """The part's envelope polygon grown by ``margin`` mm outward in r and both ways in z
    (the bore kept)."""
    P = np.asarray(part.envelope, float).copy()
    zc = 0.5 * (P[:, 1].min() + P[:, 1].max())
    bore = P[:, 0].min()
    P[:, 1] = np.where(P[:, 1] > zc, P[:, 1] + margin, P[:, 1] - margin)
    P[:, 0] = np.where(P[:, 0] > bore + 1e-9, P[:, 0] + margin, P[:, 0])
    return P


def stock_from_envelope(part: BliskPart, margin: float, resolution: float) -> RadialDexels:
    """The default blank: the part's envelope plus ``margin`` mm."""
    if not margin >= 0:
        raise StockError(f"blank margin must be ≥ 0 mm, got {margin}")
    return stock_from_profile(envelope_with_margin(part, margin), part.axis, part.blade_count,
                              part.sector_start, resolution)


def mesh_crossings(dex: RadialDexels, V, F, *, wrap: bool, chunk: int = 20000):
    """Where the sector's rays cross the triangles (V, F): (rays, r) arrays (mm).

    ``wrap`` True: the mesh is one instance of a periodic part (a blade) and crossings of the
    neighbouring sectors' rays are the sector's own (periodicity); False: the mesh is whole
    and only rays inside the sector count."""
    V = np.asarray(V, float)
    F = np.asarray(F, np.int64)
    e1, e2, d = dex.axis.angular_frame()
    r, th, z = theta_about(V, dex.axis)
    out_r, out_ray = [], []
    for s in range(0, len(F), chunk):
        f = F[s:s + chunk]
        tf = th[f]
        tf = tf[:, :1] + np.mod(tf - tf[:, :1] + math.pi, 2 * math.pi) - math.pi
        c = (tf - dex.theta0) / dex.d_theta - 0.5  # ray columns at integers
        w = (z[f] - dex.z0) / dex.dz - 0.5
        ok = r[f].min(axis=1) > 1e-9
        w0 = np.maximum(np.ceil(w.min(axis=1)).astype(np.int64), 0)
        w1 = np.minimum(np.floor(w.max(axis=1)).astype(np.int64), dex.n_z - 1)
        nw = np.where(ok, np.maximum(w1 - w0 + 1, 0), 0)
        tot = int(nw.sum())
        if tot == 0:
            continue
        # scanlines: each row of the triangle's span, the columns between its edges there
        tri = np.repeat(np.arange(len(f)), nw)
        wi = w0[tri] + np.arange(tot) - np.repeat(np.cumsum(nw) - nw, nw)
        cc, ww = c[tri], w[tri]
        ca = np.full(tot, np.inf)
        cb = np.full(tot, -np.inf)
        for p_, q_ in ((0, 1), (1, 2), (2, 0)):
            wp, wq = ww[:, p_], ww[:, q_]
            cross = (np.minimum(wp, wq) <= wi) & (wi < np.maximum(wp, wq))
            with np.errstate(divide="ignore", invalid="ignore"):
                x = cc[:, p_] + (wi - wp) * (cc[:, q_] - cc[:, p_]) / (wq - wp)
            ca = np.where(cross, np.minimum(ca, x), ca)
            cb = np.where(cross, np.maximum(cb, x), cb)
        good = np.isfinite(ca) & np.isfinite(cb)
        c_lo = np.where(good, np.ceil(np.where(good, ca, 0)), 0).astype(np.int64)
        c_hi = np.where(good, np.floor(np.where(good, cb, -1)), -1).astype(np.int64)
        nc = np.maximum(c_hi - c_lo + 1, 0)
        cnt = int(nc.sum())
        if cnt == 0:
            continue
        tri = np.repeat(tri, nc)
        wi = np.repeat(wi, nc)
        ci = np.repeat(c_lo, nc) + np.arange(cnt) - np.repeat(np.cumsum(nc) - nc, nc)
        if not wrap:
            keep = (ci >= 0) & (ci < dex.n_theta)
            tri, ci, wi = tri[keep], ci[keep], wi[keep]
        P0 = V[f[tri, 0]]
        n = triangle_normals(V, f[tri])
        ang = dex.ray_theta(ci)
        u = np.cos(ang)[:, None] * e1 + np.sin(ang)[:, None] * e2
        O = dex.axis.o + dex.ray_z(wi)[:, None] * d
        den = np.einsum("ij,ij->i", n, u)
        good = np.abs(den) > 1e-14 * np.linalg.norm(n, axis=1)
        t = np.einsum("ij,ij->i", n, P0 - O) / np.where(good, den, 1.0)
        good &= t > 0
        out_r.append(t[good])
        out_ray.append(wi[good] * dex.n_theta + np.mod(ci[good], dex.n_theta))
    if not out_r:
        return np.zeros(0, np.int64), np.zeros(0)
    return np.concatenate(out_ray), np.concatenate(out_r)


def _parity_intervals(rays, r):
    """In/out pairs of sorted crossings per ray: (rays, a, b); an odd last crossing is
    dropped (a leak in the surface)."""
    order = np.lexsort((r, rays))
    rays, r = rays[order], r[order]
    if len(r) == 0:
        return rays, r, r
    first = np.ones(len(r), bool)
    first[1:] = rays[1:] != rays[:-1]
    grp = np.cumsum(first) - 1
    pos = np.arange(len(r)) - np.nonzero(first)[0][grp]
    nxt_same = np.zeros(len(r), bool)
    nxt_same[:-1] = rays[1:] == rays[:-1]
    s = (pos % 2 == 0) & nxt_same
    idx = np.nonzero(s)[0]
    return rays[idx], r[idx], r[idx + 1]


def stock_from_mesh(V, F, axis: Axis, blade_count: int, theta0: float,
                    resolution: float) -> RadialDexels:
    """A closed blank mesh (the whole ring, mm) as the stock of one sector."""
    V = np.asarray(V, float)
    F = np.asarray(F, np.int64)
    if len(F) < 4:
        raise StockError("the blank mesh has fewer than four triangles; give a closed mesh")
    r, _, z = theta_about(V, axis)
    dex = RadialDexels.empty(axis, blade_count, theta0, (float(z.min()), float(z.max())),
                             float(r.max()), resolution)
    rays, rr = mesh_crossings(dex, V, F, wrap=False)
    rays, a, b = _parity_intervals(rays, rr)
    if len(rays) == 0:
        raise StockError("the blank mesh does not cover the part's sector (no ray of the "
                         "sector crosses it); check the mesh and the axis")
    return _fill(dex, rays, a, b)


def _welded_faces(V, F) -> np.ndarray:
    """``F`` with every corner renumbered to the first vertex at the same position (exact
    coordinates): a triangle soup (an STL read as is, three corners per triangle) becomes a
    connected surface whose only boundary edges are its open ends, and whose vertex normals
    average the faces around each corner. The identity on a mesh without coincident
    vertices (its faces are returned unchanged)."""
    _, first, inv = np.unique(V, axis=0, return_index=True, return_inverse=True)
    return first[inv.reshape(-1)][F]


def _closed_offset_blade(part: BliskPart, allowance: float):
    """Blade 0 grown by ``allowance`` along its vertex normals, its open ends closed by
    tents: the foot's apex 3 mm + allowance below (inside the hub), the tip's above. Returns
    the closed mesh (W, G) and the tip loop's meridional points (k, 2) sorted by z (None
    for a closed blade)."""
    V = np.asarray(part.blade_vertices, float)
    F = _welded_faces(V, np.asarray(part.blade_faces, np.int64))
    N2 = triangle_normals(V, F)
    vn = np.zeros_like(V)
    for k in range(3):
        np.add.at(vn, F[:, k], N2)
    vn /= np.maximum(np.linalg.norm(vn, axis=1), 1e-300)[:, None]
    W = V + allowance * vn
    # boundary edges → loops (by vertex chains)
    E = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    key = np.sort(E, axis=1)
    _, inv, cnt = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    bnd = E[cnt[inv.reshape(-1)] == 1]
    if len(bnd) == 0:
        return W, F, None
    nxt = dict(zip(bnd[:, 0].tolist(), bnd[:, 1].tolist(), strict=True))
    seen, loops = set(), []
    for s in nxt:
        if s in seen:
            continue
        loop, v = [], s
        while v not in seen and v in nxt:
            seen.add(v)
            loop.append(v)
            v = nxt[v]
        loops.append(np.asarray(loop))
    e1, e2, d = part.axis.angular_frame()
    caps, extra = [], []
    base = len(W)
    rr, tt, zz = theta_about(W, part.axis)
    mean_r = [rr[lp].mean() for lp in loops]
    foot = int(np.argmin(mean_r))
    tip_loop = loops[int(np.argmax(mean_r))] if len(loops) > 1 else None
    for n, lp in enumerate(loops):
        th = math.atan2(np.sin(tt[lp]).mean(), np.cos(tt[lp]).mean())
        r_apex = (rr[lp].min() - 3.0 - allowance) if n == foot else (rr[lp].max() + 3.0)
        apex = part.axis.o + zz[lp].mean() * d + r_apex * (math.cos(th) * e1 + math.sin(th) * e2)
        extra.append(apex)
        a = base + len(extra) - 1
        caps.append(np.stack([lp, np.roll(lp, -1), np.full(len(lp), a)], 1))
    tip_rz = None
    if tip_loop is not None:
        r0, _, z0 = theta_about(V[tip_loop], part.axis)
        o = np.argsort(z0)
        tip_rz = np.stack([r0[o], z0[o]], 1)
    return np.vstack([W, np.asarray(extra)]), np.vstack([F] + caps), tip_rz


def stock_from_allowance(part: BliskPart, allowance: float, resolution: float, *,
                         grid: RadialDexels | None = None) -> RadialDexels:
    """The part plus a uniform ``allowance`` (mm): the hub's material up to the hub offset by
    the allowance, and blade 0 grown by it (periodic), the blade's material ending at the
    envelope's top plus the allowance. With a ``grid`` (a stock) the material is cast on that
    stock's own rays (its θ0, z0, cells; ``resolution`` is then the grid's): the part as that
    grid can hold it, ray for ray, which the verdicts compare the stock with."""
    a = float(allowance)
    if not (math.isfinite(a) and a >= 0):
        raise StockError(f"allowance must be a number ≥ 0 mm, got {allowance!r}")
    env = np.asarray(part.envelope, float)
    z_lo, z_hi = env[:, 1].min() - a, env[:, 1].max() + a
    if grid is not None:
        if grid.blade_count != part.blade_count:
            raise StockError(f"the stock is for {grid.blade_count} blades, the part has "
                             f"{part.blade_count}; use a stock made for this part")
        dex = RadialDexels(grid.axis, grid.blade_count, grid.theta0, grid.z0, grid.n_theta,
                           grid.n_z, grid.resolution, grid.r_max, np.zeros((grid.n_rays, 2)),
                           np.zeros((grid.n_rays, 2)))
    else:
        dex = RadialDexels.empty(part.axis, part.blade_count, part.sector_start, (z_lo, z_hi),
                                 float(env[:, 0].max()) + a, resolution)
    zs = dex.ray_z(np.arange(dex.n_z))
    bore = float(env[:, 0].min())
    # the hub profile offset along its meridional normal (away from the axis side)
    P = part.hub_profile
    seg = np.diff(P, axis=0)
    k = np.maximum(1, np.ceil(np.hypot(*seg.T) / (0.5 * resolution)).astype(int))
    pts = np.vstack([P[i] + seg[i] * (np.arange(k[i]) / k[i])[:, None] for i in range(len(seg))]
                    + [P[-1:]])
    tan = np.gradient(pts, axis=0)
    nrm = np.stack([tan[:, 1], -tan[:, 0]], 1)
    nrm /= np.maximum(np.linalg.norm(nrm, axis=1), 1e-300)[:, None]
    nrm *= np.where(nrm[:, :1] < 0, -1.0, 1.0)
    off = pts + a * nrm
    off = off[np.argsort(off[:, 1])]
    hub_top = np.interp(zs, off[:, 1], off[:, 0])
    in_hub = (zs >= P[0, 1] - a) & (zs <= P[-1, 1] + a)
    rows = np.nonzero(in_hub)[0]
    cols = np.arange(dex.n_theta)
    rays = [(rows[:, None] * dex.n_theta + cols[None]).ravel()]
    lo = [np.full(len(rays[0]), bore)]
    hi = [np.repeat(hub_top[rows], dex.n_theta)]
    # the blade, closed and grown, clipped at the envelope's top + allowance
    W, G, tip_rz = _closed_offset_blade(part, a)
    br, bc = mesh_crossings(dex, W, G, wrap=True)
    br, ba, bb = _parity_intervals(br, bc)
    # the blade ends at its tip (the open tip loop's meridional line) plus the allowance
    top = (np.interp(zs, tip_rz[:, 1], tip_rz[:, 0]) + a if tip_rz is not None
           else np.full(dex.n_z, np.inf))
    cap = top[br // dex.n_theta]
    bb = np.minimum(bb, cap)
    rays.append(br)
    lo.append(ba)
    hi.append(bb)
    return _fill(dex, np.concatenate(rays), np.concatenate(lo), np.concatenate(hi))


def is_part_based(spec: str) -> bool:
    """Whether the stock ``spec`` is made from the part (``allowance:MM``, ``envelope:MM``,
    not a file of that name): such a stock holds the part by construction."""
    kind, _, value = spec.partition(":")
    return kind in ("allowance", "envelope") and bool(value) and not os.path.exists(spec)


def stock_from_spec(spec: str, part: BliskPart, resolution: float) -> RadialDexels:
    """The stock a user names (``simulate --stock``, a job's ``[stock] blank``):
    ``allowance:MM`` (the part plus MM), ``envelope:MM`` (the part's envelope plus MM), a
    stock state ``.npz``, a closed mesh, or a closed (r, z) profile CSV; mm. StockError naming
    the spec when it is none of them."""
    if is_part_based(spec):
        kind, _, value = spec.partition(":")
        try:
            mm = float(value)
        except ValueError:
            raise StockError(f"stock {spec}: expected a number of mm after '{kind}:'") from None
        if kind == "allowance":
            return stock_from_allowance(part, mm, resolution)
        return stock_from_envelope(part, mm, resolution)
    if not os.path.isfile(spec):
        raise StockError(f"stock file {spec} not found (or give allowance:MM / envelope:MM)")
    suffix = os.path.splitext(spec)[1].lower()
    if suffix == ".npz":
        dex = RadialDexels.load(spec)
        if dex.blade_count != part.blade_count:
            raise StockError(f"stock state {spec} is for {dex.blade_count} blades, the part "
                             f"has {part.blade_count}")
        return dex
    if suffix in MESH_SUFFIXES:
        V, F = read_mesh(spec)
        return stock_from_mesh(V, F, part.axis, part.blade_count, part.sector_start,
                               resolution)
    return stock_from_profile(read_rz_csv(spec), part.axis, part.blade_count,
                              part.sector_start, resolution)
