"""The hub surface of revolution: the hub profile (r, z) revolved about the blisk axis,
parametrised by meridional arc length m along the profile and the angle θ about the axis.

S(m, θ) = o + z(m) d + r(m) (cos θ e1 + sin θ e2), with (r, z)(m) the profile polyline (its
first and last segments extended linearly beyond the ends, as :class:`..part.profiles.Profile`
reads it). The unit normal lies in the meridional plane, away from the axis side of the
profile (out of the hub material), interpolated between the vertex normals so that it turns
smoothly where the polyline bends. Curvatures (paper 003 §5 finishes the hub as a surface of
revolution): the principal directions are the meridian and the parallel circle; the
meridional curvature κ_m is the profile's (turning angle per length at its vertices, spread
over the neighbouring half-segments), the parallel's normal curvature is κ_θ = n_r / r
(Meusnier), both positive where the hub is convex (bulging toward the tool). Along a
direction at angle ψ from the meridian, Euler: κ(ψ) = κ_m cos²ψ + κ_θ sin²ψ.

Units mm and radians.
"""

from __future__ import annotations

import numpy as np

from ..errors import PartError
from ..geometry.axis import Axis
from ..geometry.closest import segment_distance2_2d

__all__ = ["HubSurface", "scallop_for_stepover", "stepover_for_scallop"]


