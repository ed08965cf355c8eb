"""Surfaces of revolution about the blisk axis, as arrays: angles of points about the axis
and the grid of a revolved generatrix (a cone, or a polyline profile). The Blender side turns
these into objects (``blender_io.cone_to_object``); the demo and the output collection use
the angular ranges.

Angles θ about the axis follow :meth:`.cones.Axis.angular_frame` (for the axis +Z, θ is
``atan2(y, x)``). Lengths mm, angles radians.
"""

from __future__ import annotations

import math

import numpy as np

from .cones import Axis, Cone

__all__ = ["angular_range", "angular_span", "generatrix_rows", "revolve"]


def angular_span(points, axis: Axis) -> tuple[float, float]:
    """(mean angle, half width), radians, of (n, 3) points about ``axis`` (mm)."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    e1, e2, _ = axis.angular_frame()
    rel = p - axis.o
    th = np.arctan2(rel @ e2, rel @ e1)
    mean = math.atan2(float(np.mean(np.sin(th))), float(np.mean(np.cos(th))))
    half = float(np.max(np.abs(np.angle(np.exp(1j * (th - mean))))))
    return mean, half


def angular_range(points, axis: Axis, margin: float = 0.3) -> tuple[float, float]:
    """(θ0, θ1) radians about ``axis`` covering ``points`` (n, 3) mm, widened by ``margin`` ×
    their half width (+ 0.02 rad) on each side. A full turn (0, 2π) when the points go
    (nearly) all around, or when there are none."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if len(p) == 0:
        return 0.0, 2.0 * np.pi
    mean, half = angular_span(p, axis)
    half = half * (1.0 + margin) + 0.02
    if half >= np.pi:
        return 0.0, 2.0 * np.pi
    return mean - half, mean + half


def generatrix_rows(generatrix, rows: int, extend: float) -> np.ndarray:
    """(k, 2) meridional points (r, z), mm, of a generatrix from its first to its last point,
    lengthened by ``extend`` mm at both ends along the end segments (r clamped ≥ 0). A
    ``Cone`` gives ``rows + 1`` evenly spaced points (a straight line: exact); a ``Profile``
    its vertices, each segment split into ``ceil(rows / segments)`` steps."""
    if isinstance(generatrix, Cone):
        P = np.array([generatrix.p1, generatrix.p2], dtype=np.float64)
        per = rows
    else:
        P = np.asarray(generatrix.vertices, dtype=np.float64).copy()
        per = max(1, -(-rows // (len(P) - 1)))
    if extend:
        for end, nb in ((0, 1), (-1, -2)):
            u = P[end] - P[nb]
            P[end] = P[end] + extend * u / np.linalg.norm(u)
    t = np.arange(per) / per
    rz = np.concatenate([(1.0 - t)[:, None] * a + t[:, None] * b
                         for a, b in zip(P[:-1], P[1:], strict=True)] + [P[-1:]])
    rz[:, 0] = np.maximum(rz[:, 0], 0.0)
    return rz


def revolve(rz, axis: Axis, theta=(0.0, 2.0 * math.pi), segments: int = 128):
    """The quad grid of meridional points ``rz`` (k, 2) mm revolved about ``axis`` over the
    angles ``theta`` in ``segments`` steps: V ((k · s'), 3) mm and F (q, 4) int64 quads, with
    s' = segments for a full turn (a closed band) and segments + 1 otherwise. Every vertex
    lies on the surface of revolution of the polyline."""
    rz = np.asarray(rz, dtype=np.float64).reshape(-1, 2)
    segments = max(int(segments), 3)
    t0, t1 = float(theta[0]), float(theta[1])
    full = abs(abs(t1 - t0) - 2.0 * math.pi) < 1e-9
    k = segments if full else segments + 1
    th = t0 + (t1 - t0) * np.arange(k) / segments
    e1, e2, d = axis.angular_frame()
    radial = np.cos(th)[:, None] * e1 + np.sin(th)[:, None] * e2  # (k, 3)
    V = (axis.o + rz[:, 1, None, None] * d + rz[:, 0, None, None] * radial[None]).reshape(-1, 3)
    i = np.arange(segments)
    j = (i + 1) % k
    q = np.arange(len(rz) - 1)[:, None]
    F = np.stack([q * k + i, q * k + j, (q + 1) * k + j, (q + 1) * k + i], -1)
    return V, F.reshape(-1, 4).astype(np.int64)
