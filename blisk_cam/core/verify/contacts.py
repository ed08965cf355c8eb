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
    tips (q, 3), axes (q, 3)). Every figure is row by row: the rows of all passes are
    gathered first and each step runs once on all of them (the same bits as pass by pass)."""
    if not len(curves):
        z = np.zeros((0, 3))
        return z, np.zeros(0, np.int64), z, z
    t = np.arange(0, nsub) / nsub
    tips, nns, tts, u_a, u_b, last = [], [], [], [], [], []
    for c in curves:
        tips_a, tips_b = _curve_polyline(c, c.tip)
        ax_a, ax_b = _curve_polyline(c, c.axis)
        n_a, n_b = _curve_polyline(c, c.normal)
        m = len(tips_a)
        tt = np.tile(t, m)
        rep_ = np.repeat(np.arange(m), nsub)
        tips.append(tips_a[rep_] + tt[:, None] * (tips_b - tips_a)[rep_])
        nns.append(n_a[rep_] + tt[:, None] * (n_b - n_a)[rep_])
        tts.append(tt)
        u_a.append(ax_a[rep_])
        u_b.append(ax_b[rep_])
        last.append(not (c.closed and len(c.tip) > 2))  # the last pose itself
    axs = np.split(slerp(unit(np.concatenate(u_a), keep_zero=False),
                         unit(np.concatenate(u_b), keep_zero=False), np.concatenate(tts),
                         weights_first=True), np.cumsum([len(x) for x in tts])[:-1])
    for i, c in enumerate(curves):
        if last[i]:
            tips[i] = np.vstack([tips[i], c.tip[-1:]])
            axs[i] = np.vstack([axs[i], c.axis[-1:] / np.linalg.norm(c.axis[-1])])
            nns[i] = np.vstack([nns[i], c.normal[-1:]])
    ids = np.repeat(np.arange(len(curves)), [len(x) for x in tips])
    tip, ax, nn = np.vstack(tips), np.vstack(axs), np.vstack(nns)
    nn /= np.maximum(np.linalg.norm(nn, axis=1), 1e-300)[:, None]
    th = np.arctan2(np.linalg.norm(np.cross(nn, ax), axis=1), dot(nn, ax))
    ok = th <= 0.5 * np.pi - cutter.beta
    off, _ = cutter.contact(nn[ok], ax[ok])
    return tip[ok] - off, ids[ok], tip[ok], ax[ok]
