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

__all__ = ["available", "remove_solids", "sweep_available", "sweep_body_available",
           "sweep_moves"]


def available() -> bool:
    """The compiled stock kernel runs (the extension is installed and has it: an extension
    built before the kernel existed leaves the numpy reference running)."""
    ext = extension()
    return ext is not None and hasattr(ext, "stock_remove")


def sweep_available() -> bool:
    """The compiled swept-volume kernel runs (an extension built before it existed: no)."""
    ext = extension()
    return ext is not None and hasattr(ext, "stock_sweep")


def sweep_body_available() -> bool:
    """The swept-volume kernel also sweeps the body by the reference's sub-poses
    (``open_start``; an extension built before: no, the body stays posed)."""
    ext = extension()
    return sweep_available() and getattr(ext, "STOCK_SWEEP_REVISION", 1) >= 2


def _grown(lo, hi, rays, counts, olo, ohi):
    """Write the rays that needed more than K intervals (grows the arrays)."""
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
    return lo, hi


def sweep_moves(lo, hi, n_theta: int, grid, frame, t0, a0, t1, a1, group, n_groups: int, boxes,
                knots, fknots, samples, prims, prims_in, bounds, measure: bool, threads: int,
                planes=None, rho=None, planes_in=None, open_start: bool = False):
    """Remove the solids swept by moves from the stock's intervals; None when the kernel is
    not there.

    Every move takes the tool from (t0, a0) to (t1, a1) — tip linear, axis by spherical
    linear interpolation. The primitives ``prims`` (p, 5) — rows (0, zc, radius, 0, 0): a
    ball of that radius centred zc mm up the axis; (1, z1, r1, z2, r2): a frustum of radius
    r1 at z1 to r2 at z2 — are swept in closed form per ray: a ball by the capsules between
    its centres at ``knots`` (m,) + 1 poses (its centre path's chords: the error is their
    sagitta); a frustum by its translational sweeps between ``fknots`` (m,) + 1 tips with the
    mid axis (the extremes of r over the convex set of (r, t) in the moving frustum: the
    error is the axis turn within a knot times the frustum's reach) or, when ``fknots`` is
    0, by ``samples`` (m,) + 1 poses. A polygon solid ``planes`` (q, 3) (the corner of a
    bull nose) is swept by the samples. ``prims_in``/``planes_in``: the solid shrunk by the
    crash tolerance (measured with ``measure``). ``boxes`` (m, 4) = (c0, c1, w0, w1): the
    rays the whole sweep can meet (unwrapped columns, up to a whole turn). Other parameters
    and the returns as :func:`remove_solids` (pairs: candidate ray–move pairs).
    ``open_start``: the samples are the poses at t = j/samples, j = 1 … samples (the
    reference's sub-poses: the start pose is the previous move's), not from j = 0
    (:func:`sweep_body_available`)."""
    if not sweep_available():
        return None
    ext = extension()
    lo = np.ascontiguousarray(lo, dtype=np.float64)
    hi = np.ascontiguousarray(hi, dtype=np.float64)
    f64 = lambda a: np.ascontiguousarray(a, dtype=np.float64)  # noqa: E731
    i64 = lambda a: np.ascontiguousarray(a, dtype=np.int64)  # noqa: E731
    opt = lambda a, w: None if a is None else f64(a).reshape(-1, w)  # noqa: E731
    removed, vol, vol_in, depth, pairs, (rays, counts, olo, ohi) = ext.stock_sweep(
        lo, hi, int(n_theta), tuple(float(x) for x in grid), f64(frame).reshape(4, 3),
        f64(t0).reshape(-1, 3), f64(a0).reshape(-1, 3), f64(t1).reshape(-1, 3),
        f64(a1).reshape(-1, 3), i64(group), int(n_groups), i64(boxes).reshape(-1, 4),
        i64(knots), i64(fknots), i64(samples), f64(prims).reshape(-1, 5),
        f64(prims_in).reshape(-1, 5),
        tuple(float(x) for x in bounds), bool(measure), max(1, int(threads)),
        opt(planes, 3), opt(rho, 2), opt(planes_in, 3),
        **({"open_start": True} if open_start else {}))
    lo, hi = _grown(lo, hi, rays, counts, olo, ohi)
    return lo, hi, float(removed), vol, vol_in, depth, int(pairs)


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
    lo, hi = _grown(lo, hi, rays, counts, olo, ohi)
    return lo, hi, float(removed), vol, vol_in, depth, int(pairs)
