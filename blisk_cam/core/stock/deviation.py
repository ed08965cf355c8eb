"""The verdict of a simulation: the deviation map on the part (Vericut's cut-vs-design
comparison), its summary, and the files that show it.

Deviation at a part vertex p with unit normal n (out of the metal): the position s of the
stock's surface along the line p + s n nearest to p — s > 0 material left (mm), s < 0 a gouge
(mm). The stock is read at samples a quarter of its resolution apart, and the material/air
boundary between two samples is refined by bisection; the figure is good to the stock's
resolution (a ray stands for its (θ, z) cell). Material beyond ``reach_out`` is reported as
``reach_out`` (the deviation is "at least" that), a gouge deeper than ``reach_in`` as
−``reach_in``.

Where the grid resolves a gouge (:func:`resolved_points`): a ray stands for its (θ, z) cell,
so the map reads each sample on its cell's ray, up to half a cell from the sample. Where a ray
grazes the surface (a blade's side: the rays run nearly along it) or clips a thin edge, the
ray points the map reads lie just under the surface whatever the sample's depth, and a clean
cut can empty them: the map would read a gouge that is the grid's. The part cast on the
stock's own rays (``stock_from_allowance(part, 0, res, grid=stock)``, exact along each ray)
and the distance to the part's surface tell, per vertex, whether one of the ray points the map
reads down to the tolerance lies deeper than a clean program cuts. There a clean program reads
no gouge past the tolerance and a gouge past it (and half a cell) does; elsewhere the vertex
is *not judged* — counted, with its area, never silently passed.
"""

from __future__ import annotations

import math
import struct

import numpy as np

from ..geometry.distance import MeshDistance
from ..geometry.mesh import TriMesh, triangle_normals
from ..part.model import BliskPart, theta_about
from .dexels import RadialDexels
from .removal import RemovalResult

__all__ = ["deviation_map", "ply_bytes", "resolved_points", "simulation_summary", "stock_skin",
           "stl_bytes", "surface_distance", "vertex_areas", "vertex_normals"]


def vertex_normals(V, F, hub=None) -> np.ndarray:
    """(n, 3) unit area-weighted vertex normals; faces flagged ``hub`` are turned to face away
    from the axis (out of the hub material) first when an axis' radial sense is known."""
    N2 = triangle_normals(V, F)
    if hub is not None and hub[0] is not None:
        mask, axis = hub
        cen = V[F].mean(axis=1) - axis.o
        radial = cen - (cen @ axis.d)[:, None] * axis.d
        flip = mask & (np.einsum("ij,ij->i", N2, radial) < 0)
        N2[flip] *= -1.0
    vn = np.zeros_like(V)
    for k in range(3):
        np.add.at(vn, F[:, k], N2)
    return vn / np.maximum(np.linalg.norm(vn, axis=1), 1e-300)[:, None]


def deviation_map(dex: RadialDexels, V, normals, *, reach_out: float = 2.0,
                  reach_in: float = 0.5, chunk: int = 20000) -> np.ndarray:
    """(n,) deviation (mm; + material left, − gouge) at points ``V`` (n, 3) along their unit
    ``normals`` (out of the metal). See the module docstring."""
    V = np.asarray(V, float)
    Nn = np.asarray(normals, float)
    h = 0.25 * dex.resolution
    k_out = max(1, int(math.ceil(reach_out / h)))
    k_in = max(1, int(math.ceil(reach_in / h)))
    s = np.arange(-k_in, k_out + 1) * h  # index k_in is s = 0
    out = np.empty(len(V))
    for a in range(0, len(V), chunk):
        p, n = V[a:a + chunk], Nn[a:a + chunk]
        m = len(p)
        pts = p[:, None, :] + s[None, :, None] * n[:, None, :]
        occ = dex.occupied(pts.reshape(-1, 3)).reshape(m, len(s))
        below = occ[:, k_in - 1]  # material just inside the surface?
        # material inside: the first air sample at or beyond s = −h going outward
        air_out = ~occ[:, k_in - 1:]
        first_air = np.where(air_out.any(axis=1), air_out.argmax(axis=1), -1)
        # air inside: the first material sample going inward from −h
        mat_in = occ[:, :k_in][:, ::-1]
        first_mat = np.where(mat_in.any(axis=1), mat_in.argmax(axis=1), -1)
        # brackets [material side, air side] in s
        lo_s = np.where(below, s[k_in - 1 + np.maximum(first_air, 1) - 1],
                        -h * (np.maximum(first_mat, 0) + 1))
        hi_s = np.where(below, s[k_in - 1 + np.maximum(first_air, 1)],
                        -h * np.maximum(first_mat, 0))
        for _ in range(6):
            mid = 0.5 * (lo_s + hi_s)
            o = dex.occupied(p + mid[:, None] * n)
            lo_s = np.where(o, mid, lo_s)
            hi_s = np.where(o, hi_s, mid)
        d = 0.5 * (lo_s + hi_s)
        d = np.where(below & (first_air < 0), reach_out, d)
        d = np.where(~below & (first_mat < 0), -reach_in, d)
        out[a:a + m] = d
    return out


