"""The level work of a trial step of the passes (:meth:`.passes._Generator.cusp_between`)
that does not depend on the trial's pass B: slicing the three levels between passes A and
B, sampling them and B's level, and their distances to A's ball-centre path
(:func:`.expansion.cusp_side_a`). The generator runs it on its kept side thread
(:class:`..runtime.SideThread`) while it makes pass B; everything here writes only to its own
locals (the caches are the caller's to fill).
"""

from __future__ import annotations

import numpy as np

from ..kernels import polyline as compiled_polyline
from .expansion import cusp_side_a

__all__ = ["level_points_normals", "trial_level_work"]


def _resample(points, closed, spacing, normals=None, offset=0.0):
    """Points ≤ ``spacing`` apart along a polyline (on its segments, so on the mesh and the
    cone when the polyline is an exact intersection); with ``normals`` also the normals there
    (interpolated along the segment, unit). With ``offset`` ρ the spacing is measured along
    the offset polyline ``p + ρ n`` (the ball-centre path), which puts many samples where the
    normal turns — around a thin leading edge, where the scallop between passes peaks."""
    # the arithmetic of np.vstack / np.diff / np.linalg.norm / np.clip written out (the same
    # operations on the same values, so the same floats): at ~400 points a level, called for
    # every level sampled, their generic wrappers cost more than the work
    P = np.concatenate((points, points[:1])) if closed else np.asarray(points)
    N = None if normals is None else (
        np.concatenate((normals, normals[:1])) if closed else np.asarray(normals))
    if len(P) < 2:
        return points if normals is None else (points, normals)
    dP = P[1:] - P[:-1]
    if N is None or offset == 0:
        D = dP
    else:
        Q = P + offset * N
        D = Q[1:] - Q[:-1]
    L = np.sqrt(np.add.reduce(D * D, axis=1))
    cum = np.empty(len(L) + 1)
    cum[0] = 0.0
    np.cumsum(L, out=cum[1:])
    n = max(2, int(np.ceil(cum[-1] / spacing)) + 1)
    u = np.linspace(0.0, cum[-1], n, endpoint=not closed)
    seg = np.minimum(np.maximum(np.searchsorted(cum, u, side="right") - 1, 0), len(L) - 1)
    w = ((u - cum[seg]) / np.where(L > 0, L, 1.0)[seg])[:, None]
    out = P[seg] + w * dP[seg]
    if N is None:
        return out
    nn = N[seg] + w * (N[1:] - N[:-1])[seg]
    ln = np.sqrt(np.add.reduce(nn * nn, axis=1))
    return out, nn / np.where(ln > 0, ln, 1.0)[:, None]


def level_points_normals(curves, spacing, radius):
    """Surface points ``spacing`` apart (along the offset path at ``radius`` mm, see
    :func:`_resample`) on the level curves ``curves`` (list of LevelCurve) and their unit
    normals: ((k, 3) float mm, (k, 3) float), k = 0 without curves. Compiled when
    installed (the same floats)."""
    pn = [compiled_polyline.resample_offset(c.points, c.normals, c.closed, spacing, radius)
          or _resample(c.points, c.closed, spacing, c.normals, radius)
          for c in curves]
    if not pn:
        return np.zeros((0, 3)), np.zeros((0, 3))
    return np.concatenate([x[0] for x in pn]), np.concatenate([x[1] for x in pn])


def trial_level_work(slicer, keys, levels, samples, spacing, radius, dist_a):
    """The pass-B-free part of a trial's scallop measure.

    Parameters
    ----------
    slicer : MeshConeSlicer — slices the levels not in ``levels`` (read only)
    keys : list of float — the ratios of the levels from pass A to pass B
    levels : dict float → list of LevelCurve — the levels known (the caller's cached ones)
    samples : dict float → ((k, 3), (k, 3)) — the level samples known, likewise
    spacing, radius : float, mm — as :func:`level_points_normals`
    dist_a : PolylineDistance — A's ball-centre path (its memo is written: the caller must
        not use it meanwhile)

    Returns
    -------
    (new_levels, new_samples, side_a): the levels sliced and the samples made here (dicts
    keyed as ``keys``, for the caller's caches), and :func:`.expansion.cusp_side_a`'s
    levels for ``keys`` in order.
    """
    new_levels, new_samples, pn = {}, {}, []
    for k in keys:
        got = samples.get(k, new_samples.get(k))
        if got is None:
            curves = levels.get(k, new_levels.get(k))
            if curves is None:
                curves = new_levels[k] = slicer.slice(k)
            got = new_samples[k] = level_points_normals(curves, spacing, radius)
        pn.append(got)
    side_a = cusp_side_a([x[0] for x in pn], dist_a, radius, level_normals=[x[1] for x in pn])
    return new_levels, new_samples, side_a
