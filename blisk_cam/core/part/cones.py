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

from ..errors import ConeError
from ..geometry.axis import Axis, meridional
from ..geometry.vectors import cross2

__all__ = ["Cone", "MorphingCones", "check_monotone_sweep", "fit_cone"]


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
            raise ConeError(
                f"cone {tuple(vals)}: radii r1, r2 must be ≥ 0 (distance from the axis)"
            )
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

    @property
    def vertices(self) -> np.ndarray:
        """(2, 2) float, mm: the generatrix end points P1, P2 as rows (r, z), the same shape
        convention as :attr:`.profiles.Profile.vertices`."""
        return np.array([[self.r1, self.z1], [self.r2, self.z2]])

    def signed_distance(self, r, z):
        """Signed distance (mm) from meridional points to the generatrix line: D̂ × ((r,z) − P1)."""
        d = self.p2 - self.p1
        d = d / np.linalg.norm(d)
        rz = np.stack([np.asarray(r, float), np.asarray(z, float)], axis=-1)
        return cross2(d, rz - self.p1)

    def project(self, r, z):
        """Closest points on the generatrix line to meridional points; returns (r', z')."""
        d = self.p2 - self.p1
        d = d / np.linalg.norm(d)
        rz = np.stack([np.asarray(r, float), np.asarray(z, float)], axis=-1)
        t = (rz - self.p1) @ d
        q = self.p1 + t[..., None] * d
        return q[..., 0], q[..., 1]


def check_monotone_sweep(P, Q) -> float:
    """Refuse a morph whose generatrices fold over inside the region (ConeError).

    The family is X(s, λ) = (1 − s) P(λ) + s Q(λ) with P, Q polylines over a common
    parameter: on the strip j between vertices j and j + 1 it is the bilinear patch
    X = (1 − s)((1 − λ) P_j + λ P_j+1) + s((1 − λ) Q_j + λ Q_j+1), (s, λ) ∈ [0, 1]².
    Its Jacobian J = ∂X/∂s × ∂X/∂λ is bilinear in (s, λ), so its extremes on the square are at
    the four corners: J(0,0) = E_j × dP_j, J(0,1) = E_j+1 × dP_j, J(1,0) = E_j × dQ_j,
    J(1,1) = E_j+1 × dQ_j with E_j = Q_j − P_j and dP_j = P_j+1 − P_j. The morph field is
    single-valued (f_s strictly monotone in s) over the region exactly when all these corner
    values, over all strips, have one strict sign — for one strip (two cones) this says the
    quadrilateral P1 P2 Q2 Q1 is strictly convex. Cross-products are compared as sines
    (divided by the lengths) against 1e-9.

    Parameters
    ----------
    P, Q : (m, 2) float, mm — the two generatrices' vertices (r, z) at a common parameter,
        m ≥ 2 (for cones: P1, P2 and Q1, Q2).

    Returns
    -------
    sign : float, ±1 — the sign of J (−1: cone 2 lies on the left of P's direction).
    """
    P = np.asarray(P, dtype=np.float64)
    Q = np.asarray(Q, dtype=np.float64)
    E = Q - P
    dP = np.diff(P, axis=0)
    dQ = np.diff(Q, axis=0)
    nE = np.linalg.norm(E, axis=1)
    nP = np.linalg.norm(dP, axis=1)
    nQ = np.linalg.norm(dQ, axis=1)
    tiny = 1e-300
    corners = np.stack(
        [
            cross2(E[:-1], dP) / np.maximum(nE[:-1] * nP, tiny),
            cross2(E[1:], dP) / np.maximum(nE[1:] * nP, tiny),
            cross2(E[:-1], dQ) / np.maximum(nE[:-1] * nQ, tiny),
            cross2(E[1:], dQ) / np.maximum(nE[1:] * nQ, tiny),
        ],
        axis=1,
    )  # (m − 1, 4): sines of the angles between the morph rays and the generatrix segments
    sign = 1.0 if np.sum(corners) > 0 else -1.0
    bad = sign * corners <= 1e-9
    if np.any(bad):
        j, c = np.argwhere(bad)[0]
        s_c, lam = (0.0 if c in (0, 1) else 1.0), (0.0 if c in (0, 2) else 1.0)
        x = (1 - s_c) * ((1 - lam) * P[j] + lam * P[j + 1]) + s_c * (
            (1 - lam) * Q[j] + lam * Q[j + 1]
        )
        raise ConeError(
            "cone 1 and cone 2 cross inside the region: the morphing generatrices fold over "
            f"near (r, z) = ({x[0]:.3f}, {x[1]:.3f}) mm (the segments joining corresponding "
            "points of the hub and tip generatrices, e.g. P1→Q1 and P2→Q2, cross or run along "
            "a generatrix), so the surfaces at different s intersect and the morph field is "
            "not single-valued: move an end point of cone 1 or cone 2 so that the quadrilateral "
            "P1 P2 Q2 Q1 is convex"
        )
    return sign


