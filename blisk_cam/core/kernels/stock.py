"""Material removal on the stock's radial dexels, compiled: for a batch of posed solids (the
cutter's flute or one frustum of the body), every candidate ray of each solid's (θ, z) box is
met in closed form (the arithmetic of :func:`blisk_cam.core.stock.removal.ray_solid_intervals`)
and the union of a ray's intervals is subtracted from its material (what
:func:`blisk_cam.core.stock.dexels.subtract_intervals` keeps), in parallel over the grid's z
rows with the GIL released. Pairs whose ray meets no material inside the solid's bounding
cylinder are skipped (removing air changes nothing)."""

from __future__ import annotations

import numpy as np

from .backend import extension

__all__ = ["available", "remove_solids"]


def available() -> bool:
    """The compiled stock kernel runs (the extension is installed and has it: an extension
    built before the kernel existed leaves the numpy reference running)."""
    ext = extension()
    return ext is not None and hasattr(ext, "stock_remove")


def remove_solids(lo, hi, n_theta: int, grid, frame, tips, axes, group, n_groups: int, boxes,
                  planes, bounds, measure: bool, threads: int, rho=None, planes_in=None):
    """Remove posed solids from the stock's intervals; None when the numpy kernels run.

    Parameters
    ----------
    lo, hi : (n_z · n_theta, K) float64, mm — the material intervals (changed in place when
        C-contiguous float64; grown when a ray needs more than K)
    n_theta : int — columns of the grid
    grid : (θ0 rad, Δθ rad, z0 mm, Δz mm)
    frame : (4, 3) — the axis' origin (mm) and its angular frame e1, e2, d
    tips, axes : (m, 3) — the solids' tips (mm) and unit axes
    group : (m,) int — each solid's group (0 … n_groups − 1: the row within the batch)
    boxes : (m, 4) int — (c0, c1, w0, w1): the unwrapped columns and the rows of candidate
        rays (an empty range: none)
    planes : (q, 3) — the solid's half-planes (nρ, nz, c) in the tool frame
    bounds : (z_lo, z_hi, radius) mm — a cylinder about the tool axis holding the solid
    measure : bool — also measure, per group, the material its union of intervals meets
        before the removal
    rho : (q, 2) float or None — the ρ range of each plane's edge, for a profile whose
        boundary below the top rises with ρ: on each ray only the edges its ρ range meets
        are evaluated (the others cannot bind); None: every plane on every ray
    planes_in : (p, 3) float or None — the solid shrunk by the crash tolerance: with
        ``measure``, per group also the material the union of its intervals meets

    Returns
    -------
    lo, hi : the interval arrays (the same objects unless grown or copied)
    removed : float, mm² — Σ (hi² − lo²)/2 removed (× Δθ Δz = volume)
    volume, volume_in, depth : (n_groups,) float — per group the material met by the solid
        and by the shrunk solid (mm², × Δθ Δz) and the longest stretch met along one ray
        (mm); zeros unless ``measure`` (``volume_in`` also without ``planes_in``)
    pairs : int — the candidate ray–solid pairs of the boxes
    """
    if not available():
        return None
    ext = extension()
    lo = np.ascontiguousarray(lo, dtype=np.float64)
    hi = np.ascontiguousarray(hi, dtype=np.float64)
    f64 = lambda a: np.ascontiguousarray(a, dtype=np.float64)  # noqa: E731
    removed, vol, vol_in, depth, pairs, (rays, counts, olo, ohi) = ext.stock_remove(
        lo, hi, int(n_theta), tuple(float(x) for x in grid), f64(frame).reshape(4, 3),
        f64(tips).reshape(-1, 3), f64(axes).reshape(-1, 3),
        np.ascontiguousarray(group, dtype=np.int64), int(n_groups),
        np.ascontiguousarray(boxes, dtype=np.int64).reshape(-1, 4), f64(planes).reshape(-1, 3),
        tuple(float(x) for x in bounds), bool(measure), max(1, int(threads)),
        None if rho is None else f64(rho).reshape(-1, 2),
        None if planes_in is None else f64(planes_in).reshape(-1, 3))
    if len(rays):
        need = int(counts.max())
        grow = need - lo.shape[1]
        lo = np.hstack([lo, np.zeros((len(lo), grow))])
        hi = np.hstack([hi, np.zeros((len(hi), grow))])
        starts = np.cumsum(counts) - counts
        for ray, s, n in zip(rays, starts, counts, strict=True):
            lo[ray] = 0.0
            hi[ray] = 0.0
            lo[ray, :n] = olo[s:s + n]
            hi[ray, :n] = ohi[s:s + n]
    return lo, hi, float(removed), vol, vol_in, depth, int(pairs)