class HubSurface:
    """The revolved hub profile.

    Parameters
    ----------
    profile : (k, 2) float, mm — (r, z) points ordered along the axis (k ≥ 2)
    axis : Axis
    """

    def __init__(self, profile, axis: Axis):
        P = np.asarray(profile, dtype=np.float64)
        if P.ndim != 2 or P.shape[1] != 2 or len(P) < 2:
            raise PartError(f"hub profile must be (k ≥ 2, 2) (r, z) points, got {P.shape}")
        seg = np.diff(P, axis=0)
        ln = np.hypot(seg[:, 0], seg[:, 1])
        keep = np.concatenate([[True], ln > 1e-9])
        P = P[keep]
        if len(P) < 2:
            raise PartError("hub profile has no length (all points coincide)")
        self.profile = P
        self.axis = axis
        self.e1, self.e2, self.d = axis.angular_frame()
        seg = np.diff(P, axis=0)
        self.seg_len = np.hypot(seg[:, 0], seg[:, 1])
        self.m_nodes = np.concatenate([[0.0], np.cumsum(self.seg_len)])
        tan = seg / self.seg_len[:, None]
        nrm = np.stack([tan[:, 1], -tan[:, 0]], 1)
        nrm *= np.where(nrm[:, :1] < 0, -1.0, 1.0)  # away from the axis side
        self._seg_tan = tan
        vn = np.vstack([nrm[:1], nrm[:-1] + nrm[1:], nrm[-1:]])
        self._vertex_normal = vn / np.linalg.norm(vn, axis=1)[:, None]
        # profile curvature at the vertices: signed turning angle / mean neighbouring length,
        # positive when the profile bends toward the axis side (convex hub)
        km = np.zeros(len(P))
        if len(P) > 2:
            cross = tan[:-1, 0] * tan[1:, 1] - tan[:-1, 1] * tan[1:, 0]
            dot = np.einsum("ij,ij->i", tan[:-1], tan[1:])
            turn = np.arctan2(cross, dot)
            # tangent (dr, dz) turning toward −r (clockwise in (r, z)) is convex for a hub
            sgn = 1.0 if np.mean(nrm[:, 0]) >= 0 else -1.0
            km[1:-1] = -sgn * turn / (0.5 * (self.seg_len[:-1] + self.seg_len[1:]))
        self._kappa_m = km

    def offset(self, a: float) -> HubSurface:
        """The hub surface offset by ``a`` mm along its normal, out of the material (a ≥ 0):
        the surface a ball leaves ``a`` mm of stock on (hub semi-finishing, paper 003 §5 —
        the hub's counterpart of the blade offset of :mod:`..process.blade_finish`). The
        offset of a surface of revolution is its meridian's offset revolved: every profile
        segment moves ``a`` along its own normal and the vertices go to the meets of the moved
        segments (the miter point a / cos(β/2) along the bisector, β the turn at the vertex).
        PartError where the offset folds over itself: a concave bend of the profile tighter
        than ``a``."""
        a = float(a)
        if not (np.isfinite(a) and a >= 0.0):
            raise PartError(f"hub offset must be a number ≥ 0 mm, got {a!r}")
        if a == 0.0:
            return self
        seg = np.diff(self.profile, axis=0)
        nrm = np.stack([self._seg_tan[:, 1], -self._seg_tan[:, 0]], 1)
        nrm *= np.where(nrm[:, :1] < 0, -1.0, 1.0)
        vn = self._vertex_normal
        # the segment normal on either side of each vertex (the ends: their own segment's)
        side = np.vstack([nrm[:1], nrm])
        cos_half = np.einsum("ij,ij->i", vn, side)
        Q = self.profile + (a / np.maximum(cos_half, 1e-9))[:, None] * vn
        new = np.diff(Q, axis=0)
        folds = np.einsum("ij,ij->i", new, seg) <= 0.0
        if np.any(folds):
            i = int(np.argmax(folds))
            r, z = self.profile[i]
            raise PartError(
                f"the hub offset by {a:g} mm folds over itself near r {r:.1f} mm, z {z:.1f} "
                f"mm (a concave bend of the hub profile tighter than {a:g} mm): leave less "
                f"stock on the hub")
        return HubSurface(Q, self.axis)

    @property
    def length(self) -> float:
        """Meridional length of the profile, mm."""
        return float(self.m_nodes[-1])

    # ------------------------------------------------------------------ evaluation
    def rz(self, m) -> np.ndarray:
        """(k, 2) (r, z) at meridional positions ``m`` (k,), mm; linear beyond the ends."""
        m = np.atleast_1d(np.asarray(m, dtype=np.float64))
        i = np.clip(np.searchsorted(self.m_nodes, m, side="right") - 1, 0, len(self.seg_len) - 1)
        return self.profile[i] + (m - self.m_nodes[i])[:, None] * self._seg_tan[i]

    def normal_rz(self, m) -> np.ndarray:
        """(k, 2) unit meridional normal (n_r, n_z), interpolated between vertex normals."""
        m = np.atleast_1d(np.asarray(m, dtype=np.float64))
        vn = self._vertex_normal
        out = np.stack([np.interp(m, self.m_nodes, vn[:, 0]),
                        np.interp(m, self.m_nodes, vn[:, 1])], 1)
        return out / np.linalg.norm(out, axis=1)[:, None]

    def radial(self, theta) -> np.ndarray:
        th = np.atleast_1d(np.asarray(theta, dtype=np.float64))
        return np.cos(th)[:, None] * self.e1 + np.sin(th)[:, None] * self.e2

    def tangential(self, theta) -> np.ndarray:
        """(k, 3) unit e_θ (direction of growing θ)."""
        th = np.atleast_1d(np.asarray(theta, dtype=np.float64))
        return -np.sin(th)[:, None] * self.e1 + np.cos(th)[:, None] * self.e2

    def point(self, m, theta) -> np.ndarray:
        """(k, 3) S(m, θ), mm."""
        rz = self.rz(m)
        return self.axis.o + rz[:, 1:2] * self.d + rz[:, 0:1] * self.radial(theta)

    def normal(self, m, theta) -> np.ndarray:
        """(k, 3) unit normal at S(m, θ), out of the hub material."""
        n = self.normal_rz(m)
        return n[:, 0:1] * self.radial(theta) + n[:, 1:2] * self.d

    def meridian(self, m, theta) -> np.ndarray:
        """(k, 3) unit tangent of the meridian (growing m) at S(m, θ)."""
        m = np.atleast_1d(np.asarray(m, dtype=np.float64))
        i = np.clip(np.searchsorted(self.m_nodes, m, side="right") - 1, 0, len(self.seg_len) - 1)
        t = self._seg_tan[i]
        return t[:, 0:1] * self.radial(theta) + t[:, 1:2] * self.d

    def coordinates(self, points):
        """(m, θ, height) of (k, 3) points: m of the nearest profile point (mm), θ about the
        axis (rad, in (−π, π]), and the signed distance to the revolved profile (mm, > 0 on
        the tool side)."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3) - self.axis.o
        x, y, z = p @ self.e1, p @ self.e2, p @ self.d
        r = np.hypot(x, y)
        th = np.arctan2(y, x)
        best = np.full(len(r), np.inf)
        m = np.zeros(len(r))
        P, tan, L = self.profile, self._seg_tan, self.seg_len
        last = len(L) - 1
        for i in range(len(L)):
            a = P[i]
            t = (r - a[0]) * tan[i, 0] + (z - a[1]) * tan[i, 1]
            lo = -np.inf if i == 0 else 0.0
            hi = np.inf if i == last else L[i]
            t = np.clip(t, lo, hi)
            d2 = (r - a[0] - t * tan[i, 0]) ** 2 + (z - a[1] - t * tan[i, 1]) ** 2
            better = d2 < best
            best = np.where(better, d2, best)
            m = np.where(better, self.m_nodes[i] + t, m)
        rz = self.rz(m)
        nrz = np.stack([tan[np.clip(np.searchsorted(self.m_nodes, m, side="right") - 1, 0,
                                    last)][:, 1], -tan[np.clip(np.searchsorted(
                                        self.m_nodes, m, side="right") - 1, 0, last)][:, 0]], 1)
        nrz *= np.where(nrz[:, :1] < 0, -1.0, 1.0)
        h = (r - rz[:, 0]) * nrz[:, 0] + (z - rz[:, 1]) * nrz[:, 1]
        return m, th, h

    def distance(self, points) -> np.ndarray:
        """(k,) unsigned distance (mm) of points to the revolved profile polyline (within its
        end points: an independent measure for checks)."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3) - self.axis.o
        r = np.hypot(p @ self.e1, p @ self.e2)
        z = p @ self.d
        d2 = np.full(len(r), np.inf)
        for a, b in zip(self.profile[:-1], self.profile[1:], strict=True):
            d2 = np.minimum(d2, segment_distance2_2d(r, z, a[0], a[1], b[0], b[1]))
        return np.sqrt(d2)

    # ------------------------------------------------------------------ curvature
    def kappa_m(self, m) -> np.ndarray:
        """(k,) meridional curvature (1/mm, > 0 convex) at ``m``."""
        return np.interp(np.atleast_1d(m), self.m_nodes, self._kappa_m)

    def kappa_theta(self, m) -> np.ndarray:
        """(k,) normal curvature of the parallel circle (1/mm, > 0 convex): n_r / r."""
        r = self.rz(m)[:, 0]
        return self.normal_rz(m)[:, 0] / np.maximum(r, 1e-9)

    def normal_curvature(self, m, psi) -> np.ndarray:
        """(k,) normal curvature (1/mm, > 0 convex) along the direction at angle ``psi`` (rad)
        from the meridian (Euler's formula with the meridian and parallel as principal
        directions)."""
        c2 = np.cos(np.asarray(psi, dtype=np.float64)) ** 2
        return self.kappa_m(m) * c2 + self.kappa_theta(m) * (1.0 - c2)


