"""Cones about the blisk axis and the linear morphing cone (LMC) between two of them.

Paper 001 (Zhang, Hu, Tang 2015), §2.2, Eqs. 1–4: the generatrix of the morphing cone at
ratio ``s`` is the linear interpolation of the generatrices of cone 1 and cone 2,

    A(s) = (1 − s) P1 + s Q1,   B(s) = (1 − s) P2 + s Q2,

revolved about the blisk axis. We use the implicit form in the meridional half-plane
(ARCHITECTURE.md, math notes),

    f_s(r, z) = D(s) × ((r, z) − A(s)),   D(s) = B(s) − A(s),

which is valid for disks (generatrix perpendicular to the axis) and cylinders (parallel to
it), where the paper's Eq. 8 divides by zero. ``f_s`` is quadratic in ``s``, so the ratio of
the LMC through any point (the *morph field*) is closed-form.

Units: mm and radians. Meridional coordinates: ``z`` along the axis, ``r`` ≥ 0 from it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import ConeError

__all__ = [
    "Axis",
    "Cone",
    "MorphingCones",
    "fit_cone",
    "meridional",
]


def _cross2(a, b):
    """2-D cross product a × b of (..., 2) arrays."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


@dataclass(frozen=True)
class Axis:
    """The blisk axis: a line through ``origin`` along unit ``direction`` (mm)."""

    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    direction: tuple[float, float, float] = (0.0, 0.0, 1.0)

    def __post_init__(self):
        o = np.asarray(self.origin, dtype=np.float64)
        d = np.asarray(self.direction, dtype=np.float64)
        if o.shape != (3,) or d.shape != (3,) or not (np.all(np.isfinite(o)) and np.all(np.isfinite(d))):
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

    def radial_frame(self, points):
        """Unit radial directions e_r of (n, 3) points (arbitrary but consistent on the axis)."""
        p = np.asarray(points, dtype=np.float64) - self.o
        d = self.d
        radial = p - (p @ d)[:, None] * d
        n = np.linalg.norm(radial, axis=1)
        # On the axis the radial direction is undefined: pick any vector normal to d.
        fallback = np.cross(d, [1.0, 0.0, 0.0] if abs(d[0]) < 0.9 else [0.0, 1.0, 0.0])
        fallback /= np.linalg.norm(fallback)
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


@dataclass(frozen=True)
class Cone:
    """A cone (or cylinder, or disk) about the axis: the revolution of the generatrix segment
    P1 = (r1, z1) → P2 = (r2, z2) in the meridional half-plane (mm). The surface is the whole
    line through P1, P2 revolved; the segment only marks the region of interest."""

    r1: float
    z1: float
    r2: float
    z2: float

    def __post_init__(self):
        vals = np.array([self.r1, self.z1, self.r2, self.z2], dtype=np.float64)
        if not np.all(np.isfinite(vals)):
            raise ConeError(f"cone {tuple(vals)}: all four numbers must be finite")
        if vals[0] < 0 or vals[2] < 0:
            raise ConeError(f"cone {tuple(vals)}: radii r1, r2 must be ≥ 0 (distance from the axis)")
        if np.hypot(vals[2] - vals[0], vals[3] - vals[1]) < 1e-9:
            raise ConeError(
                f"cone {tuple(vals)}: P1 and P2 coincide; give two distinct generatrix points"
            )
        for name, v in zip(("r1", "z1", "r2", "z2"), vals, strict=True):
            object.__setattr__(self, name, float(v))

    @classmethod
    def from_list(cls, values) -> Cone:
        v = list(values)
        if len(v) != 4:
            raise ConeError(f"a cone is four numbers r1 z1 r2 z2 (mm), got {len(v)}")
        return cls(*v)

    def as_list(self) -> list[float]:
        return [self.r1, self.z1, self.r2, self.z2]

    @property
    def p1(self) -> np.ndarray:
        return np.array([self.r1, self.z1])

    @property
    def p2(self) -> np.ndarray:
        return np.array([self.r2, self.z2])

    def signed_distance(self, r, z):
        """Signed distance (mm) from meridional points to the generatrix line: D̂ × ((r,z) − P1)."""
        d = self.p2 - self.p1
        d = d / np.linalg.norm(d)
        rz = np.stack([np.asarray(r, float), np.asarray(z, float)], axis=-1)
        return _cross2(d, rz - self.p1)

    def project(self, r, z):
        """Closest points on the generatrix line to meridional points; returns (r', z')."""
        d = self.p2 - self.p1
        d = d / np.linalg.norm(d)
        rz = np.stack([np.asarray(r, float), np.asarray(z, float)], axis=-1)
        t = (rz - self.p1) @ d
        q = self.p1 + t[..., None] * d
        return q[..., 0], q[..., 1]


