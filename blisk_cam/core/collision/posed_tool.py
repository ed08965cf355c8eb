"""The tool assembly at a pose as a signed-distance body: the flute and the
body's frusta about the tool axis, their support and bounds. mm.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..errors import CollisionError
from ..geometry.closest import segment_distance2_2d
from ..tool.cutter import Cutter

__all__ = ["PART_BODY", "PART_FLUTE"]

PART_FLUTE, PART_BODY = 0, 1
PART_NAMES = ("flute", "body")
#: how far beyond ds the clearance is measured before it is capped, mm
CAP_MARGIN = 5.0


# ====================================================================== parts
def _seg_near(px, py, ax, ay, bx, by):
    """(squared distance, nearest x, nearest y) from 2-D points to the segment a → b."""
    dx, dy = bx - ax, by - ay
    dd = dx * dx + dy * dy
    t = np.clip(((px - ax) * dx + (py - ay) * dy) / (dd if dd > 0 else 1.0), 0.0, 1.0)
    qx, qy = ax + t * dx, ay + t * dy
    ex, ey = px - qx, py - qy
    return ex * ex + ey * ey, qx, qy


class _Frustum:
    """A solid frustum of the body: the revolution of the trapezoid (0, z0), (r0, z0),
    (r1, z1), (0, z1) (mm)."""

    kind = PART_BODY

    def __init__(self, z0, r0, z1, r1):
        self.z0, self.r0, self.z1, self.r1 = map(float, (z0, r0, z1, r1))
        self.rmax = max(self.r0, self.r1)

    def radius_at(self, z):
        t = np.clip((z - self.z0) / (self.z1 - self.z0), 0.0, 1.0)
        return self.r0 + t * (self.r1 - self.r0)

    def sd_rz(self, rho, z):
        z0, r0, z1, r1 = self.z0, self.r0, self.z1, self.r1
        if r0 == r1:  # a cylinder: closed form
            dr = rho - r0
            dz = np.maximum(z0 - z, z - z1)
            out = np.hypot(np.maximum(dr, 0.0), np.maximum(dz, 0.0))
            return np.where((dr > 0) | (dz > 0), out, np.maximum(dr, dz))
        d2 = segment_distance2_2d(rho, z, 0.0, z0, r0, z0)
        d2 = np.minimum(d2, segment_distance2_2d(rho, z, r0, z0, r1, z1))
        d2 = np.minimum(d2, segment_distance2_2d(rho, z, r1, z1, 0.0, z1))
        inside = (z >= z0) & (z <= z1) & (rho <= self.radius_at(z))
        d = np.sqrt(d2)
        return np.where(inside, -d, d)

    def sd_grad_rz(self, rho, z):
        """(sd, ∂sd/∂ρ, ∂sd/∂z) at meridional points (k,): the gradient is the unit vector
        from the nearest boundary point (away from it outside, toward it inside); (0, 0)
        where the point is on the boundary (no gradient: the caller falls back)."""
        z0, r0, z1, r1 = self.z0, self.r0, self.z1, self.r1
        if r0 == r1:  # a cylinder: closed form
            dr = rho - r0
            dlo, dhi = z0 - z, z - z1
            dz = np.maximum(dlo, dhi)
            er, ez = np.maximum(dr, 0.0), np.maximum(dz, 0.0)
            out = np.hypot(er, ez)
            outside = out > 0
            inv = np.divide(1.0, out, out=np.zeros_like(out), where=outside)
            radial = dr >= dz
            gz = np.where(outside, ez * inv, ~radial)
            return (np.where(outside, out, np.maximum(dr, dz)),
                    np.where(outside, er * inv, radial), np.where(dlo > dhi, -gz, gz))
        best = None
        for a0, b0, a1, b1 in ((0.0, z0, r0, z0), (r0, z0, r1, z1), (r1, z1, 0.0, z1)):
            d2, qr, qz = _seg_near(rho, z, a0, b0, a1, b1)
            if best is None:
                best = [d2, qr, qz]
            else:
                closer = d2 < best[0]
                best = [np.where(closer, d2, best[0]), np.where(closer, qr, best[1]),
                        np.where(closer, qz, best[2])]
        d2, qr, qz = best
        inside = (z >= z0) & (z <= z1) & (rho <= self.radius_at(z))
        d = np.sqrt(d2)
        sgn = np.where(inside, -1.0, 1.0)
        inv = np.where(d > 1e-12, sgn / np.where(d > 1e-12, d, 1.0), 0.0)
        return sgn * d, (rho - qr) * inv, (z - qz) * inv

    def support_rz(self, s, c):
        """Meridional (ρ, z) of the support point in the direction with radial part s ≥ 0 and
        axial part c."""
        first = self.r0 * s + self.z0 * c >= self.r1 * s + self.z1 * c
        return np.where(first, self.r0, self.r1), np.where(first, self.z0, self.z1)


class _Flute:
    """The cutter's cutting part up to the flute length (exact convex shape,
    :mod:`..tool.cutter`)."""

    kind = PART_FLUTE

    def __init__(self, cutter: Cutter, flute_length: float):
        try:
            self.cutter = replace(cutter, h=float(flute_length))
        except Exception as err:  # ToolError: flute shorter than the corner
            raise CollisionError(f"flute length {flute_length:g} mm is impossible for the "
                                 f"cutter: {err}") from None
        g = self.cutter._g
        self.z0, self.z1 = 0.0, float(flute_length)
        self.rmax = float(g["T"][0])
        self._g = g

    def sd_rz(self, rho, z):
        return self.cutter.signed_distance_rz(rho, z)

    def support_rz(self, s, c):
        cu, g = self.cutter, self._g
        th = np.arctan2(s, -c)  # angle of the direction from −axis, in [0, π]
        th_c = np.clip(th, g["th_lo"], g["th_hi"])
        rho = np.where(th < g["th_lo"], 0.0, cu.e + cu.r * np.sin(th_c))
        z = np.where(th < g["th_lo"], 0.0, cu.f - cu.r * np.cos(th_c))
        top = th > g["th_hi"]
        return np.where(top, g["T"][0], rho), np.where(top, g["T"][1], z)


def _posed_sd(part, X, tip, axis):
    dv = X - tip
    z = np.einsum("ij,ij->i", dv, axis)
    rr = np.einsum("ij,ij->i", dv, dv) - z * z
    return part.sd_rz(np.sqrt(np.maximum(rr, 0.0)), z)


def _posed_sd_grad(part, X, tip, axis):
    """(sd (k,), gradient (k, 3) or None, valid (k,) bool) of the posed part at points X:
    the gradient of the convex sd, where the part provides it (frustums) and it exists
    (off the axis and off the part's boundary). By convexity sd(x) ≥ sd(X) + g·(x − X)
    for every x."""
    if not hasattr(part, "sd_grad_rz"):
        return _posed_sd(part, X, tip, axis), None, None
    sd, dv, al, be, valid = _posed_sd_ab(part, X, tip, axis)
    return sd, al[:, None] * dv + be[:, None] * axis, valid


def _posed_sd_ab(part, X, tip, axis):
    """(sd, dv = X − tip, α, β, valid): the gradient of the posed part's sd at X is
    α dv + β axis (∂sd/∂ρ along the unit radial (dv − z axis)/ρ, ∂sd/∂z along the axis)."""
    dv = X - tip
    z = np.einsum("ij,ij->i", dv, axis)
    rho = np.sqrt(np.maximum(np.einsum("ij,ij->i", dv, dv) - z * z, 0.0))
    sd, gr, gz = part.sd_grad_rz(rho, z)
    valid = (rho > 1e-9) & ((gr != 0.0) | (gz != 0.0))
    al = gr / np.where(valid, rho, 1.0)
    return sd, dv, al, gz - al * z, valid


def _box_bound(part, c, tip, axis, r, h):
    """(k,) lower bound of the posed part's sd over boxes (centre c, half-sizes h (k, 3),
    sphere radius r): the larger of sd(c) − r and the tangent plane of the convex sd at c
    over the box, sd(c) − Σ |∇sd(c)_i| h_i."""
    sd, dv, al, be, valid = _posed_sd_ab(part, c, tip, axis)
    s = np.abs(al * dv[:, 0] + be * axis[:, 0]) * h[:, 0]
    s += np.abs(al * dv[:, 1] + be * axis[:, 1]) * h[:, 1]
    s += np.abs(al * dv[:, 2] + be * axis[:, 2]) * h[:, 2]
    return np.maximum(sd - r, np.where(valid, sd - s, -np.inf))


def _posed_support(part, v, tip, axis):
    """(k, 3) support points of the posed part in directions v (k, 3)."""
    c = np.einsum("ij,ij->i", v, axis)
    perp = v - c[:, None] * axis
    s = np.linalg.norm(perp, axis=1)
    ref = np.where((np.abs(axis[:, 0]) < 0.9)[:, None], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    any_perp = np.cross(axis, ref)
    any_perp /= np.linalg.norm(any_perp, axis=1)[:, None]
    u = np.where((s > 1e-12)[:, None], perp / np.maximum(s, 1e-300)[:, None], any_perp)
    rho, z = part.support_rz(s, c)
    return tip + z[:, None] * axis + rho[:, None] * u