def resolved_points(solid: RadialDexels, V, normals, tolerance: float, surface_distance, *,
                    cut_depth: float, allowance: float = 0.0) -> np.ndarray:
    """(n,) bool: where the deviation map at points ``V`` (n, 3) with unit ``normals`` (out of
    the metal) tells a gouge past ``tolerance`` (mm, below the surface the verdict judges: the
    part grown by ``allowance`` mm) from the grid's own reading.

    ``solid``: the part cast on the stock's own rays (``stock_from_allowance(part, 0, res,
    grid=stock)``); ``surface_distance``: a callable, (m, 3) points → (m,) their distance to
    the part's surface (mm, exact: :func:`surface_distance`); ``cut_depth`` (mm): how deep a
    clean program cuts below the judged surface (its chord tolerance: the linear moves between
    poses cut that far into the surface at most).

    The map reads the sample at p + s n on the ray of the sample's cell at the sample's radius
    (:meth:`.dexels.RadialDexels.ray_points`): up to half a cell across θ and z from the
    sample, so the depth of that ray point below the surface is not s — where a ray grazes
    the surface (a blade's side: its normal nearly across the rays) or clips a thin edge, it
    lies just under the surface whatever s. A ray point is *kept* when it lies more than
    ``cut_depth`` (+ 1/16 of a cell) below the judged surface, the depth measured exactly
    (inside the part by ``solid``, which is exact along the ray, and the distance to the
    part's surface): a clean program leaves it. A vertex is resolved when the map, reading
    inward from s = −¼ res, meets a kept ray point at a sample s ≥ a − ``tolerance`` (a the
    allowance): it then reads no gouge past the tolerance after a clean program, and a gouge
    deeper than the tolerance and half a cell removes that point and every sample above it
    and the map reads past the tolerance. (When the allowance is within ¼ res of the
    tolerance or above it, no such sample lies inside the part: every sample from −¼ res up
    to a − ``tolerance`` must then be kept, the map reading outward.) Elsewhere a clean cut
    can empty the rays the map reads and it would show a gouge that is the grid's: those
    vertices are not resolved (the verdicts count them as not judged).

    Cost: per point, at most one occupancy look-up and one distance query per sample."""
    V = np.asarray(V, float)
    Nn = np.asarray(normals, float)
    h = 0.25 * solid.resolution
    a = float(allowance)
    need = max(float(cut_depth), 0.0) + 0.25 * h
    lowest = (a - float(tolerance)) / h  # samples s = m h with m ≥ lowest
    inward = list(range(-1, int(math.ceil(lowest - 1e-9)) - 1, -1))

    def kept(idx, m):
        Q = solid.ray_points(V[idx] + (m * h) * Nn[idx])
        inside = solid.occupied(Q)
        # a point outside the part lies at most `a` below the judged surface
        cand = np.flatnonzero(inside if a <= need else np.ones(len(Q), bool))
        out = np.zeros(len(idx), bool)
        if len(cand):
            d = np.asarray(surface_distance(Q[cand]), float)
            out[cand] = a + np.where(inside[cand], d, -d) >= need
        return out

    if inward:  # any kept sample the map meets reading inward, deepest first
        ok = np.zeros(len(V), bool)
        for m in inward[::-1]:
            todo = np.flatnonzero(~ok)
            if len(todo) == 0:
                break
            ok[todo] = kept(todo, m)
        return ok
    ok = np.ones(len(V), bool)  # every sample from −¼ res out to a − tolerance
    for m in range(-1, int(math.ceil(lowest - 1e-9)) + 1):
        todo = np.flatnonzero(ok)
        if len(todo) == 0:
            break
        ok[todo] = kept(todo, m)
    return ok


