"""The nearest centre segment of a swept ball, compiled (parry3d-f64's bounding-volume tree
over runs of consecutive segments prunes; the squared distances that decide are those of
:meth:`blisk_cam.core.verify.sweep_ball.SweptBall._d2`, operation for operation, so each
point's least squared distance is the numpy reference's float). Of segments at exactly the
same distance the highest id wins (numpy: the last in its tree's order; the distance is the
same)."""

from __future__ import annotations

import numpy as np

from .backend import extension, kernel

__all__ = ["first_hits", "forest_available", "forest_first_hits", "forest_nearest",
           "nearest_segments", "ridge_steps", "segment_tree"]


def segment_tree(a, b, d, dd):
    """The compiled tree of the segments a + t d, t ∈ [0, 1] (a, b = their ends, d (S, 3)
    mm; dd (S,) mm² |d|² with 0 replaced by 1); None when the numpy kernels run."""
    fn = kernel("SweptBallTree")
    if fn is None:
        return None
    c = np.ascontiguousarray
    return fn(c(a, dtype=np.float64), c(b, dtype=np.float64),
              c(d, dtype=np.float64), c(dd, dtype=np.float64))


def nearest_segments(tree, points, threads: int):
    """(d2 (k,) mm², seg (k,) int64): each point's (k, 3) least squared distance to the
    segments and the segment, on ``threads`` threads (the GIL released)."""
    return tree.nearest(np.ascontiguousarray(points, dtype=np.float64), max(1, int(threads)))


def first_hits(tree, points, directions, radius: float, max_height, threads: int):
    """(k,) mm: the first hit of each ray ``points + t directions`` ((k, 3), unit directions)
    with the capsules of ``radius`` mm around the tree's segments, ``inf`` beyond
    ``max_height`` (k,) mm or without one — ``SweptBall.height_along``'s figures (the ray–
    capsule arithmetic of :func:`..geometry.closest.ray_capsules_first_hit`), on ``threads``
    threads."""
    c = np.ascontiguousarray
    P = c(points, dtype=np.float64)
    h = c(np.broadcast_to(np.asarray(max_height, np.float64), (len(P),)))
    return tree.first_hits(P, c(directions, dtype=np.float64), float(radius), h,
                           max(1, int(threads)))


def forest_available() -> bool:
    """Whether the installed kernels query several swept balls' trees in one call
    (:func:`forest_nearest`, :func:`forest_first_hits`, :func:`ridge_steps`)."""
    ext = extension()
    return ext is not None and hasattr(ext, "ridge_steps")


def forest_nearest(trees, points, start, threads: int):
    """:func:`nearest_segments` of points (k, 3) sorted by tree, tree j's being
    ``start[j]:start[j + 1]`` (``start`` (len(trees) + 1,) int64), in one call on ``threads``
    threads: (d2 (k,), seg (k,)), each point's as its own tree gives it."""
    c = np.ascontiguousarray
    return extension().forest_nearest(list(trees), c(points, dtype=np.float64),
                                      c(start, dtype=np.int64), max(1, int(threads)))


def forest_first_hits(trees, points, directions, radius: float, max_height, start,
                      threads: int):
    """:func:`first_hits` of points sorted by tree (``start`` as in :func:`forest_nearest`)
    against their tree's capsules, in one call: (k,) mm."""
    c = np.ascontiguousarray
    P = c(points, dtype=np.float64)
    h = c(np.broadcast_to(np.asarray(max_height, np.float64), (len(P),)))
    return extension().forest_first_hits(list(trees), P, c(directions, dtype=np.float64),
                                         float(radius), h, c(start, dtype=np.int64),
                                         max(1, int(threads)))


def ridge_steps(trees, xa, xb, ga, gb, lo, radius: float, steps: int, threads: int):
    """The Illinois regula falsi of verify's scallop ridges on the levels' trees (None for a
    level without segments), every step of every edge in one call (see the kernel's
    docstring): (x (k, 3), d_lo (k,), d_hi (k,))."""
    c = np.ascontiguousarray
    return extension().ridge_steps(list(trees), c(xa, dtype=np.float64),
                                   c(xb, dtype=np.float64), c(ga, dtype=np.float64),
                                   c(gb, dtype=np.float64), c(lo, dtype=np.int64),
                                   float(radius), int(steps), max(1, int(threads)))
