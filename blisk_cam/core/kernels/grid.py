"""The barycentric sample grids of :func:`blisk_cam.core.verify.samples._grid_samples`,
compiled: the same arrays, value for value (the points are the reference's very sums)."""

from __future__ import annotations

import numpy as np

from .backend import extension

__all__ = ["grid_samples"]


def grid_samples(V, F, faces, nf):
    """(points (p, 3) mm, face (p,), bary (p, 3), vertex (p,), edges (e, 2), edge face (e,))
    of the grids of ``faces`` (k,) with ``nf`` (k,) segments per side on the mesh V (n, 3)
    mm, F (m, 3); None when the numpy kernels run (or an id or count is out of range: the
    reference then does what it does)."""
    ext = extension()
    if ext is None:
        return None
    c = np.ascontiguousarray
    return ext.grid_samples(c(V, dtype=np.float64), c(F, dtype=np.int64),
                            c(faces, dtype=np.int64), c(nf, dtype=np.int64))
