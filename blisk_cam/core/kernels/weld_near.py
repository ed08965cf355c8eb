"""The tolerance pass of the weld (``geometry.weld._welded``) compiled for points that are
all distinct (an STL welded exactly as it is read): the columns' extents, and whether
numpy's scan along the weld direction (``weld._close_pairs``) finds no pair at all, without
numpy's column copies, projections and stable argsort. Anything else is numpy's."""

from __future__ import annotations

import numpy as np

from .backend import kernel

__all__ = ["weld_extents", "weld_no_close_pairs"]

_REQ = ("C_CONTIGUOUS", "ALIGNED")


def weld_extents(V):
    """(3,) float64 mm: ``c.max() − c.min()`` of each column c of ``V + 0.0`` (V (k, 3)
    float64, finite), the same values; None when the numpy kernels run (or a wheel without
    this kernel)."""
    fn = kernel("weld_extents")
    if fn is None or V.dtype != np.float64 or V.ndim != 2 or V.shape[1] != 3 or len(V) == 0:
        return None
    return fn(np.require(V, requirements=_REQ))


def weld_no_close_pairs(V, direction, tol: float, scan_max: int) -> bool:
    """True when ``weld._close_pairs`` of all the points V (k, 3) float64 mm (distinct,
    finite), sorted by their projection on the unit ``direction`` (3,), finds no pair within
    ``tol`` mm (and runs: no two equal projections, no point with more than ``scan_max``
    neighbours within the tolerance of projection); False when it would find one or not
    run, or when the numpy kernels run (the caller then runs numpy's scan)."""
    fn = kernel("weld_no_close_pairs")
    if fn is None or V.dtype != np.float64 or V.ndim != 2 or V.shape[1] != 3:
        return False
    return bool(fn(np.require(V, requirements=_REQ), [float(x) for x in direction],
                   float(tol), int(scan_max)))