@dataclass(frozen=True)
class MorphingCones:
    """The family of linear morphing cones between ``cone1`` (s = 0) and ``cone2`` (s = 1).

    The constructor normalises and checks the pair:

    * if the two generatrices run in opposite directions (P1→P2 against Q1→Q2) Q1 and Q2 are
      swapped, because interpolating crossed end points would twist the family;
    * the cones must not coincide and must not cross between the segments' end points
      (each segment strictly on one side of the other's line), otherwise the LMCs of different
      ``s`` intersect inside the region and the morph field is not single-valued.

    The field is oriented so that ``f_s > 0`` on the cone-2 side of the LMC at ``s``.
    """

    cone1: Cone
    cone2: Cone

    def __post_init__(self):
        c1, c2 = self.cone1, self.cone2
        d1 = c1.p2 - c1.p1
        d2 = c2.p2 - c2.p1
        if float(d1 @ d2) < 0:
            c2 = Cone(c2.r2, c2.z2, c2.r1, c2.z1)
            object.__setattr__(self, "cone2", c2)
        if np.allclose(c1.as_list(), c2.as_list(), atol=1e-9, rtol=0):
            raise ConeError("cone 1 and cone 2 are the same cone; move the tip cone away from the hub cone")
        # each end point of one segment strictly on one side of the other line
        s2_on_1 = c1.signed_distance(np.array([c2.r1, c2.r2]), np.array([c2.z1, c2.z2]))
        s1_on_2 = c2.signed_distance(np.array([c1.r1, c1.r2]), np.array([c1.z1, c1.z2]))
        scale = max(np.linalg.norm(d1), np.linalg.norm(d2))
        eps = 1e-9 * max(scale, 1.0)
        if not (np.all(s2_on_1 > eps) or np.all(s2_on_1 < -eps)) or not (
            np.all(s1_on_2 > eps) or np.all(s1_on_2 < -eps)
        ):
            raise ConeError(
                "cone 1 and cone 2 cross (or touch) between their end points "
                f"(cone 1 {c1.as_list()}, cone 2 {c2.as_list()}); the morphing cones would "
                "intersect inside the region: move a cone end point so that the hub and tip "
                "generatrices do not cross"
            )
        # orientation: f_0 positive on the cone-2 side
        object.__setattr__(self, "_sign", 1.0 if s2_on_1[0] > 0 else -1.0)
        # and the family must sweep monotonically: f_s at Q and P for intermediate s
        ss = np.linspace(0.0, 1.0, 65)
        a, b = self.generatrix(ss)
        for s, aa, bb in zip(ss, a, b, strict=True):
            if np.linalg.norm(bb - aa) < 1e-9 * max(scale, 1.0):
                raise ConeError(
                    f"the morphing cone at s = {s:.3f} degenerates to a point; the hub and tip "
                    "generatrices are anti-parallel and of equal length: check the end points"
                )

    # --- the family -----------------------------------------------------------------------
    @property
    def sign(self) -> float:
        return self._sign  # type: ignore[attr-defined]

    def generatrix(self, s):
        """End points A(s), B(s) of the generatrix at ratio ``s`` (scalar or (k,)); each (…, 2)."""
        s = np.asarray(s, dtype=np.float64)[..., None]
        c1, c2 = self.cone1, self.cone2
        a = (1.0 - s) * c1.p1 + s * c2.p1
        b = (1.0 - s) * c1.p2 + s * c2.p2
        return a, b

    def cone_at(self, s: float) -> Cone:
        """The LMC at ratio ``s`` as a :class:`Cone`."""
        a, b = self.generatrix(float(s))
        return Cone(float(a[0]), float(a[1]), float(b[0]), float(b[1]))

    def line_coefficients(self, s: float):
        """(α, β, γ) with α r + β z + γ = signed meridional distance to the LMC at ``s``.

        Oriented so that it is positive on the cone-2 side; (α, β) is a unit vector.
        """
        a, b = self.generatrix(float(s))
        d = b - a
        d = d / np.linalg.norm(d)
        # d × ((r, z) − a) = d_r (z − a_z) − d_z (r − a_r)
        alpha = -d[1] * self.sign
        beta = d[0] * self.sign
        gamma = (d[1] * a[0] - d[0] * a[1]) * self.sign
        return float(alpha), float(beta), float(gamma)

    def f(self, s: float, r, z):
        """Signed meridional distance (mm) of points (r, z) to the LMC at ``s`` (+ toward cone 2)."""
        alpha, beta, gamma = self.line_coefficients(s)
        return alpha * np.asarray(r, float) + beta * np.asarray(z, float) + gamma

    def ratio(self, r, z):
        """The morph field: the ratio ``s`` of the LMC through each meridional point.

        Solves f_s(r, z) = 0, quadratic in s (the un-normalised cross product
        D(s) × ((r, z) − A(s)) with A, D linear in s), choosing the root that is continuous with
        the linear solution (the one the family sweeps monotonically through [0, 1]).
        Points on no LMC of the family (negative discriminant, far outside) get ±inf on the
        side they lie.

        Parameters
        ----------
        r, z : (n,) float, mm

        Returns
        -------
        s : (n,) float
        """
        r = np.asarray(r, dtype=np.float64)
        z = np.asarray(z, dtype=np.float64)
        x = np.stack([r, z], axis=-1)
        c1, c2 = self.cone1, self.cone2
        p1, q1 = c1.p1, c2.p1
        d1 = c1.p2 - c1.p1
        dd = (c2.p2 - c2.p1) - d1
        da = q1 - p1
        # f(s) = D(s) × (X − A(s)) = c0 + c1 s + c2 s²
        k0 = _cross2(d1, x - p1)
        k1 = _cross2(dd, x - p1) - _cross2(d1, da)
        k2 = -_cross2(dd, da) * np.ones_like(r)
        disc = k1 * k1 - 4.0 * k2 * k0
        sq = np.sqrt(np.maximum(disc, 0.0))
        denom = k1 + np.copysign(sq, k1)
        with np.errstate(divide="ignore", invalid="ignore"):
            s = np.where(np.abs(denom) > 0, -2.0 * k0 / denom, np.nan)
        # k0 = k1 = 0 (point on both lines): any s; take 0. Negative discriminant: off family.
        far = (disc < 0) | ~np.isfinite(s)
        if np.any(far):
            side = self.f(0.0, r[far], z[far])
            s = s.copy()
            s[far] = np.where(side > 0, np.inf, -np.inf)
        return s

    def ratio_of_points(self, points, axis: Axis):
        """Morph field at (n, 3) points (mm)."""
        r, z = meridional(points, axis)
        return self.ratio(r, z)


