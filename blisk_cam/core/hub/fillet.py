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

Layers spaced by a scallop height s instead (:func:`layer_heights_for_scallop`): in the
fillet's normal section the contact runs along the arc of radius R_f (u = R_f φ) and then up
the wall (u = R_f π/2 + the height above the fillet's top); neighbouring layers lie the
exact two-ball stepover apart (:func:`.surface.stepover_for_scallop`, the one the hub uses:
concave κ = −1/R_f on the fillet, flat on the wall), the steps even within each part, one
layer at the fillet's top, the last at the requested top. A wall layer's centre is at its
contact's height (the ball beside the wall).

Units mm and radians.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import ToolError
from ..geometry.distance import MeshDistance
from ..geometry.mesh import TriMesh
from .channel import chord_indices, root_loop, side_distance
from .surface import HubSurface, scallop_for_stepover, stepover_for_scallop

__all__ = ["FilletLayer", "FilletMeasure", "check_fillet_ball", "fillet_layers",
           "face_principal_curvatures", "layer_heights", "layer_heights_for_scallop",
           "measure_fillet"]

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


def layer_heights_for_scallop(rho: float, fillet_radius: float, scallop: float,
                              top: float | None = None):
    """Layers spaced for the ``scallop`` height (mm) between neighbours (module docstring),
    from the lower edge up to the contact at ``top`` mm above the hub (default: the fillet's
    top, R_f). Returns ((n, 2) (height of the ball centre above the hub mm, angle rad: φ on
    the fillet, π/2 + the height up the wall over R_f above it), (n − 1,) the scallop (mm)
    the exact two-ball formula gives between neighbours)."""
    R = float(fillet_radius)
    top = R if top is None else float(top)
    if not (scallop > 0.0 and scallop < rho):
        raise ToolError(f"fillet layers: the scallop must be in (0, {rho:g}) mm (the ball's "
                        f"radius), got {scallop:g}")
    if not top > 0.0:
        raise ToolError(f"fillet layers: the top must be above the hub, got {top:g} mm")
    u_fillet = R * 0.5 * math.pi
    u_top = R * math.acos(1.0 - top / R) if top < R else u_fillet + (top - R)
    d_f = float(stepover_for_scallop(rho, scallop, np.array([-1.0 / R]))[0])
    d_w = float(stepover_for_scallop(rho, scallop, np.array([0.0]))[0])
    a = min(u_top, u_fillet)
    u = np.linspace(0.0, a, max(1, math.ceil(a / d_f - 1e-9)) + 1)
    kappa = np.full(len(u) - 1, -1.0 / R)
    if u_top > u_fillet:
        w = np.linspace(u_fillet, u_top, max(1, math.ceil((u_top - u_fillet) / d_w - 1e-9))
                        + 1)
        u = np.concatenate([u, w[1:]])
        kappa = np.concatenate([kappa, np.zeros(len(w) - 1)])
    phi = np.minimum(u / R, 0.5 * math.pi)
    h = np.where(u <= u_fillet, R - (R - rho) * np.cos(phi), R + (u - u_fillet))
    ang = np.where(u <= u_fillet, phi, 0.5 * math.pi + (u - u_fillet) / R)
    return np.stack([h, ang], 1), scallop_for_stepover(rho, np.diff(u), kappa)


def _touching_loop(C, nrm, dist: MeshDistance, target: float, tol: float, passes: int = 4):
    """The closed loop of ball centres ``C`` (k, 3) kept ``target`` from the blade: centres the
    scan left off it (up the wall, where the blade's edges lean off the root loop's normal) moved
    along the nearest point's normal to the distance; then, up to ``passes`` times, the midpoint
    of every segment closer than target − ``tol`` inserted, moved so too (the sweep between two
    centres would cut the blade there). ``nrm`` (k, 2), the developed normals, follow."""
    cp = dist.query(C)
    off = np.abs(cp.distance - target) > 1e-3 * max(1.0, target)
    if off.any():
        nb = C[off] - cp.point[off]
        nb /= np.maximum(np.linalg.norm(nb, axis=1), 1e-300)[:, None]
        C = C.copy()
        C[off] = cp.point[off] + target * nb
    for _ in range(passes):
        M = 0.5 * (C + np.roll(C, -1, axis=0))
        q = dist.query(M)
        bad = np.flatnonzero(q.distance < target - tol)
        if not len(bad):
            break
        nb = M[bad] - q.point[bad]
        nb /= np.maximum(np.linalg.norm(nb, axis=1), 1e-300)[:, None]
        nm = nrm[bad] + np.roll(nrm, -1, axis=0)[bad]
        nm /= np.maximum(np.linalg.norm(nm, axis=1), 1e-300)[:, None]
        C = np.insert(C, bad + 1, q.point[bad] + target * nb, axis=0)
        nrm = np.insert(nrm, bad + 1, nm, axis=0)
    return C, nrm


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
                  step: float = 0.5, max_step: float = 2.0, tool_name: str = "ball",
                  heights=None, hub_rings: int = 0, ring_step: float = 1.0):
    """[FilletLayer] around blade 0's root, lower edge first; ``heights`` (n, 2) (centre
    height mm, angle rad) the layers' own (:func:`layer_heights_for_scallop`), else
    ``layers`` of :func:`layer_heights`. With ``heights``, ``hub_rings`` loops of the ball on
    the hub before them, ``ring_step`` mm apart outward of the lower edge's (outermost first;
    angle −j·ring_step / R_f): the hub round the root, behind the edges where the hub passes
    end.

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
    own = heights is not None
    if heights is None:
        heights = layer_heights(rho, fillet_radius, layers)
    for h, phi in heights:
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
        if own and hub_rings and phi == 0.0:
            for j in range(int(hub_rings), 0, -1):
                Cr, mr, tr = centre(hi + j * ring_step, h)
                hr = hub.normal(mr, tr)
                o3 = nrm[:, 0:1] * hub.meridian(mr, tr) + nrm[:, 1:2] * hub.tangential(tr)
                o3 -= np.einsum("ij,ij->i", o3, hr)[:, None] * hr
                o3 /= np.maximum(np.linalg.norm(o3, axis=1), 1e-300)[:, None]
                idx = chord_indices(np.vstack([Cr, Cr[:1]]), chord, max_step)[:-1]
                out.append(FilletLayer(Cr[idx] - rho * hr[idx], hr[idx], Cr[idx], hr[idx],
                                       o3[idx], h, -j * ring_step / fillet_radius))
        C, mm, tt = centre(hi, h)
        nrm_k = nrm
        if own and h > rho + chord:
            C, nrm_k = _touching_loop(C, nrm, dist, target, chord)
            mm, tt, _ = hub.coordinates(C)
        cp = dist.query(C)
        hub_foot = hub.point(mm, tt)
        hn = hub.normal(mm, tt)
        use_hub = h <= cp.distance  # the hub is the nearer surface (the lower edge)
        nearest = np.where(use_hub[:, None], hub_foot, cp.point)
        n = C - nearest
        n /= np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]
        cc = C - rho * n
        o3 = nrm_k[:, 0:1] * hub.meridian(mm, tt) + nrm_k[:, 1:2] * hub.tangential(tt)
        o3 -= np.einsum("ij,ij->i", o3, hn)[:, None] * hn
        o3 /= np.maximum(np.linalg.norm(o3, axis=1), 1e-300)[:, None]
        # the ball's sweep is its centre's polyline: its chord error is the gouge (around the
        # blade's edges the centres turn on a wider radius than the contacts); the layers of
        # ``heights`` keep it, the lower-edge pass of ``layers`` its contacts' (as before)
        idx = chord_indices(np.vstack([C, C[:1]]) if own else np.vstack([cc, cc[:1]]), chord,
                            max_step)[:-1]
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