# ---------------------------------------------------------------------- scallop spacing
def stepover_for_scallop(rho: float, scallop, kappa) -> np.ndarray:
    """(k,) distance (mm, along the surface) between two ball passes that leaves the
    ``scallop`` height (mm) on a surface of normal curvature ``kappa`` (1/mm, > 0 convex, < 0
    concave) across the passes, ball radius ``rho`` (mm).

    In the normal section the surface is a circle of radius R = 1/|κ|; the ball centres lie on
    the concentric circle of radius L = R ± ρ, the angle φ apart; the cusp lies on the
    bisector at q = R ± h from the centre, where both balls meet: ρ² = L² + q² − 2 L q cos(φ/2),
    so φ = 2 arccos((L² + q² − ρ²) / (2 L q)) and the stepover is R φ. Flat (κ → 0):
    2 √(2ρh − h²). A concave section tighter than the ball (R ≤ ρ) gives 0 (the ball cannot
    follow it)."""
    h = np.broadcast_to(np.asarray(scallop, dtype=np.float64), np.shape(kappa)).copy()
    k = np.asarray(kappa, dtype=np.float64)
    h = np.minimum(h, rho)
    flat = 2.0 * np.sqrt(np.maximum(2.0 * rho * h - h * h, 0.0))
    out = flat.copy()
    curved = np.abs(k) > 1e-9
    if np.any(curved):
        R = 1.0 / np.abs(k[curved])
        hh = h[curved]
        convex = k[curved] > 0
        L = np.where(convex, R + rho, R - rho)
        q = np.where(convex, R + hh, R - hh)
        with np.errstate(invalid="ignore", divide="ignore"):
            c = (L * L + q * q - rho * rho) / (2.0 * L * q)
            w = R * 2.0 * np.arccos(np.clip(c, -1.0, 1.0))
        w = np.where(L > 0, w, 0.0)
        out[curved] = w
    return out


def scallop_for_stepover(rho: float, stepover, kappa) -> np.ndarray:
    """(k,) scallop height (mm) left by ball passes ``stepover`` mm apart (the inverse of
    :func:`stepover_for_scallop`, same circle model)."""
    w = np.asarray(stepover, dtype=np.float64)
    k = np.broadcast_to(np.asarray(kappa, dtype=np.float64), w.shape)
    flat = rho - np.sqrt(np.maximum(rho * rho - 0.25 * w * w, 0.0))
    out = np.array(flat, dtype=np.float64)
    curved = np.abs(k) > 1e-9
    if np.any(curved):
        R = 1.0 / np.abs(k[curved])
        convex = k[curved] > 0
        L = np.where(convex, R + rho, R - rho)
        half = 0.5 * w[curved] / R
        root = np.sqrt(np.maximum(rho * rho - (L * np.sin(half)) ** 2, 0.0))
        # the balls' circles meet on the bisector: the cusp is the root nearer the surface
        q = L * np.cos(half) + np.where(convex, -root, root)
        out[curved] = np.where(convex, q - R, R - q)
    return out
