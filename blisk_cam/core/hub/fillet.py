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

__all__ = ["FilletLayer", "FilletMeasure", "check_fillet_ball", "fillet_layers",
           "face_principal_curvatures", "layer_heights", "measure_fillet"]

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


# ------------------------------------------------------------------------ measured fillet
class FilletMeasure:
    """The hub fillet measured on the blade mesh (:func:`measure_fillet`): ``radius`` mm (the
    median concave principal radius over the fillet band), ``tightest`` mm (its 5th
    percentile: a sheared fillet is tighter in places), ``height`` mm (the band's top above
    the hub), ``faces`` (the band's face count)."""

    def __init__(self, radius, tightest, height, faces):
        self.radius, self.tightest = float(radius), float(tightest)
        self.height, self.faces = float(height), int(faces)


def face_principal_curvatures(mesh: TriMesh) -> np.ndarray:
    """(m, 3) per face the eigenvalues (ascending, 1/mm) of the shape operator — the symmetric
    part of the Jacobian of the linearly interpolated vertex normals restricted to the face's
    plane; one is ≈ 0 (the normal's), the others the principal curvatures, > 0 convex for
    outward normals (as :func:`..paths.spacing.surface_radii`)."""
    V, F = mesh.V, mesh.F
    fn = mesh.face_normals
    a2 = mesh.face_areas * 2.0
    inv = np.where(a2 > 0, 1.0 / np.where(a2 > 0, a2, 1.0), 0.0)
    vn = mesh.vertex_normals
    J = np.zeros((len(F), 3, 3))
    for i in range(3):
        e = V[F[:, (i + 2) % 3]] - V[F[:, (i + 1) % 3]]
        g = np.cross(fn, e) * inv[:, None]  # gradient of corner i's hat function
        J += vn[F[:, i]][:, :, None] * g[:, None, :]
    P = np.eye(3)[None] - fn[:, :, None] * fn[:, None, :]
    return np.linalg.eigvalsh(P @ (0.5 * (J + J.transpose(0, 2, 1))) @ P)


#: height bins (mm) of the fillet band search, and the least faces a bin needs
_BIN, _MIN_FACES = 1.0, 12


def measure_fillet(blade: TriMesh, hub: HubSurface) -> FilletMeasure | None:
    """The hub fillet of the blade mesh, measured: per face its tightest concave principal
    radius (:func:`face_principal_curvatures`) and its height above the hub; in 1 mm height
    bins from the hub up (the first bin, where the fillet meets the hub tangentially and the
    mesh's own rim bends the normals, skipped), the fillet band is the run of bins whose median
    concave radius stays below 3 × the smallest bin median and below a tenth of the wall's
    (above a third of the blade's height). None when the blade has no such band (no fillet)."""
    w = face_principal_curvatures(blade)
    kmin = w[:, 0]
    rc = np.where(kmin < 0, -1.0 / np.minimum(kmin, -1e-12), np.inf)
    _, _, h = hub.coordinates(blade.V[blade.F].mean(axis=1))
    top = float(h.max())
    wall = rc[h > top / 3.0]
    wall_med = float(np.median(wall)) if len(wall) else np.inf
    edges = np.arange(_BIN, top / 3.0, _BIN)
    meds = []
    for lo in edges:
        sel = (h >= lo) & (h < lo + _BIN)
        meds.append(float(np.median(rc[sel])) if sel.sum() >= _MIN_FACES else np.inf)
    meds = np.asarray(meds)
    if not len(meds) or not np.isfinite(meds).any():
        return None
    limit = min(3.0 * float(meds.min()), 0.1 * wall_med)
    if not meds[0] < limit:
        return None
    n = int(np.argmax(~(meds < limit))) if (~(meds < limit)).any() else len(meds)
    height = float(edges[n - 1] + _BIN)
    band = (h >= _BIN) & (h < height) & np.isfinite(rc)
    if band.sum() < _MIN_FACES:
        return None
    return FilletMeasure(np.median(rc[band]), np.percentile(rc[band], 5), height,
                         int(band.sum()))
