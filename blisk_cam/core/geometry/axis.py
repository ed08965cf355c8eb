"""The blisk axis and coordinates about it: :class:`Axis`, meridional (r, z)
coordinates, angles about the axis, and surfaces of revolution of an (r, z)
polyline. Lengths in mm, angles in radians.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ConeError
from .vectors import perpendicular

__all__ = [
    "Axis",
    "meridional",
    "angular_range",
    "angular_span",
    "revolve",
]


@dataclass(frozen=True)
class Axis:
    """The blisk axis: a line through ``origin`` along unit ``direction`` (mm)."""

    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    direction: tuple[float, float, float] = (0.0, 0.0, 1.0)

    def __post_init__(self):
        o = np.asarray(self.origin, dtype=np.float64)
        d = np.asarray(self.direction, dtype=np.float64)
        finite = np.all(np.isfinite(o)) and np.all(np.isfinite(d))
        if o.shape != (3,) or d.shape != (3,) or not finite:
            raise ConeError("axis: origin and direction must be three finite numbers each")
        n = float(np.linalg.norm(d))
        if n < 1e-12:
            raise ConeError("axis: the direction is zero; give a non-zero direction vector")
        object.__setattr__(self, "origin", tuple(float(x) for x in o))
        object.__setattr__(self, "direction", tuple(float(x) for x in d / n))

    @property
    def o(self) -> np.ndarray:
        return np.asarray(self.origin)

    @property
    def d(self) -> np.ndarray:
        return np.asarray(self.direction)

    def as_list(self) -> list[float]:
        """``[ox, oy, oz, dx, dy, dz]`` as in the paths JSON."""
        return [*self.origin, *self.direction]

    def angular_frame(self):
        """Orthonormal (e1, e2, d), each (3,) float64: e1 is world X projected normal to the
        axis (world Y if X ∥ axis), e2 = d × e1, so that for the axis +Z the angle θ about it
        is the usual atan2(y, x). The one convention for angles about the blisk axis (cone
        objects, gizmo half-planes, the demo's blade placement)."""
        d = self.d
        ref = np.array([1.0, 0.0, 0.0]) if abs(d[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        e1 = ref - (ref @ d) * d
        e1 /= np.linalg.norm(e1)
        return e1, np.cross(d, e1), d

    def radial_frame(self, points):
        """Unit radial directions e_r of (n, 3) points (arbitrary but consistent on the axis)."""
        p = np.asarray(points, dtype=np.float64) - self.o
        d = self.d
        radial = p - (p @ d)[:, None] * d
        n = np.linalg.norm(radial, axis=1)
        # On the axis the radial direction is undefined: pick any vector normal to d.
        fallback = perpendicular(d)
        out = np.where(n[:, None] > 1e-12, radial / np.maximum(n, 1e-300)[:, None], fallback)
        return out


def meridional(points, axis: Axis):
    """Meridional coordinates of points.

    Parameters
    ----------
    points : (n, 3) float, mm
    axis : Axis

    Returns
    -------
    r, z : (n,) float, mm. ``z = (X − o)·d``, ``r = |X − o − z d|``.
    """
    p = np.asarray(points, dtype=np.float64) - axis.o
    z = p @ axis.d
    radial = p - z[:, None] * axis.d
    r = np.sqrt(np.einsum("ij,ij->i", radial, radial))
    return r, z


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


def cylindrical(points, axis: Axis):
    """Cylindrical coordinates of points about the blisk axis.

    Parameters
    ----------
    points : (n, 3) float, mm
    axis : Axis

    Returns
    -------
    r : (n,) float, mm — distance from the axis
    theta : (n,) float, radians — angle about the axis from a fixed reference (d × X, or
        d × Y when the axis is near X)
    z : (n,) float, mm — along the axis from its origin
    frame : ((3,), (3,)) — the reference directions of theta = 0 and π/2, for
        :func:`from_cylindrical`
    """
    d = axis.d
    ref = perpendicular(d)
    ref2 = np.cross(d, ref)
    p = np.asarray(points, dtype=np.float64) - axis.o
    z = p @ d
    x, y = p @ ref, p @ ref2
    return np.hypot(x, y), np.arctan2(y, x), z, (ref, ref2)


def from_cylindrical(r, th, z, axis: Axis, frame):
    """Points from cylindrical coordinates, the inverse of :func:`cylindrical`.

    Parameters
    ----------
    r, th, z : (n,) float — mm, radians, mm
    axis : Axis
    frame : the ``frame`` :func:`cylindrical` returned

    Returns
    -------
    (n, 3) float, mm
    """
    ref, ref2 = frame
    return (
        axis.o
        + np.outer(z, axis.d)
        + (r * np.cos(th))[:, None] * ref
        + (r * np.sin(th))[:, None] * ref2
    )
