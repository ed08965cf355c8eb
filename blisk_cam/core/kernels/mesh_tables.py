"""Tables of a mesh for the passes' intrusion checks, compiled: the faces around each vertex
(the permutation of numpy's stable argsort, by a counting sort) and the k-d tree over every
vertex, edge midpoint and face centroid (the same sums, so the same points, as
:meth:`blisk_cam.core.paths.probe_samples._ProbeSamples.all_points`)."""

from __future__ import annotations

import numpy as np

from .backend import extension, kernel

__all__ = ["chain_directed", "sample_tree", "vertex_face_table"]


def vertex_face_table(F, n_vertices: int, *, narrow: bool = False):
    """(ptr (n + 1,), face (3 m,), corner (3 m,)) int64 of the faces F (m, 3): the faces of
    vertex v are ``face[ptr[v]:ptr[v + 1]]`` (ascending), v being their corner
    ``corner[...]``; None when the numpy kernels run. ``narrow``: face int32 and corner int8
    (the same values, made so at once; int64 from a wheel without that kernel), for F with
    3 m below 2³¹."""
    ext = extension()
    if ext is None:
        return None
    F = np.ascontiguousarray(F, dtype=np.int64)
    fn = getattr(ext, "vertex_face_table_narrow", None) if narrow else None
    if fn is not None:
        return fn(F, int(n_vertices))
    return ext.vertex_face_table(F, int(n_vertices))


def sample_tree(V, E, F, threads: int):
    """The compiled k-d tree (:func:`.knn.point_tree`'s kind) over the vertices V (n, 3) mm,
    the midpoints of the edges E (e, 2) and the centroids of the faces F (m, 3), numbered
    in that order; None when the numpy kernels run."""
    ext = extension()
    if ext is None:
        return None
    c = np.ascontiguousarray
    return ext.sample_point_tree(c(V, dtype=np.float64), c(E, dtype=np.int64),
                                 c(F, dtype=np.int64), max(1, int(threads)))


def chain_directed(n_nodes: int, links):
    """The chains of directed links (k, 2) over ``n_nodes`` (``geometry.mesh``'s
    ``_chain_directed``: a list of (order (p,) int64, closed bool), the same chains in the
    same order); None when the numpy kernels run or the links are not disjoint directed
    paths and cycles (the numpy reference then takes the general route)."""
    fn = kernel("chain_directed")
    if fn is None:
        return None
    got = fn(np.ascontiguousarray(links, dtype=np.int64), int(n_nodes))
    if got is None:
        return None
    order, starts, closed = got
    return [(order[starts[i]:starts[i + 1]], bool(closed[i])) for i in range(len(closed))]