@dataclass(frozen=True)
class MorphingCones:
    """The family of linear morphing cones between ``cone1`` (s = 0) and ``cone2`` (s = 1).

    The constructor normalises and checks the pair:

    * if the two generatrices run in opposite directions (P1→P2 against Q1→Q2) Q1 and Q2 are
      swapped, because interpolating crossed end points would twist the family;
    * the cones must not coincide and must not cross between the segments' end points
      (each segment strictly on one side of the other's line), otherwise the LMCs of different
      ``s`` intersect inside the region and the morph field is not single-valued;
    * the family must sweep the region monotonically (:func:`check_monotone_sweep`: the
      quadrilateral P1 P2 Q2 Q1 strictly convex), which also excludes the folds where the
      segments P1→Q1 and P2→Q2 cross although neither cone crosses the other.

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
            raise ConeError(
                "cone 1 and cone 2 are the same cone; move the tip cone away from the hub cone"
            )
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
        # and the family must sweep the region monotonically (no two LMCs meet inside it)
        check_monotone_sweep(np.stack([c1.p1, c1.p2]), np.stack([c2.p1, c2.p2]))

    # --- the family -----------------------------------------------------------------------
    @property
    def sign(self) -> float:
        return self._sign  # type: ignore[attr-defined]

    def polyline(self, s):
        """Vertices of the generatrix at ratio ``s``: (2, 2) for a scalar ``s`` (rows A(s),
        B(s)), (k, 2, 2) for (k,) ``s``. The interface shared with
        :class:`.profiles.MorphingProfiles` (whose polylines have more vertices)."""
        a, b = self.generatrix(s)
        return np.stack([a, b], axis=-2)

    def segment_lines(self, s: float) -> np.ndarray:
        """(1, 3) float: (α, β, γ) of :meth:`line_coefficients` as the single segment line
        of the generatrix polyline at ``s`` (the interface shared with
        :class:`.profiles.MorphingProfiles`)."""
        return np.array([self.line_coefficients(s)])

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
        """Signed meridional distance (mm) of points (r, z) to the LMC at ``s`` (+ toward
        cone 2)."""
        alpha, beta, gamma = self.line_coefficients(s)
        return alpha * np.asarray(r, float) + beta * np.asarray(z, float) + gamma

    def ratio_terms(self):
        """The 2-vectors (r, z) of :meth:`ratio`'s quadratic: cone 1's first point p1 (mm),
        its direction d1 = p2 − p1 (mm), the change of direction dd from cone 1 to cone 2
        (mm) and the offset da of cone 2's first point from p1 (mm), each (2,) float64."""
        c1, c2 = self.cone1, self.cone2
        d1 = c1.p2 - c1.p1
        return c1.p1, d1, (c2.p2 - c2.p1) - d1, c2.p1 - c1.p1

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
        p1, d1, dd, da = self.ratio_terms()
        # f(s) = D(s) × (X − A(s)) = c0 + c1 s + c2 s²
        k0 = cross2(d1, x - p1)
        k1 = cross2(dd, x - p1) - cross2(d1, da)
        k2 = -cross2(dd, da) * np.ones_like(r)
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
    resid = cross2(d, rz - c)
    lo, hi = t.min() - extend, t.max() + extend
    a, b = c + lo * d, c + hi * d
    for end in (a, b):
        if end[0] < 0 and abs(d[0]) > 1e-12:
            # clip at the axis along the fitted line (r cannot be negative)
            end[:] = end + (-end[0] / d[0]) * d
    cone = Cone(float(a[0]), float(a[1]), float(b[0]), float(b[1]))
    return cone, float(np.max(np.abs(resid))), float(np.sqrt(np.mean(resid**2)))