def surface_distance(V, F):
    """A callable: (m, 3) points → (m,) their exact distance (mm) to the triangles (V, F)
    (the part's surface, for :func:`resolved_points`)."""
    md = MeshDistance(TriMesh.from_arrays(np.asarray(V, float), np.asarray(F, np.int64)),
                      compiled=True)
    return lambda P: md.query(np.asarray(P, float)).distance


def vertex_areas(V, F) -> np.ndarray:
    """(n,) mm²: a third of the area of every face around each vertex (the vertices' areas
    sum to the mesh's)."""
    F = np.asarray(F, np.int64)
    a = 0.5 * np.linalg.norm(triangle_normals(V, F), axis=1) / 3.0
    out = np.zeros(len(V))
    for k in range(3):
        np.add.at(out, F[:, k], a)
    return out


def simulation_summary(part: BliskPart, dex: RadialDexels, removal: RemovalResult, V, dev,
                       *, gouge_tolerance: float, initial_volume: float,
                       reached=None, allowance: float = 0.0, resolved=None,
                       area=None) -> dict:
    """The verdict as a JSON-ready dict: volumes (sector and whole blisk, mm³), deviation
    figures (mm), the largest gouge and where, crashes, and ``passed`` (no crash, no gouge
    deeper than ``gouge_tolerance``). With an ``allowance`` a > 0 (the programs leave stock:
    semi-finishing) a gouge is a cut into the allowance: the depth below a (deviation < a),
    and ``deviation_mm.allowance`` says a. ``resolved`` (n,) bool (:func:`resolved_points`;
    None: every vertex): gouges are judged on those vertices only; the others are counted as
    not judged (``not_judged_vertices``, and with ``area`` (n,) mm² per vertex,
    ``not_judged_area_mm2``)."""
    dev = np.asarray(dev, float)
    left = dev[dev > 0]
    sel = dev if reached is None else dev[np.asarray(reached, bool)]
    judged = np.isfinite(dev) if resolved is None else np.asarray(resolved, bool) & np.isfinite(dev)
    worst = int(np.flatnonzero(judged)[np.argmin(dev[judged])]) if judged.any() else -1
    a = float(allowance)
    gouge = float(a - dev[worst]) if worst >= 0 and dev[worst] < a else 0.0
    n = part.blade_count
    r, th, z = theta_about(V[worst:worst + 1], part.axis) if worst >= 0 else (0, 0, 0)
    passed = not removal.crashes and gouge <= gouge_tolerance
    summary = {
        "passed": bool(passed),
        "blade_count": n,
        "resolution_mm": dex.resolution,
        "rays": dex.n_rays,
        "rows": removal.rows,
        "sub_poses": removal.sub_poses,
        "volume_initial_mm3": {"sector": initial_volume, "blisk": initial_volume * n},
        "volume_removed_mm3": {"sector": removal.volume, "blisk": removal.volume * n,
                               "by_move": {k: v for k, v in removal.removed.items()}},
        "volume_remaining_mm3": {"sector": dex.volume(), "blisk": dex.volume() * n},
        "deviation_mm": {
            "vertices": int(len(dev)),
            "max_left": float(left.max()) if len(left) else 0.0,
            "p95_left": float(np.percentile(left, 95)) if len(left) else 0.0,
            "max_left_reached": float(sel.max()) if len(sel) else 0.0,
            "max_gouge": gouge,
            "max_gouge_at_mm": [round(float(x), 4) for x in V[worst]] if worst >= 0 else None,
            "max_gouge_at_r_theta_deg_z": ([round(float(r[0]), 4),
                                            round(math.degrees(float(th[0])), 4),
                                            round(float(z[0]), 4)] if worst >= 0 else None),
            "gouge_tolerance": float(gouge_tolerance),
            "gouged_vertices": int((judged & (dev < a - gouge_tolerance)).sum()),
            "not_judged_vertices": int((~judged).sum()),
            **({"not_judged_area_mm2": round(float(np.asarray(area, float)[~judged].sum()), 3),
                "area_mm2": round(float(np.asarray(area, float).sum()), 3)}
               if area is not None else {}),
            **({"allowance": a} if a else {}),
        },
        "crashes": [c.as_dict() for c in removal.crashes],
    }
    return summary


