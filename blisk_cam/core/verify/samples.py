"""Surface samples of the machined region for :mod:`.verify`: a deterministic barycentric
grid on every triangle whose morph ratio lies in [0, 1], finer than ``spacing``, with the
smooth normal, plus the points where the grid edges cross the region's boundary cones.

Units are mm; numpy/scipy only (no bpy).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..errors import ToleranceError
from ..geometry.axis import Axis
from ..geometry.closest import barycentric
from ..geometry.mesh import TriMesh
from ..kernels import grid as compiled_grid
from ..part.cones import MorphingCones

__all__ = ["SurfaceSamples", "default_spacing", "surface_samples"]


# ================================================================== surface samples
@dataclass
class SurfaceSamples:
    """Samples of the mesh surface in the machined region.

    Attributes
    ----------
    points : (k, 3) float, mm — on the mesh
    normals : (k, 3) float — unit smooth normals (interpolated vertex normals)
    face : (k,) int64 — face of each sample
    bary : (k, 3) float — barycentric coordinates in that face
    s : (k,) float — morph ratio
    vertex : (k,) int64 — mesh vertex id of samples that are vertices, else −1
    edges : (e, 2) int64 — sample-grid edges (straight, inside one face, so on the mesh)
    edge_face : (e,) int64 — the face each grid edge lies in
    spacing : float, mm — grid spacing (upper bound of every grid edge length)
    n_boundary : int — the last ``n_boundary`` samples lie on the region boundary (s = 0 or 1)
    """

    points: np.ndarray
    normals: np.ndarray
    face: np.ndarray
    bary: np.ndarray
    s: np.ndarray
    vertex: np.ndarray
    edges: np.ndarray
    edge_face: np.ndarray
    spacing: float
    n_boundary: int = 0

    def __len__(self) -> int:
        return len(self.points)

    def at_vertices(self, values, n_vertices: int) -> np.ndarray:
        """(n_vertices,) the values (k′ ≥ k,) of the samples that are mesh vertices, at their
        vertices; NaN at the other vertices (outside the region)."""
        out = np.full(int(n_vertices), np.nan)
        isv = self.vertex >= 0
        out[self.vertex[isv]] = np.asarray(values)[: len(self)][isv]
        return out


@lru_cache(maxsize=128)
def _grid_template(n: int):
    """Barycentric grid of a triangle with n segments per side.

    Returns (bary (P, 3), corner (P,) int: 0/1/2 for the corners else −1, edges (E, 2)).
    """
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    keep = i + j <= n
    i, j = i[keep], j[keep]
    bary = np.stack([n - i - j, i, j], axis=1) / float(n)
    idx = -np.ones((n + 2, n + 2), dtype=np.int64)
    idx[i, j] = np.arange(len(i))
    corner = np.full(len(i), -1)
    corner[(i == 0) & (j == 0)] = 0
    corner[(i == n) & (j == 0)] = 1
    corner[(i == 0) & (j == n)] = 2
    e = []
    # (i, j)–(i+1, j), (i, j)–(i, j+1) and the diagonal (i+1, j)–(i, j+1)
    for (ai, aj), (bi, bj) in (((0, 0), (1, 0)), ((0, 0), (0, 1)), ((1, 0), (0, 1))):
        b0 = idx[i + ai, j + aj]
        b1 = idx[i + bi, j + bj]
        ok = (b0 >= 0) & (b1 >= 0)
        e.append(np.stack([b0[ok], b1[ok]], axis=1))
    edges = np.unique(np.sort(np.vstack(e), axis=1), axis=0)
    return bary, corner, edges


def default_spacing(tool_radius: float, cusp: float) -> float:
    """Default sample spacing (mm): a third of the flat-surface pass spacing of a ball,
    ``w = 2 sqrt(2 ρ h − h²)``; ρ/8 when the cusp height is not positive.

    A third is enough because the scallop ridges are located between the samples (see
    :func:`verify_path`); the samples only have to see which pass is the nearer one."""
    rho, h = float(tool_radius), float(cusp)
    if rho <= 0:
        raise ToleranceError(f"tool radius must be positive, got {rho} mm")
    if not (h > 0) or h >= rho:
        return rho / 8.0
    return 2.0 / 3.0 * np.sqrt(2.0 * rho * h - h * h)


def _grid_samples(V, F, faces, nf):
    """The barycentric grids of ``faces`` (nf (k,) segments per side), shared mesh vertices
    once: (points (p, 3), face (p,), bary (p, 3), mesh vertex or -1 (p,), grid edges (e, 2)
    as (lower, higher) sample ids, their face (e,)). The compiled kernel when it runs (the
    same arrays in ~1/4 of the CPU seconds, most of them the first touch of the output pages;
    this runs on verify's side thread beside the centre query);
    :func:`_grid_samples_numpy` is the reference."""
    out = compiled_grid.grid_samples(V, F, faces, nf)
    if out is not None:
        return out
    return _grid_samples_numpy(V, F, faces, nf)


def _grid_samples_numpy(V, F, faces, nf):
    """The numpy reference of :func:`_grid_samples`."""
    verts = np.unique(F[faces])
    vmap = np.full(len(V), -1, dtype=np.int64)
    vmap[verts] = np.arange(len(verts))
    nv = len(verts)
    # a face of each vertex, and the one-hot barycentric coordinates there
    vface = np.full(len(V), -1, dtype=np.int64)
    vcorner = np.zeros(len(V), dtype=np.int64)
    for k in (2, 1, 0):
        vface[F[faces, k]] = faces
        vcorner[F[faces, k]] = k
    pts = [V[verts]]
    face_l = [vface[verts]]
    bary_l = [np.eye(3)[vcorner[verts]]]
    edges_l, eface_l = [], []
    base = nv
    for n in np.unique(nf):
        fg = faces[nf == n]
        g = len(fg)
        bary, corner, tedges = _grid_template(int(n))
        nc = corner < 0
        bnc = bary[nc]
        npt = len(bnc)
        lmap = np.empty((g, len(bary)), dtype=np.int64)
        for k in range(3):
            lmap[:, corner == k] = vmap[F[fg, k]][:, None]
        lmap[:, nc] = base + np.arange(g * npt).reshape(g, npt)
        base += g * npt
        if npt:
            # (b0 a + b1 b) + b2 c: the order of einsum's sum here, written out (the
            # compiled kernel adds the same products in the same order)
            T = V[F[fg]]
            p = bnc[None, :, 0, None] * T[:, None, 0, :]
            p += bnc[None, :, 1, None] * T[:, None, 1, :]
            p += bnc[None, :, 2, None] * T[:, None, 2, :]
            pts.append(p.reshape(-1, 3))
            face_l.append(np.repeat(fg, npt))
            bary_l.append(np.tile(bnc, (g, 1)))
        edges_l.append(lmap[:, tedges].reshape(-1, 2))
        eface_l.append(np.repeat(fg, len(tedges)))
    P = np.vstack(pts)
    face = np.concatenate(face_l)
    bary = np.vstack(bary_l)
    vertex = np.full(len(P), -1, dtype=np.int64)
    vertex[:nv] = verts
    edges = np.vstack(edges_l)
    eface = np.concatenate(eface_l)
    # grid edges of n = 1 faces are mesh edges shared by two faces: keep one copy. Only they
    # can repeat (an edge of a finer grid has an end that is no mesh vertex, and those are
    # the face's own), and they come first (np.unique(nf) is ascending): the rest is kept
    # as it is (Rotor 37 has no n = 1 face: the unique of ~500k edges and its gathers were
    # ~40 % of this function)
    lo, hi = edges[:, 0], edges[:, 1]
    key = np.stack([np.minimum(lo, hi), np.maximum(lo, hi)], axis=1)  # np.sort(axis=1)'s
    n1 = int(np.count_nonzero(nf == 1)) * len(_grid_template(1)[2])
    if n1:
        # the first copy of each edge: one int64 per (low, high) pair (exact below 3e9
        # samples here) is unique exactly when the pair is, and a 1-D unique is far faster
        # than by rows
        _, first = np.unique(key[:n1, 0] * np.int64(base + 1) + key[:n1, 1],
                             return_index=True)
        keep = np.concatenate([np.sort(first), np.arange(n1, len(key))])
        key, eface = key[keep], eface[keep]
    return P, face, bary, vertex, key, eface


def _boundary_crossings(cones, axis, P, s, inside, edges, eface, s0, s1, s_tol):
    """Where the grid edges with one end inside and one outside meet the boundary cones,
    by regula falsi on the morph ratio: ([points (b, 3)], [faces (b,)]), empty lists if none."""
    ea, eb = edges[:, 0], edges[:, 1]
    cross = inside[ea] != inside[eb]
    bp, bf = [], []
    if np.any(cross):
        ca, cb, cf = ea[cross], eb[cross], eface[cross]
        pa, pb = P[ca], P[cb]
        sa, sb = s[ca], s[cb]
        out = np.where(inside[ca], sb, sa)
        target = np.where(out < s0 - s_tol, s0, s1)
        ga = np.clip(sa, -1e6, 1e6) - target
        gb = np.clip(sb, -1e6, 1e6) - target
        ta, tb = np.zeros(len(ca)), np.ones(len(ca))
        for _ in range(30):
            den = gb - ga
            t = np.where(np.abs(den) > 0, ta - ga * (tb - ta) / np.where(den != 0, den, 1.0),
                         0.5 * (ta + tb))
            t = np.clip(t, ta + 0.01 * (tb - ta), tb - 0.01 * (tb - ta))
            x = pa + t[:, None] * (pb - pa)
            gx = np.clip(cones.ratio_of_points(x, axis), -1e6, 1e6) - target
            left = np.sign(gx) == np.sign(ga)
            ta, ga = np.where(left, t, ta), np.where(left, gx, ga)
            tb, gb = np.where(left, tb, t), np.where(left, gb, gx)
            if np.max(np.abs(gx)) < 1e-12:
                break
        bp.append(x)
        bf.append(cf)
    return bp, bf


def surface_samples(
    mesh: TriMesh,
    cones: MorphingCones,
    axis: Axis,
    spacing: float,
    *,
    s_range=(0.0, 1.0),
    s_tol: float = 1e-9,
    max_samples: int = 6_000_000,
) -> SurfaceSamples:
    """Dense deterministic samples of the mesh between two morphing cones.

    Every triangle that reaches into the region gets a barycentric grid with
    ``n = ceil(longest edge / spacing)`` segments per side (its corners are shared mesh
    vertices); samples whose morph ratio lies outside ``s_range`` (± ``s_tol``) are dropped,
    and the points where the grid edges cross the two boundary cones are added (found by
    regula falsi on the morph ratio along the edge). Triangles are selected by the ratios of
    their corners (with a margin of 1e-3 of the range), which misses only a triangle bulging
    into the region between corners that are all outside it.

    Parameters
    ----------
    mesh : TriMesh
    cones : MorphingCones — cone 1 (s = 0) and cone 2 (s = 1)
    axis : Axis
    spacing : float, mm — longest allowed grid edge
    s_range : (float, float) — the region in morph ratio
    s_tol : float — tolerance on the ratio at the boundary
    max_samples : int — above this the spacing is enlarged (reported in ``.spacing``)

    Returns
    -------
    SurfaceSamples
    """
    spacing = float(spacing)
    if not (spacing > 0) or not np.isfinite(spacing):
        raise ToleranceError(f"sample spacing must be a positive number of mm, got {spacing}")
    s0, s1 = float(s_range[0]), float(s_range[1])
    V, F = mesh.V, mesh.F
    sv = cones.ratio_of_points(V, axis)
    fs = sv[F]
    margin = 1e-3 * max(s1 - s0, 1e-9)
    sel = (np.max(fs, axis=1) >= s0 - margin) & (np.min(fs, axis=1) <= s1 + margin)
    faces = np.nonzero(sel)[0]
    if len(faces) == 0:
        z3 = np.zeros((0, 3))
        zi = np.zeros(0, np.int64)
        return SurfaceSamples(z3, z3, zi, z3, np.zeros(0), zi, np.zeros((0, 2), np.int64), zi,
                              spacing)
    T = V[F[faces]]
    elen = np.linalg.norm(T - np.roll(T, -1, axis=1), axis=2).max(axis=1)

    def count(sp):
        n = np.maximum(np.ceil(elen / sp), 1).astype(np.int64)
        return n, int(np.sum((n + 1) * (n + 2) // 2 - 3))

    nf, total = count(spacing)
    while total > max_samples:
        spacing *= 1.25
        nf, total = count(spacing)

    P, face, bary, vertex, edges, eface = _grid_samples(V, F, faces, nf)
    s = cones.ratio_of_points(P, axis)
    inside = (s >= s0 - s_tol) & (s <= s1 + s_tol)
    bp, bf = _boundary_crossings(cones, axis, P, s, inside, edges, eface, s0, s1, s_tol)
    ea, eb = edges[:, 0], edges[:, 1]
    keep = np.nonzero(inside)[0]
    remap = np.full(len(P), -1, dtype=np.int64)
    remap[keep] = np.arange(len(keep))
    eok = inside[ea] & inside[eb]
    edges = remap[edges[eok]]
    eface = eface[eok]
    P, face, bary, vertex, s = P[keep], face[keep], bary[keep], vertex[keep], s[keep]
    nb = 0
    if bp:
        X = np.vstack(bp)
        fX = np.concatenate(bf)
        FX = F[fX]
        bX = np.clip(barycentric(X, V[FX[:, 0]], V[FX[:, 1]], V[FX[:, 2]]), 0.0, 1.0)
        bX /= bX.sum(axis=1, keepdims=True)
        P = np.vstack([P, X])
        face = np.concatenate([face, fX])
        bary = np.vstack([bary, bX])
        vertex = np.concatenate([vertex, np.full(len(X), -1, dtype=np.int64)])
        s = np.concatenate([s, cones.ratio_of_points(X, axis)])
        nb = len(X)
    normals = mesh.interpolate_normals(face, bary)
    isv = vertex >= 0
    normals[isv] = mesh.vertex_normals[vertex[isv]]
    return SurfaceSamples(P, normals, face, bary, s, vertex, edges, eface, spacing, nb)
