"""The exact-duplicate pass of the weld (:mod:`blisk_cam.core.geometry.weld`), compiled: one
pass over an open-addressing hash table instead of numpy's vectorised rounds (the answer,
the lowest index of the points with the same coordinate bits, does not depend on the hash)."""

from __future__ import annotations

import numpy as np

from .backend import extension

__all__ = ["first_equal_point"]


def first_equal_point(x, y, z):
    """For each point of the coordinate columns ``x, y, z`` ((k,) float64, mm, finite, no
    −0.0), the index of the first point equal to it, (k,) int64; None when the numpy
    kernels run."""
    ext = extension()
    if ext is None:
        return None
    return ext.first_equal_point(*(np.ascontiguousarray(c, dtype=np.float64) for c in (x, y, z)))
