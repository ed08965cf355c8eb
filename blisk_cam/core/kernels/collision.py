"""The refine step of collision detection, compiled: the exact minimum of a posed tool part's
signed distance over candidate triangles (:func:`blisk_cam.core.collision.tri_tree._refine`),
each pose's pairs together, the poses in parallel (rayon, the GIL released). The part's
distance is the numpy one operation for operation; the edges' golden-section searches stop
within 1e-9 mm of their minimum, and a pair skipped by its pose's bound returns a value above
the pose's minimum, as in numpy: the poses' minima agree within 1e-9 mm."""

from __future__ import annotations

import numpy as np

from .backend import extension

__all__ = ["available", "refine_pairs"]


def available() -> bool:
    """Whether the compiled refine runs."""
    ext = extension()
    return ext is not None and hasattr(ext, "refine_pairs")


def refine_pairs(part, A, B, C, nrm, ok, tip, axis, pose, ub, threads: int):
    """(best (k,) mm, where (k, 3) mm, ub (m,) lowered): ``part`` the part's floats (see
    ``tri_tree._part_spec``), triangles A, B, C and unit normals ``nrm`` (k, 3), ``ok`` (k,)
    bool (a usable normal), the poses ``tip``, ``axis`` (k, 3) of the pairs, ``pose`` (k,)
    their pose ids into ``ub`` (m,), the poses' upper bounds."""
    c = np.ascontiguousarray
    return extension().refine_pairs(
        [float(x) for x in part], *(c(x, dtype=np.float64) for x in (A, B, C, nrm)),
        c(ok, dtype=np.bool_), c(tip, dtype=np.float64), c(axis, dtype=np.float64),
        c(pose, dtype=np.int64), c(ub, dtype=np.float64), max(1, int(threads)))
