"""The orientation pass of ``geometry.mesh.TriMesh`` compiled: the face components by
union–find (scipy's sparse graph is the reference) and one pass over the faces for the
area vectors, unit normals, areas and the per-component sums of ``_capped_volume`` (numpy's
passes are the reference; the same values, bit for bit)."""

from __future__ import annotations

import functools

import numpy as np

from .backend import kernel

__all__ = ["einsum_outer_first", "face_components", "orient_face_terms", "repeats_on_edges"]


def face_components(F, edge_halfedges, threads: int = 1):
    """(count, labels (m,) int32, inconsistent int) of the faces F (m, 3) int64 and their
    edge table's ``edge_halfedges`` (e, 2) int64: the connected components of the faces
    linked by their interior edges, numbered as scipy's ``csgraph.connected_components``
    numbers them (by each component's lowest face), and on how many interior edges the two
    faces run the same way (``F.ravel()[h0] == F.ravel()[h1]`` of the
    ``weld._interior_pairs``); None when the numpy kernels run (or a wheel without this
    kernel). On ``threads`` threads (the same answer)."""
    fn = kernel("face_components")
    if fn is None or F.dtype != np.int64 or edge_halfedges.dtype != np.int64:
        return None
    req = ("C_CONTIGUOUS", "ALIGNED")
    return fn(np.require(F, requirements=req), np.require(edge_halfedges, requirements=req),
              max(1, int(threads)))


def repeats_on_edges(F, edge_halfedges, threads: int = 1):
    """``weld._repeats_on_edges`` of the faces F (m, 3) int64 read from their edge table's
    ``edge_halfedges`` (e, 2) int64 (no interior pairs built): whether the two faces of an
    interior edge have the same sum of vertex ids; None when the numpy kernels run (or a
    wheel without this kernel). On ``threads`` threads (the same answer)."""
    fn = kernel("repeats_on_edges")
    if fn is None or F.dtype != np.int64 or edge_halfedges.dtype != np.int64:
        return None
    req = ("C_CONTIGUOUS", "ALIGNED")
    return bool(fn(np.require(F, requirements=req),
                   np.require(edge_halfedges, requirements=req), max(1, int(threads))))


@functools.cache
def einsum_outer_first() -> bool | None:
    """How this process's numpy adds the three products of a row in
    ``np.einsum("ij,ij->i", a, b)`` over (k, 3) float64 rows (it depends on the SIMD loop
    numpy picks at run time): False for ``(p0 + p1) + p2`` (its AVX2 loop), True for
    ``(p0 + p2) + p1`` (its SSE and AVX-512 loops), None for any other order (the numpy
    reference then runs). Probed on rows whose sums tell the orders apart."""
    e = 2.0 ** -53  # 1 + e rounds to 1; −1 + e does not
    a = np.array([[1.0, e, -1.0], [e, 1.0, -1.0], [1.0, -1.0, e], [2.0, 3.0, 5.0]])
    got = tuple(float(x) for x in np.einsum("ij,ij->i", a, np.ones_like(a)))
    if got == (0.0, 0.0, e, 10.0):
        return False
    if got == (e, e, 0.0, 10.0):
        return True
    return None


def orient_face_terms(V, F, labels, ncomp: int, threads: int = 1):
    """``TriMesh._capped_volume``'s per-face pass: (n2 (m, 3), |n2| (m,), unit normals
    (m, 3), areas (m,) mm², volume (ncomp,) mm³, area (ncomp,) mm², V.mean(axis=0) (3,)
    mm) of V (n, 3) float64 mm,
    F (m, 3) int64 and the face components ``labels`` (m,) int32 — the area vectors
    ``triangle_normals`` gives, their norms, ``n2 / |n2|`` (zero where |n2| = 0), half the
    norms, and per component Σ ((V[F[:, 0]] − V.mean(axis=0)) · n2) / 6 and Σ area over its
    faces (no caps), the same bits as numpy's. None when the numpy kernels run, the arrays
    are of other types, numpy adds einsum's products in an order the kernel does not know,
    or an id is out of range. On ``threads`` threads (the same bits: the per-face terms by
    ranges of faces, the sums in face order)."""
    fn = kernel("orient_face_terms")
    if (fn is None or V.dtype != np.float64 or F.dtype != np.int64 or labels.dtype != np.int32
            or V.ndim != 2 or V.shape[1] != 3 or F.ndim != 2 or F.shape[1] != 3
            or labels.shape != (len(F),)):
        return None
    outer_first = einsum_outer_first()
    if outer_first is None:
        return None
    req = ("C_CONTIGUOUS", "ALIGNED")
    return fn(np.require(V, requirements=req), np.require(F, requirements=req),
              np.require(labels, requirements=req), int(ncomp), outer_first,
              max(1, int(threads)))
