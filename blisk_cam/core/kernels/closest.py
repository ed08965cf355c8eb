"""Nearest faces of a triangle mesh, compiled (a bounding-volume tree of boxes and oriented
boxes prunes, kernels/src/face_bvh.rs; the squared distances that decide are those of
:func:`blisk_cam.core.geometry.closest.closest_on_triangles`, operation for operation, so
the faces chosen are the numpy reference's)."""

from __future__ import annotations

import numpy as np

from .backend import extension

__all__ = ["face_tree", "nearest_closest", "nearest_faces", "triangle_d2"]


def face_tree(V, F, disks: bool = False):
    """The compiled tree of the faces F (m, 3) of vertices V (n, 3) mm; None when the numpy
    kernels run. ``disks``: keep a bound per face (15 floats a face) that makes queries far
    off the surface (ball centres) faster; the faces found are the same."""
    ext = extension()
    if ext is None:
        return None
    return ext.FaceTree(np.ascontiguousarray(V, dtype=np.float64),
                        np.ascontiguousarray(F, dtype=np.int64), bool(disks))


def nearest_faces(tree, points, threads: int):
    """(k,) int64 — for each point (k, 3) mm, the face at the least squared distance (the
    lowest id among equal ones; −1 for a non-finite point), on ``threads`` threads (the GIL
    released)."""
    return tree.nearest(np.ascontiguousarray(points, dtype=np.float64), max(1, int(threads)))


def nearest_closest(tree, points, threads: int):
    """(face (k,) int64, q (k, 3), d2 (k,), feature (k,) int8, bary (k, 3)): the faces of
    :func:`nearest_faces` and ``closest_on_triangles`` of each point and its face, computed
    with its arithmetic (a point without a face, −1, takes numpy's face −1: the last), on
    ``threads`` threads; None when the installed kernels predate it."""
    if not hasattr(tree, "nearest_closest"):
        return None
    return tree.nearest_closest(np.ascontiguousarray(points, dtype=np.float64),
                                max(1, int(threads)))


def triangle_d2(p, a, b, c):
    """The compiled squared distances of ``closest_on_triangles`` (pairwise (k, 3) rows), for
    the tests that compare them with the reference; None when the numpy kernels run."""
    ext = extension()
    if ext is None:
        return None
    return ext.triangle_d2(*(np.ascontiguousarray(x, dtype=np.float64) for x in (p, a, b, c)))
