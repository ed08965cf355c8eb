"""Level surfaces of channel roughing: where the tool tip runs, from the shroud down to the hub.

Paper 003 §5 roughs the blisk "as slotting — removing most spare material and remaining
0.5 mm stock", in levels between the hub and the shroud. A level here is a surface of
revolution about the blisk axis given by its radius r(z) at axial stations z (mm): the tool
tip, on a radial tool axis, runs on it. Three families, the same three modes every anchor of
the finishing paths has:

* ``from-hub`` — constant radial offsets k · depth from the floor (the lowest tip surface
  that keeps the allowance from the hub, :func:`floor_radius`);
* ``from-shroud`` — constant offsets (k + 1) · depth below the shroud (the blank's top),
  never below the floor;
* ``morph`` — the floor morphed into the shroud, r = f + s (t − f), s = 1 − (k + 1)/K (the
  linear morph of paper 001 Eqs. 1–4 applied to the floor and the shroud profiles).

In every mode the level count K = ⌈max(t − f) / depth⌉, so no step between two levels
exceeds the depth per cut, and the last level is the floor itself. Levels are returned from
the shroud down (the order they are cut).

The floor: a tool on a radial axis whose tip is at radius r over station z touches the hub
first with the lowest point of its bottom. The cutter's underside at lateral distance |ζ|
from its axis lies u(|ζ|) above the tip (0 on a flat bottom, the corner arc beyond it), so
the tip keeps the allowance a from the hub when r ≥ max_ζ (h_a(z + ζ) − u(|ζ|)), h_a the
hub profile offset by a along its meridional normal. Across the axis (in θ) the hub falls
away from the tool (a surface of revolution is convex in θ), so the meridional section
decides. Units: mm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import BliskCamError
from ..tool.cutter import Cutter

__all__ = ["LEVEL_MODES", "Level", "channel_volume", "cutter_underside", "floor_radius",
           "level_radii", "offset_profile", "stock_top"]

LEVEL_MODES = ("from-hub", "from-shroud", "morph")


@dataclass
class Level:
    """One level: ``index`` 0 at the shroud, ``r`` (n,) tip radius at the stations ``z``
    (mm), ``label`` what the user reads in a warning (mode and offset); ``z`` and
    ``outside`` (stations beyond the blank) are set when the region refines the stations;
    ``side`` (n,) the side tilt of the tool axis per station (rad), set by the roughing;
    ``walls_only`` a level of contour passes along the walls only."""

    index: int
    r: np.ndarray
    label: str
    z: np.ndarray | None = None
    outside: np.ndarray | None = None
    side: np.ndarray | None = None
    walls_only: bool = False


def offset_profile(profile, allowance: float, spacing: float = 0.1) -> np.ndarray:
    """(k, 2) the (r, z) polyline ``profile`` (ordered along z, material toward the axis)
    offset by ``allowance`` mm along its normal away from the axis, resampled every
    ``spacing`` mm and sorted along z."""
    P = np.asarray(profile, float)
    seg = np.diff(P, axis=0)
    k = np.maximum(1, np.ceil(np.hypot(*seg.T) / spacing).astype(int))
    pts = np.vstack([P[i] + seg[i] * (np.arange(k[i]) / k[i])[:, None] for i in range(len(seg))]
                    + [P[-1:]])
    tan = np.gradient(pts, axis=0)
    nrm = np.stack([tan[:, 1], -tan[:, 0]], 1)
    nrm /= np.maximum(np.linalg.norm(nrm, axis=1), 1e-300)[:, None]
    nrm *= np.where(nrm[:, :1] < 0, -1.0, 1.0)
    off = pts + allowance * nrm
    return off[np.argsort(off[:, 1], kind="stable")]


def cutter_underside(cutter: Cutter, zeta) -> np.ndarray:
    """(k,) height (mm) of the cutter's underside above its tip at lateral distances
    ``zeta`` (mm) from its axis; +inf beyond the cutter's largest radius."""
    prof = cutter.profile(96)
    rho, h = prof[:, 0], prof[:, 1]
    top = int(np.argmax(rho >= rho.max() - 1e-12))
    rho, h = rho[:top + 1], h[:top + 1]
    # for each radius the lowest height (a flat bottom: several heights 0 at one radius)
    keep = np.ones(len(rho), bool)
    keep[1:] = np.diff(rho) > 1e-12
    rho, h = rho[keep], h[keep]
    z = np.abs(np.asarray(zeta, float))
    out = np.interp(z, rho, h) if len(rho) > 1 else np.zeros(z.shape)
    return np.where(z <= rho[-1] + 1e-12, out, np.inf)


