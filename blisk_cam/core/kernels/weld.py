"""The exact-duplicate pass of the weld (:mod:`blisk_cam.core.geometry.weld`), compiled: one
pass over an open-addressing hash table instead of numpy's vectorised rounds (the answer,
the lowest index of the points with the same coordinate bits, does not depend on the hash)."""

from __future__ import annotations

import numpy as np

from .backend import extension, kernel

__all__ = ["edge_table", "first_equal_point", "first_equal_rows", "interior_pairs",
           "interpolate_normals", "stl_corners_welded", "triangle_normals",
           "vertex_normals"]


def first_equal_point(x, y, z):
    """For each point of the coordinate columns ``x, y, z`` ((k,) float64, mm, finite, no
    −0.0), the index of the first point equal to it, (k,) int64; None when the numpy
    kernels run."""
    ext = extension()
    if ext is None:
        return None
    return ext.first_equal_point(*(np.ascontiguousarray(c, dtype=np.float64) for c in (x, y, z)))


def first_equal_rows(V):
    """For each row of ``V`` ((k, 3) float64, mm, finite), the index of the first row equal to
    it (−0.0 counted as 0.0: the answer :func:`first_equal_point` gives for the columns
    ``V[:, j] + 0.0``), (k,) int64, read from the rows (no column copies); None when the
    numpy kernels run (or a wheel without this kernel, or more rows than it takes)."""
    fn = kernel("first_equal_rows")
    if fn is None:
        return None
    # aligned too: the caller's arrays may sit at any byte of a buffer (dask hands a task's
    # arrays over in its message frames), which np.ascontiguousarray keeps as they are
    return fn(np.require(V, dtype=np.float64, requirements=("C_CONTIGUOUS", "ALIGNED")))


def stl_corners_welded(records, n: int):
    """A binary STL's ``n`` triangles welded exactly as they are read, from its records
    ``records`` (the file's bytes after the 84-byte header, (50 n,) uint8): (V (k, 3) float64
    mm — the distinct corners in the order of their first appearance, each that corner's
    float32 value widened —, F (n, 3) int64 over them), what ``geometry.weld``'s exact pass
    makes of the float64 soup the numpy reader builds (−0.0 equal to 0.0). None when the
    numpy kernels run (or a wheel without this kernel), or when a coordinate is NaN or
    infinite (the reader then names the problem)."""
    fn = kernel("stl_corners_welded")
    if fn is None:
        return None
    got = fn(records, int(n))
    if got is None:
        return None
    V, corner = got
    return V.reshape(-1, 3), corner.reshape(-1, 3)


def edge_table(F, n_vertices: int, threads: int = 1):
    """The edge table of the faces F (m, 3) over ``n_vertices`` (``geometry.weld``'s
    ``_edge_table``: a dict of ``edges``, ``face_edges``, ``edge_halfedges``,
    ``edge_faces``, the same arrays) by a counting sort of the half-edges; None when the
    numpy kernels run (or a wheel without this kernel), when an edge has more than two faces
    (the numpy reference then raises) or the ids exceed 32 bits. On ``threads`` threads (the
    same arrays)."""
    fn = kernel("edge_table_arrays")
    if fn is None:
        return None
    got = fn(np.ascontiguousarray(F, dtype=np.int64), int(n_vertices), max(1, int(threads)))
    if got is None:
        return None
    edges, face_edges, edge_halfedges, edge_faces = got
    return {"edges": edges, "face_edges": face_edges, "edge_faces": edge_faces,
            "edge_halfedges": edge_halfedges}


def triangle_normals(V, F):
    """``geometry.mesh.triangle_normals`` of V (n, 3) float64 and F (m, 3) int64 in one pass
    (the same products and differences, so the same bits), (m, 3) float64; None when the
    numpy kernels run, the arrays are of other types, or an id is out of range."""
    fn = kernel("triangle_normals")
    if (fn is None or V.dtype != np.float64 or F.dtype != np.int64 or len(F) == 0
            or V.ndim != 2 or V.shape[1] != 3 or F.ndim != 2 or F.shape[1] != 3):
        return None
    req = ("C_CONTIGUOUS", "ALIGNED")
    return fn(np.require(V, requirements=req), np.require(F, requirements=req))


def vertex_normals(n_vertices: int, F, n2):
    """``TriMesh.vertex_normals`` in one call: the area vectors n2 (m, 3) float64 of the
    faces F (m, 3) int64 summed per vertex as the numpy reference does (a weighted
    ``bincount`` per corner, the corners' sums added in order) and divided by their norm
    (``np.linalg.norm``'s sum of squares, 1.0 where it is not positive), (n, 3) float64, the
    same bits; None when the numpy kernels run (or a wheel without this kernel), the arrays
    are of other types, or an id is out of range."""
    fn = kernel("vertex_normals_of")
    if (fn is None or F.dtype != np.int64 or n2.dtype != np.float64 or len(F) == 0
            or F.ndim != 2 or F.shape[1] != 3 or n2.shape != F.shape):
        return None
    req = ("C_CONTIGUOUS", "ALIGNED")
    return fn(int(n_vertices), np.require(F, requirements=req), np.require(n2, requirements=req))


def interpolate_normals(vn, F, faces, bary):
    """``TriMesh.interpolate_normals``: the vertex normals vn (n, 3) float64 of the corners
    of faces (k,) int64 (rows of F (m, 3) int64) weighted by bary (k, 3) float64, added in
    the corners' order and normalised as the numpy reference does (the same bits), (k, 3)
    float64; None when the numpy kernels run, the arrays are of other types or shapes, or
    an id is out of range (numpy's turn: it wraps negative face ids)."""
    fn = kernel("interpolate_normals")
    if (fn is None or vn.dtype != np.float64 or F.dtype != np.int64
            or faces.dtype != np.int64 or bary.dtype != np.float64 or faces.ndim != 1
            or F.ndim != 2 or F.shape[1] != 3 or vn.ndim != 2 or vn.shape[1] != 3
            or bary.shape != (len(faces), 3)):
        return None
    req = ("C_CONTIGUOUS", "ALIGNED")
    return fn(np.require(vn, requirements=req), np.require(F, requirements=req),
              np.require(faces, requirements=req), np.require(bary, requirements=req))


def interior_pairs(edge_halfedges):
    """``geometry.weld._interior_pairs`` from an edge table's ``edge_halfedges`` (e, 2):
    (h0, h1, f0, f1) (p,) int64 in one pass; None when the numpy kernels run."""
    fn = kernel("interior_pairs")
    if fn is None:
        return None
    return fn(np.ascontiguousarray(edge_halfedges, dtype=np.int64))