def fit_cone(points, axis: Axis, *, extend: float = 0.0):
    """Least-squares cone through 3-D points (a hub or tip boundary loop, or user points).

    Fits the meridional line by total least squares (PCA of (r, z)), so it handles disks and
    cylinders alike, and returns the generatrix segment spanning the points' projections,
    extended by ``extend`` mm at each end, ordered so that z (then r) increases.

    Parameters
    ----------
    points : (n, 3) float, mm, n ≥ 2 with distinct meridional positions
    axis : Axis
    extend : float, mm

    Returns
    -------
    cone : Cone
    residual : float, mm — the largest meridional distance of a point from the fitted line
    rms : float, mm
    """
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3 or len(p) < 2:
        raise ConeError("fit_cone needs at least two 3-D points")
    if not np.all(np.isfinite(p)):
        raise ConeError("fit_cone: the points contain NaN or infinite coordinates")
    r, z = meridional(p, axis)
    rz = np.stack([r, z], axis=1)
    c = rz.mean(axis=0)
    u, sv, vt = np.linalg.svd(rz - c, full_matrices=False)
    d = vt[0]
    if sv[0] < 1e-9:
        raise ConeError("fit_cone: the points all have the same (r, z); they do not define a cone")
    if d[1] < 0 or (abs(d[1]) < 1e-12 and d[0] < 0):
        d = -d
    t = (rz - c) @ d
    resid = _cross2(d, rz - c)
    lo, hi = t.min() - extend, t.max() + extend
    a, b = c + lo * d, c + hi * d
    for end in (a, b):
        if end[0] < 0 and abs(d[0]) > 1e-12:
            # clip at the axis along the fitted line (r cannot be negative)
            end[:] = end + (-end[0] / d[0]) * d
    cone = Cone(float(a[0]), float(a[1]), float(b[0]), float(b[1]))
    return cone, float(np.max(np.abs(resid))), float(np.sqrt(np.mean(resid**2)))
