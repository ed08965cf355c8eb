"""The slicing roots of :meth:`blisk_cam.core.paths.slicing.MeshConeSlicer._edge_roots` for a
linear morphing cone, compiled (the same arithmetic, operation for operation: the crossing
points and edge parameters are the numpy reference's to the last bit)."""

from __future__ import annotations

import numpy as np

from .backend import extension

__all__ = ["cone_edge_roots"]


def cone_edge_roots(r, z, radial, V, edges, edge_ids, line, on_tol: float, threads: int):
    """(points (k, 3) mm, t (k,)) — the crossings of the meridional line ``line`` = (α, β, γ)
    ((α, β) unit) on the mesh edges ``edge_ids`` (k,) of ``edges`` (ne, 2), from the
    vertices' meridional ``r``, ``z`` (n,) mm, radial vectors ``radial`` (n, 3) and positions
    ``V`` (n, 3); vertices within ``on_tol`` mm of the line count as on it. None when the
    numpy kernels run."""
    ext = extension()
    if ext is None:
        return None
    alpha, beta, gamma = (float(x) for x in line)
    c = np.ascontiguousarray
    return ext.cone_edge_roots(
        c(r, dtype=np.float64), c(z, dtype=np.float64), c(radial, dtype=np.float64),
        c(V, dtype=np.float64), c(edges, dtype=np.int64), c(edge_ids, dtype=np.int64),
        (alpha, beta, gamma, alpha**2), float(on_tol), max(1, int(threads)))