def floor_radius(hub_profile, cutter: Cutter, allowance: float, z, step: float = 0.05,
                 lead: float = 0.0, side: float = 0.0):
    """(n,) the lowest tip radius (mm) over stations ``z`` of a cutter on the radial axis
    tilted by ``lead`` (toward +z) and ``side`` (toward +θ, rad) that keeps ``allowance``
    from the hub (module docstring). The underside is sampled in polar points (ρ every
    ``step`` mm, 64 angles); a tilted tool's low rim is what touches first; the hub's fall in
    θ away from the tool is not counted (conservative). ``side`` may be an (n,) array: a side
    tilt per station."""
    if np.ndim(side) > 0:
        side = np.broadcast_to(np.asarray(side, float), np.shape(z))
        z = np.asarray(z, float)
        out = np.empty(len(z))
        for s in np.unique(side):
            m = side == s
            out[m] = floor_radius(hub_profile, cutter, allowance, z[m], step, lead, float(s))
        return out
    off = offset_profile(hub_profile, allowance)
    R = cutter.max_radius
    z = np.asarray(z, float)
    if lead == 0.0 and side == 0.0:
        n = max(3, int(math.ceil(2 * R / step)) | 1)
        zeta = np.linspace(-R, R, n)
        dz, dr = zeta, cutter_underside(cutter, zeta)
    else:
        rho = np.linspace(0.0, R, max(2, int(math.ceil(R / step)) + 1))
        psi = np.linspace(0.0, 2 * math.pi, 64, endpoint=False)
        rr, pp = np.meshgrid(rho, psi)
        u = cutter_underside(cutter, rr).ravel()
        ez, et = (rr * np.cos(pp)).ravel(), (rr * np.sin(pp)).ravel()
        # the tool frame: axis a = (radial + tan φ θ̂ + tan λ ẑ)/|·|; the bottom's directions
        # ⊥ a: toward z (e_z') and toward θ (e_t'), to first order in the tilts exact enough
        # for tilts below 45° through the exact rotation of the frame below
        a = np.array([1.0, math.tan(side), math.tan(lead)])
        a /= np.linalg.norm(a)
        ez_w = np.array([0.0, 0.0, 1.0]) - a[2] * a
        ez_w /= np.linalg.norm(ez_w)
        et_w = np.cross(a, ez_w)
        # world offsets (radial, θ, z) of each underside point from the tip
        P = u[:, None] * a[None] + ez[:, None] * ez_w[None] + et[:, None] * et_w[None]
        dr, dz = P[:, 0], P[:, 2]
    out = np.full(len(z), -np.inf)
    for s in range(0, len(z), 1024):
        zz = z[s:s + 1024, None] + dz[None]
        need = np.interp(zz, off[:, 1], off[:, 0]) - dr[None]
        out[s:s + 1024] = need.max(axis=1)
    return out


def stock_top(stock) -> tuple[np.ndarray, np.ndarray]:
    """(z rows, r top) of a :class:`~..stock.dexels.RadialDexels`: the largest radius of
    material in each row of rays (over the sector's angles), rows holding material only."""
    hi = np.where(stock.hi > stock.lo, stock.hi, 0.0).max(axis=1).reshape(stock.n_z,
                                                                          stock.n_theta)
    top = hi.max(axis=1)
    rows = np.nonzero(top > 0)[0]
    return stock.ray_z(rows), top[rows]


def level_radii(z, floor, top, mode: str, depth: float) -> list[Level]:
    """The levels (from the shroud down) over stations ``z``: ``floor`` and ``top`` (n,)
    radii (mm), ``mode`` one of :data:`LEVEL_MODES`, ``depth`` the largest step (mm)."""
    if mode not in LEVEL_MODES:
        raise BliskCamError(f"level mode must be one of {', '.join(LEVEL_MODES)}, got {mode!r}")
    if not (math.isfinite(depth) and depth > 0):
        raise BliskCamError(f"depth per cut must be > 0 mm, got {depth:g}")
    f = np.asarray(floor, float)
    t = np.maximum(np.asarray(top, float), f)
    span = float((t - f).max()) if len(f) else 0.0
    K = max(1, int(math.ceil(span / depth - 1e-9)))
    out = []
    for k in range(K):
        if mode == "from-hub":
            off = (K - 1 - k) * depth
            r, label = f + off, f"from the hub +{off:g} mm"
        elif mode == "from-shroud":
            off = (k + 1) * depth
            r, label = np.maximum(t - off, f), f"from the shroud −{off:g} mm"
        else:
            s = 1.0 - (k + 1) / K
            r, label = f + s * (t - f), f"morph s = {s:.3f}"
        out.append(Level(k, r, f"level {k + 1} of {K} ({label})"))
    return out


def channel_volume(stock, hub_profile) -> float:
    """Material (mm³, one sector) of ``stock`` above the hub: on the rays whose z lies within
    the hub profile's axial extent, the part of each interval beyond the hub radius there —
    the channels and the blades, not the disk's faces beyond the hub nor the bore."""
    P = np.asarray(hub_profile, float)
    z = stock.ray_z(np.arange(stock.n_z))
    inside = (z >= P[0, 1]) & (z <= P[-1, 1])
    hub = np.repeat(np.where(inside, np.interp(z, P[:, 1], P[:, 0]), np.inf), stock.n_theta)
    lo = np.maximum(stock.lo, hub[:, None])
    hi = stock.hi
    ok = hi > lo
    return float(0.5 * np.where(ok, hi * hi - lo * lo, 0.0).sum() * stock.d_theta * stock.dz)
