"""Fillet passes: closed loops around the blade root where a ball smaller than the fillet
radius runs along the fillet (paper 003 §5: the process ends with one pass along the
fillet/hub intersection with a ball smaller than the fillet radius; issue 24 asks for layers
across the fillet too, so no ridge is left between blade finishing and hub finishing).

A ball of radius ρ inside a fillet of radius R_f > ρ touching it at the angle φ from the hub
has its centre at the height h(φ) = R_f − (R_f − ρ) cos φ above the hub: h = ρ at φ = 0 (the
ball on the hub, touching the fillet's lower edge), h = R_f at φ = 90° (touching the wall
above the fillet). Layer j (of ``layers``) is the loop of ball centres at height h(φ_j),
φ_j = 75° j / (layers − 1) (one layer: the lower edge alone), each centre placed along the
hub's developed normal of the root loop (over the fillet toward the wall for φ > 0) where its
distance to the blade mesh becomes ρ + allowance coming from the wall (a scan, then
bisection): the ball then touches the fillet (or the hub, at the edge) and
keeps the allowance from the blade. The contact point (CC) is the centre minus ρ along the
direction to the nearest surface point (blade or hub).

Units mm and radians.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import ToolError
from ..geometry.distance import MeshDistance
from ..geometry.mesh import TriMesh
from .channel import chord_indices, root_loop, side_distance
from .surface import HubSurface

__all__ = ["FilletLayer", "check_fillet_ball", "fillet_layers", "layer_heights"]

_BISECT = 30


class FilletLayer:
    """One closed fillet loop: ``cc`` (k, 3), ``normal`` (k, 3) (unit, centre − contact),
    ``centre`` (k, 3) ball centres, ``hub_normal`` (k, 3), ``outward`` (k, 3) unit direction
    away from the blade along the hub, ``height`` mm (centre above the hub), ``angle`` rad
    (φ, from the hub)."""

    def __init__(self, cc, normal, centre, hub_normal, outward, height, angle):
        self.cc, self.normal, self.centre = cc, normal, centre
        self.hub_normal, self.outward = hub_normal, outward
        self.height, self.angle = float(height), float(angle)


#: the top layer touches the fillet this far up (φ, rad): short of the wall, where the
#: contact would come to the ball's equator (the wall above is blade finishing's)
TOP_ANGLE = math.radians(75.0)


def layer_heights(rho: float, fillet_radius: float, layers: int) -> np.ndarray:
    """(layers, 2) (height of the ball centre above the hub mm, φ rad) per layer, φ from 0
    (the lower edge) to :data:`TOP_ANGLE`."""
    if layers <= 1:
        phi = np.zeros(1)
    else:
        phi = TOP_ANGLE * np.arange(layers) / (layers - 1)
    return np.stack([fillet_radius - (fillet_radius - rho) * np.cos(phi), phi], 1)


def _resample_closed(P, step):
    Q = np.vstack([P, P[:1]])
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(Q, axis=0), axis=1))])
    n = max(16, int(math.ceil(s[-1] / step)))
    u = np.linspace(0.0, s[-1], n, endpoint=False)
    return np.stack([np.interp(u, s, Q[:, i]) for i in range(Q.shape[1])], 1)


def check_fillet_ball(rho: float, fillet_radius: float, tool_name: str = "ball"):
    """ToolError naming both radii unless the ball (radius ``rho`` mm) is smaller than the
    fillet (``fillet_radius`` mm)."""
    if not rho < fillet_radius:
        raise ToolError(f"fillet finishing needs a ball smaller than the fillet: the {tool_name} "
                        f"has radius {rho:g} mm, the fillet radius is {fillet_radius:g} mm; use "
                        f"a ball of radius < {fillet_radius:g} mm (diameter < "
                        f"{2 * fillet_radius:g} mm)")


def fillet_layers(blade: TriMesh, hub: HubSurface, rho: float, fillet_radius: float, *,
                  layers: int = 1, allowance: float = 0.0, chord: float = 0.05,
                  step: float = 0.5, max_step: float = 2.0, tool_name: str = "ball"):
    """[FilletLayer] around blade 0's root, lower edge first.

    Raises
    ------
    ToolError — the ball is not smaller than the fillet (naming both radii)
    """
    check_fillet_ball(rho, fillet_radius, tool_name)
    loop = root_loop(blade, hub)
    m, th, _ = hub.coordinates(loop)
    th0 = math.atan2(float(np.sin(th).mean()), float(np.cos(th).mean()))
    th = th0 + np.mod(th - th0 + math.pi, 2 * math.pi) - math.pi
    r_ref = float(hub.rz(np.array([m.mean()]))[0, 0])
    D = _resample_closed(np.stack([m, r_ref * th], 1), step)  # developed (m, r θ)
    tan = np.roll(D, -1, axis=0) - np.roll(D, 1, axis=0)
    tan /= np.maximum(np.linalg.norm(tan, axis=1), 1e-300)[:, None]
    nrm = np.stack([tan[:, 1], -tan[:, 0]], 1)
    area = 0.5 * float(np.sum(D[:, 0] * np.roll(D[:, 1], -1) - np.roll(D[:, 0], -1) * D[:, 1]))
    if area < 0:  # clockwise polygon: the right-hand normal points inside
        nrm = -nrm
    dist = MeshDistance(blade)
    target = rho + allowance

    def centre(d, h):
        q = D + d[:, None] * nrm
        mm, tt = q[:, 0], q[:, 1] / r_ref
        return hub.point(mm, tt) + h * hub.normal(mm, tt), mm, tt

    out = []
    for h, phi in layer_heights(rho, fillet_radius, layers):
        # the centre lies over the fillet (toward the wall, d < 0) for φ > 0: scan d from the
        # wall side out; the last sample too close to the blade, then bisection to the next
        span = fillet_radius + target + 1.0
        grid = np.arange(-span, span + 1e-9, min(0.5, 0.5 * rho))
        k = len(D)
        Dk = np.repeat(D, len(grid), axis=0) + np.tile(grid, k)[:, None] * np.repeat(nrm, len(
            grid), axis=0)
        mm_, tt_ = Dk[:, 0], Dk[:, 1] / r_ref
        cg = hub.point(mm_, tt_) + h * hub.normal(mm_, tt_)
        close = (side_distance(dist.query(cg)) < target).reshape(k, len(grid))
        last = len(grid) - 1 - np.argmax(close[:, ::-1], axis=1)
        last = np.where(close.any(axis=1), last, 0)
        lo = grid[last]
        hi = grid[np.minimum(last + 1, len(grid) - 1)]
        for _ in range(_BISECT):
            mid = 0.5 * (lo + hi)
            c, _, _ = centre(mid, h)
            close = side_distance(dist.query(c)) < target
            lo, hi = np.where(close, mid, lo), np.where(close, hi, mid)
        C, mm, tt = centre(hi, h)
        cp = dist.query(C)
        hub_foot = hub.point(mm, tt)
        hn = hub.normal(mm, tt)
        use_hub = h <= cp.distance  # the hub is the nearer surface (the lower edge)
        nearest = np.where(use_hub[:, None], hub_foot, cp.point)
        n = C - nearest
        n /= np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]
        cc = C - rho * n
        o3 = nrm[:, 0:1] * hub.meridian(mm, tt) + nrm[:, 1:2] * hub.tangential(tt)
        o3 -= np.einsum("ij,ij->i", o3, hn)[:, None] * hn
        o3 /= np.maximum(np.linalg.norm(o3, axis=1), 1e-300)[:, None]
        idx = chord_indices(np.vstack([cc, cc[:1]]), chord, max_step)[:-1]
        out.append(FilletLayer(cc[idx], n[idx], C[idx], hn[idx], o3[idx], h, phi))
    return out
