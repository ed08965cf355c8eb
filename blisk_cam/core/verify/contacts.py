"""The contact points of a posed non-ball cutter, for :mod:`.measure`'s pose checks: the tip
that touches a CC point, and the lowest point of the cutter posed between two poses."""

from __future__ import annotations

import numpy as np

from ..geometry.vectors import dot, slerp, unit
from .sweep_ball import _curve_polyline

__all__ = ["cl_or_nan", "interpolated_contacts"]


def cl_or_nan(cutter, cc, normal, axis):
    """Tip points of the cutter touching ``cc``; NaN rows where the axis is tilted beyond
    the cutter's side (no contact possible)."""
    out = np.full_like(cc, np.nan)
    th = np.arctan2(np.linalg.norm(np.cross(normal, axis), axis=1), dot(normal, axis))
    ok = th <= 0.5 * np.pi - cutter.beta
    if np.any(ok):
        out[ok] = cutter.cl_points(cc[ok], normal[ok], axis[ok])
    return out


def interpolated_contacts(cutter, curves, nsub):
    """Per pass, at ``nsub`` points of every segment (tip and CC linear, axis on the great arc,
    normal interpolated and normalised): the posed cutter's extreme point toward −n, i.e. the
    point that touches when the pose is right. Returns (points (q, 3), curve id (q,),
    tips (q, 3), axes (q, 3))."""
    pts, ids, tps, axs = [], [], [], []
    t = np.arange(0, nsub) / nsub
    for i, c in enumerate(curves):
        tips_a, tips_b = _curve_polyline(c, c.tip)
        ax_a, ax_b = _curve_polyline(c, c.axis)
        n_a, n_b = _curve_polyline(c, c.normal)
        m = len(tips_a)
        tt = np.tile(t, m)
        rep_ = np.repeat(np.arange(m), nsub)
        tip = tips_a[rep_] + tt[:, None] * (tips_b - tips_a)[rep_]
        ax = slerp(unit(ax_a[rep_], keep_zero=False), unit(ax_b[rep_], keep_zero=False), tt,
                   weights_first=True)
        nn = n_a[rep_] + tt[:, None] * (n_b - n_a)[rep_]
        if not (c.closed and len(c.tip) > 2):  # the last pose itself
            tip = np.vstack([tip, c.tip[-1:]])
            ax = np.vstack([ax, c.axis[-1:] / np.linalg.norm(c.axis[-1])])
            nn = np.vstack([nn, c.normal[-1:]])
        nn /= np.maximum(np.linalg.norm(nn, axis=1), 1e-300)[:, None]
        th = np.arctan2(np.linalg.norm(np.cross(nn, ax), axis=1), dot(nn, ax))
        ok = th <= 0.5 * np.pi - cutter.beta
        off, _ = cutter.contact(nn[ok], ax[ok])
        pts.append(tip[ok] - off)
        ids.append(np.full(int(ok.sum()), i, dtype=np.int64))
        tps.append(tip[ok])
        axs.append(ax[ok])
    if not pts:
        z = np.zeros((0, 3))
        return z, np.zeros(0, np.int64), z, z
    return np.vstack(pts), np.concatenate(ids), np.vstack(tps), np.vstack(axs)
