"""The fixed-point lift of :func:`blisk_cam.core.paths.passes._fixed_point_lift`, compiled
(the same point–triangle distances operation for operation, the same steps: λ is the numpy
reference's to the last bit)."""

from __future__ import annotations

import numpy as np

from .backend import extension

__all__ = ["fixed_point_lift"]


def fixed_point_lift(V, F, cand, p, n, lam, consts, steps: int, threads: int):
    """(q,) λ (mm) after up to ``steps`` fixed-point steps for points ``p`` and unit normals
    ``n`` (q, 3) from ``lam`` (q,), on the candidate faces ``cand`` (q, c) of the mesh V, F
    (−1 padding); ``consts`` = (ρ, tolerance, gain, plane slack) mm. None when the numpy
    kernels run."""
    ext = extension()
    if ext is None:
        return None
    c = np.ascontiguousarray
    return ext.fixed_point_lift(
        c(V, dtype=np.float64), c(F, dtype=np.int64), c(cand, dtype=np.int64),
        c(p, dtype=np.float64), c(n, dtype=np.float64), c(lam, dtype=np.float64),
        tuple(float(x) for x in consts), int(steps), max(1, int(threads)))
