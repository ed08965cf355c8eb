"""The slicing roots of :meth:`blisk_cam.core.paths.slicing.MeshConeSlicer._edge_roots` for a
linear morphing cone, compiled (the same arithmetic, operation for operation: the crossing
points and edge parameters are the numpy reference's to the last bit), and the whole crossing
part of :meth:`~blisk_cam.core.paths.slicing.MeshConeSlicer.slice` in one call."""

from __future__ import annotations

import numpy as np

from .backend import extension, kernel
from .mesh_orient import einsum_outer_first

__all__ = ["cone_edge_roots", "cone_level", "cone_slicer_field", "slicer_candidates",
           "slicer_face_index"]


def cone_edge_roots(r, z, radial, V, edges, edge_ids, line, on_tol: float, threads: int):
    """(points (k, 3) mm, t (k,)) — the crossings of the meridional line ``line`` = (α, β, γ)
    ((α, β) unit) on the mesh edges ``edge_ids`` (k,) of ``edges`` (ne, 2), from the
    vertices' meridional ``r``, ``z`` (n,) mm, radial vectors ``radial`` (n, 3) and positions
    ``V`` (n, 3); vertices within ``on_tol`` mm of the line count as on it. None when the
    numpy kernels run."""
    ext = extension()
    if ext is None:
        return None
    alpha, beta, gamma = (float(x) for x in line)
    c = np.ascontiguousarray
    return ext.cone_edge_roots(
        c(r, dtype=np.float64), c(z, dtype=np.float64), c(radial, dtype=np.float64),
        c(V, dtype=np.float64), c(edges, dtype=np.int64), c(edge_ids, dtype=np.int64),
        (alpha, beta, gamma, alpha**2), float(on_tol), max(1, int(threads)))


def cone_level(r, z, radial, V, vn, F, edges, face_edges, cand, line, on_tol: float,
               end_above_zero: bool):
    """The crossing part of ``MeshConeSlicer.slice`` for a linear morphing cone, in one call:
    of the candidate faces ``cand`` (c,) int of ``F`` (m, 3) (edges v0v1, v1v2, v2v0 in
    ``face_edges`` (m, 3) of ``edges`` (ne, 2)) those the meridional line ``line`` = (α, β, γ)
    crosses (a corner is above where its side f > 0, f ≥ 0 with ``end_above_zero``; vertices
    within ``on_tol`` mm on the line), and of their crossed edges the crossings and the smooth
    normals (``vn`` (n, 3) interpolated along the edge, unit) — the numpy reference's floats.

    Returns
    -------
    edges (u,) int64 ascending, links (f, 2) int64 (indices into ``edges``: entered below →
    above, left above → below), points (u, 3) mm, t (u,), normals (u, 3); None when the numpy
    kernels run (or the installed ones predate this kernel).
    """
    fn = kernel("cone_level")
    if fn is None:
        return None
    alpha, beta, gamma = (float(x) for x in line)
    c = np.ascontiguousarray
    f64, i64 = np.float64, np.int64
    return fn(
        c(r, dtype=f64), c(z, dtype=f64), c(radial, dtype=f64), c(V, dtype=f64),
        c(vn, dtype=f64), c(F, dtype=i64), c(edges, dtype=i64), c(face_edges, dtype=i64),
        c(cand, dtype=i64), (alpha, beta, gamma, alpha**2), float(on_tol), bool(end_above_zero))


def slicer_candidates(narrow, start: int, end: int, wide, smin, smax, lo: float, hi: float,
                      below: float):
    """(c,) int64 ascending: the faces ``narrow[start:end]`` with ``lo ≤ smin ≤ hi`` and
    ``smax ≥ below`` and the faces ``wide`` with ``smin ≤ hi`` and ``smax ≥ below`` (``smin``,
    ``smax`` (m,) float64 per face) — ``MeshConeSlicer._candidate_faces``'s ids, in one call
    with the GIL released; None when the numpy kernels run (or the installed ones predate
    this kernel)."""
    fn = kernel("slicer_candidates")
    if fn is None:
        return None
    c = np.ascontiguousarray
    return fn(
        c(narrow, dtype=np.int64), int(start), int(end), c(wide, dtype=np.int64),
        c(smin, dtype=np.float64), c(smax, dtype=np.float64), float(lo), float(hi),
        float(below))


def cone_slicer_field(V, o, d, F, ratio_consts):
    """The vertex and face fields of ``MeshConeSlicer`` for a cone pair, in two passes: (r
    (n,) mm, z (n,) mm, radial (n, 3) mm, s (n,), face smin (m,), face smax (m,)) of the
    vertices V (n, 3) float64 mm about the axis through ``o`` along ``d`` ((3,) float64) and
    the faces F (m, 3) int64 — ``geometry.axis.meridional``'s r, z, the radial vectors
    p − z d, ``MorphingCones.ratio``'s s and the faces' least and largest s, the same bits.
    z is numpy's own ``(V − o) @ d`` (OpenBLAS's dot). ``ratio_consts``: (p1 (2,), d1 (2,),
    dd (2,), cross2(d1, da), −cross2(dd, da), (α, β, γ) of s = 0) of the cone pair (floats).
    None when the numpy kernels run (or a wheel without this kernel), the arrays are of
    other types, or numpy adds einsum's products in an order the kernel does not know."""
    fn = kernel("cone_slicer_field")
    if (fn is None or V.dtype != np.float64 or F.dtype != np.int64 or V.ndim != 2
            or V.shape[1] != 3 or F.ndim != 2 or F.shape[1] != 3 or not V.flags.c_contiguous):
        return None
    outer_first = einsum_outer_first()
    if outer_first is None:
        return None
    p = V - o  # as meridional: p, then z = p @ d; p becomes the radial vectors in place
    z = p @ d
    p1, d1, dd, d1_da, k2, side = ratio_consts
    consts = [float(x) for x in (*p1, *d1, *dd, d1_da, k2, *side)]
    r, s, smin, smax = fn(p, z, [float(x) for x in d], consts,
                          np.require(F, requirements=("C_CONTIGUOUS", "ALIGNED")), outer_first)
    return r, z, p, s, smin, smax


def slicer_face_index(smin, smax, q: float, n_buckets: int, bucket_range):
    """``MeshConeSlicer._index_face_ranges`` of the faces' least and largest s ((m,) float64):
    (cut — the q-quantile of the finite spans smax − smin as ``np.quantile`` gives it —,
    bucket_lo, bucket_scale, narrow faces (k,) int64 by bucket then id, bucket starts
    (n_buckets + 1,) int64, wide faces (w,) int64 ascending); None when the numpy kernels
    run (or a wheel without this kernel)."""
    fn = kernel("slicer_face_index")
    if fn is None or smin.dtype != np.float64 or smax.dtype != np.float64:
        return None
    c = np.ascontiguousarray
    return fn(c(smin), c(smax), float(q), int(n_buckets),
              (float(bucket_range[0]), float(bucket_range[1])))
