"""The insertion of points where a polyline's normal turns (``densify_by_normal_turn`` of
:mod:`blisk_cam.core.paths.sampling`), compiled around numpy's own ``np.arccos``: the same
arithmetic, operation for operation, so the result is the numpy reference's to the last bit.

The arc cosines stay numpy's because its AVX-512 loops (on hosts that have them) round them
differently from the C library's ``acos`` (up to 2 ulp; numpy 1.26: 29 % of values, 2.5:
5 %); its float64 sines, square roots, divisions and the rest are the C library's or exact
on every host (``kernels/src/densify.rs``).
"""

from __future__ import annotations

import numpy as np

from .backend import kernel

__all__ = ["densify_by_normal_turn"]


def densify_by_normal_turn(points, normals, closed: bool, max_turn: float):
    """``sampling.densify_by_normal_turn`` on the compiled kernels: (points (k', 3) mm,
    normals (k', 3) unit, segment (k',) int64) from ``points`` (k, 3) mm, ``normals`` (k, 3)
    and ``max_turn`` radians; None when the numpy kernels run, for fewer than two points,
    and where a segment's normals are anti-parallel (the reference turns them through a
    perpendicular) — the caller then runs the numpy reference.
    """
    cosines, by_turn = kernel("densify_cosines"), kernel("densify_by_turn")
    if cosines is None or by_turn is None:
        return None
    P = np.ascontiguousarray(points, dtype=np.float64)
    N = np.ascontiguousarray(normals, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 3 or N.shape != P.shape or len(P) + bool(closed) < 2:
        return None
    N, cos = cosines(N, bool(closed))
    return by_turn(P, N, cos, np.arccos(cos), bool(closed), float(max_turn))
