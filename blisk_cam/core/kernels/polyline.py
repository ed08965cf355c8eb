"""Distances from points to ball-centre polylines, compiled (``paths.expansion``'s
``PolylineDistance``): the k samples of the compiled k-d tree (:mod:`.knn`) nearest a hint
point name the candidate segments, the distance is the least over them, exact to each, with
the numpy reference's arithmetic operation for operation. Rows the tree cannot answer as
scipy would (a tie at the k-th nearest, fewer than k found) are flagged for the caller's
numpy answer. And the level samples those distances are measured at: a polyline resampled
along its offset (``paths.trial_levels._resample``, the same floats)."""

from __future__ import annotations

import numpy as np

from .backend import extension, kernel

__all__ = ["available", "polyline_distance", "resample_offset"]


def available() -> bool:
    """Whether the compiled polyline distance runs (the extension is installed, new enough,
    and not switched off)."""
    ext = extension()
    return ext is not None and hasattr(ext, "polyline_distance") and hasattr(ext, "PointTree")


def polyline_distance(tree, p, hint, k: int, seg_of_sample, a, ab, L2, threads: int):
    """(d (q,) float mm, fallback (q,) bool): the distance of each point ``p`` (q, 3) to the
    segments ``a + t ab`` (t ∈ [0, 1]; ``L2`` = |ab|², 0 replaced by 1) of the ``k`` samples
    of ``tree`` (a :func:`.knn.point_tree`) nearest its ``hint`` (q, 3);
    ``seg_of_sample`` (n,) int: the segment of each sample. ``fallback`` rows hold NaN (the
    caller measures them with scipy's k-d tree). On ``threads`` threads, the GIL released."""
    f64 = np.float64
    return extension().polyline_distance(
        tree, np.ascontiguousarray(p, dtype=f64), np.ascontiguousarray(hint, dtype=f64),
        int(k), np.ascontiguousarray(seg_of_sample, dtype=np.int64),
        np.ascontiguousarray(a, dtype=f64), np.ascontiguousarray(ab, dtype=f64),
        np.ascontiguousarray(L2, dtype=f64), max(1, int(threads)))


def resample_offset(points, normals, closed: bool, spacing: float, offset: float):
    """(points (q, 3) mm, normals (q, 3)): the polyline ``points`` (k, 3) with unit
    ``normals`` (k, 3) (``closed``: back to its first point too) resampled at most ``spacing``
    mm apart along ``points + offset · normals``, with the normals interpolated there (unit) —
    ``paths.trial_levels._resample(points, closed, spacing, normals, offset)``'s floats. None when
    the numpy kernels run (or the installed ones predate this kernel), or where the numpy
    reference must answer (fewer than two points, a length that is not finite)."""
    fn = kernel("resample_offset")
    if fn is None:
        return None
    c = np.ascontiguousarray
    return fn(c(points, dtype=np.float64), c(normals, dtype=np.float64),
              bool(closed), float(spacing), float(offset))