def ply_bytes(V, F, dev, judged=None) -> bytes:
    """Binary little-endian PLY of the mesh with a per-vertex float ``deviation`` (mm) and,
    with ``judged`` ((n,) bool), a per-vertex uchar ``judged`` (1: the verdict judges the
    vertex; 0: below the stock's resolution or inside the part, its reading not judged)."""
    V = np.asarray(V, "<f4")
    F = np.asarray(F, "<i4")
    fields = [("p", "<f4", 3), ("d", "<f4")] + ([("j", "u1")] if judged is not None else [])
    head = ("ply\nformat binary_little_endian 1.0\ncomment blisk_cam deviation map, mm "
            "(+ material left, - gouge)\n"
            + ("comment judged: 1 where the verdict judges the vertex, 0 where the stock's "
               "resolution cannot\n" if judged is not None else "")
            + f"element vertex {len(V)}\nproperty float x\nproperty float y\nproperty float z\n"
            "property float deviation\n"
            + ("property uchar judged\n" if judged is not None else "")
            + f"element face {len(F)}\nproperty list uchar int vertex_indices\nend_header\n")
    vert = np.empty(len(V), dtype=fields)
    vert["p"] = V
    vert["d"] = np.asarray(dev, "<f4")
    if judged is not None:
        vert["j"] = np.asarray(judged, bool)
    face = np.empty(len(F), dtype=[("n", "u1"), ("i", "<i4", 3)])
    face["n"] = 3
    face["i"] = F
    return head.encode("ascii") + vert.tobytes() + face.tobytes()


def stock_skin(dex: RadialDexels, copies: int = 1):
    """The remaining stock as a skin of triangles: every interval end of every ray is its
    (θ, z) cell's patch at that radius (not welded — a picture of the dexels, not a solid),
    over ``copies`` pitch sectors. Returns V (n, 3), F (m, 3)."""
    e1, e2, d = dex.axis.angular_frame()
    ray, slot = np.nonzero(dex.hi > dex.lo)
    Vs, Fs = [], []
    base = 0
    for k in range(int(copies)):
        for ends in (dex.lo[ray, slot], dex.hi[ray, slot]):
            i = ray % dex.n_theta + k * dex.n_theta
            j = ray // dex.n_theta
            t0, t1 = dex.ray_theta(i - 0.5), dex.ray_theta(i + 0.5)
            z0, z1 = dex.ray_z(j - 0.5), dex.ray_z(j + 0.5)
            corners = []
            for t, zz in ((t0, z0), (t1, z0), (t1, z1), (t0, z1)):
                corners.append(dex.axis.o + zz[:, None] * d
                               + ends[:, None] * (np.cos(t)[:, None] * e1
                                                  + np.sin(t)[:, None] * e2))
            Q = np.stack(corners, 1).reshape(-1, 3)
            q = base + 4 * np.arange(len(ends))[:, None]
            Fs.append(np.vstack([np.hstack([q, q + 1, q + 2]), np.hstack([q, q + 2, q + 3])]))
            Vs.append(Q)
            base += len(Q)
    if not Vs:
        return np.zeros((0, 3)), np.zeros((0, 3), np.int64)
    return np.vstack(Vs), np.vstack(Fs)


def stl_bytes(V, F, name: str = "blisk_cam stock") -> bytes:
    """Binary STL of (V, F)."""
    V = np.asarray(V, float)
    F = np.asarray(F, np.int64)
    n = triangle_normals(V, F)
    n /= np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]
    rec = np.zeros(len(F), dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])
    rec["n"] = n
    rec["v"] = V[F]
    return name.encode("ascii")[:80].ljust(80, b" ") + struct.pack("<I", len(F)) + rec.tobytes()
