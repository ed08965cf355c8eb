"""The roughing tool axis through the channel: it leans with the blades.

A radial tool between two twisted, leaning blades touches one wall with the top of its flute
(or its shank) where the wall leans over the channel and stays far from the wall below: a
wedge of up to (flute length) · tan(lean) is left that no later level removes. The axis here
follows the blades instead. At a station z the blades' **mean camber surface** crosses the
cylinder of radius r_c at θ_m(r_c, z) = ½ (θ_pressure + θ_suction), the middle of the blade's
section there (:class:`.region.Section`). Its change with the radius over the band of
cylinders a level's flute sweeps, s = dθ_m/dr (least squares over the band), is the blades'
tangential lean there; the axis is the radial direction tilted toward +θ by the side tilt
φ(z) with tan φ = r s (the point h up the axis moves h tan φ / r in θ, as the mean camber
surface does). Blade 1 is blade 0 turned by the pitch, so its mean camber surface leans the
same way at the same z: the mean camber lean is the blend of the two sides' leans across the
channel at every position w across it, and every pass of a station takes the same axis.

**Bounded turn.** Along a pass consecutive poses are one station apart; the side tilt is
limited to change by at most ``max_turn`` per station step (a slope limiter: the sequence
clipped forward and backward, the mean of the two — a convex combination of two sequences
whose steps are within the bound keeps its steps within it). Stations inserted between two
base stations interpolate φ linearly, so their steps are smaller. The axis also turns with
the radial direction as the tip moves across θ (a 0.5 mm move at 150 mm radius: 0.2°; where
a pass follows a twisted wall, up to ~1° per station), and that turn adds to the side tilt's:
bounding φ alone does not bound the tool axis. :func:`bound_turn` therefore takes the
finished poses of a pass and, where two consecutive axes are more than ``max_turn`` apart
(angle ω), inserts k − 1 poses between them, k = ⌈ω / max_turn⌉: the tip on the straight
move between the two (where the machine takes it anyway), the axis on the great circle
between the two axes at equal angles (spherical linear interpolation), so every step turns
by ω / k ≤ ``max_turn`` — measured on the actual axes, not on φ. The motion is the one the
machine makes between the two poses; only its resolution changes.

Where no blade is near (before the leading and after the trailing edge), the nearest
station's tilt is held. Units mm, radians.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["bound_turn", "limit_turn", "mean_camber_lean", "tilted_axes", "turn_angles"]


def _section_mid(sec, z, half: float) -> np.ndarray:
    """(n,) θ_m of one section at the stations ``z``: the middle of the section's θ among its
    points within ``half`` mm of the station (NaN where it has none)."""
    out = np.full(len(z), np.nan)
    if len(sec.z) == 0:
        return out
    a = np.searchsorted(sec.z, z - half, "left")
    b = np.searchsorted(sec.z, z + half, "right")
    has = b > a
    if not has.any():
        return out
    a, b = a[has], b[has]
    cnt = b - a
    idx = np.repeat(a - np.cumsum(cnt) + cnt, cnt) + np.arange(int(cnt.sum()))
    starts = np.cumsum(cnt) - cnt
    lo = np.minimum.reduceat(sec.theta[idx], starts)
    hi = np.maximum.reduceat(sec.theta[idx], starts)
    out[has] = 0.5 * (lo + hi)
    return out


def mean_camber_lean(sections, z, r_lo, r_hi, half: float = 0.3,
                     max_lean: float = math.radians(30.0)) -> np.ndarray:
    """(n,) side tilt φ (rad, within ±``max_lean``) at the stations ``z`` (n,) following the
    blades' mean camber surface over the cylinders between ``r_lo`` and ``r_hi`` (n,) mm
    (module docstring); held from the nearest station where the blade does not cross every
    cylinder of the band (0 where it does nowhere)."""
    z = np.asarray(z, float)
    r_lo = np.broadcast_to(np.asarray(r_lo, float), z.shape)
    r_hi = np.broadcast_to(np.asarray(r_hi, float), z.shape)
    rc = np.array([s.radius for s in sections])
    mids = np.stack([_section_mid(s, z, half) for s in sections]) if len(sections) else \
        np.zeros((0, len(z)))
    # least squares of θ_m against r_c per station, over the band's sections
    band = (rc[:, None] >= r_lo[None]) & (rc[:, None] <= r_hi[None])
    use = np.isfinite(mids) & band
    w = use.astype(float)
    n = w.sum(axis=0)
    # a station counts where the blade crosses every cylinder of the band: near the leading
    # and trailing edges, which move along z with the radius, a fit over the part of the band
    # the blade still reaches follows the edge's sweep, not the camber surface
    full = n >= band.sum(axis=0)
    m = np.where(use, mids, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        r_mean = (w * rc[:, None]).sum(axis=0) / n
        t_mean = m.sum(axis=0) / n
        dr = np.where(use, rc[:, None] - r_mean[None], 0.0)
        slope = (dr * np.where(use, mids - t_mean[None], 0.0)).sum(axis=0) / \
            (dr * dr).sum(axis=0)
    ok = full & (n >= 2) & np.isfinite(slope)
    if not ok.any():
        return np.zeros(len(z))
    phi = np.clip(np.arctan(slope * 0.5 * (r_lo + r_hi)), -max_lean, max_lean)
    idx = np.nonzero(ok)[0]
    pos = np.clip(np.searchsorted(idx, np.arange(len(z))), 0, len(idx) - 1)
    left = idx[np.clip(pos - 1, 0, len(idx) - 1)]
    right = idx[pos]
    near = np.where(np.abs(z[left] - z) <= np.abs(z[right] - z), left, right)
    return np.where(ok, phi, phi[near])


def limit_turn(phi, max_step: float) -> np.ndarray:
    """(n,) ``phi`` (rad) with consecutive values at most ``max_step`` apart: the mean of the
    sequence clipped forward and backward (module docstring)."""
    phi = np.asarray(phi, float)
    if len(phi) < 2 or not math.isfinite(max_step):
        return phi.copy()
    f = phi.copy()
    for i in range(1, len(f)):
        f[i] = min(max(f[i], f[i - 1] - max_step), f[i - 1] + max_step)
    b = phi.copy()
    for i in range(len(b) - 2, -1, -1):
        b[i] = min(max(b[i], b[i + 1] - max_step), b[i + 1] + max_step)
    return 0.5 * (f + b)


def turn_angles(axes) -> np.ndarray:
    """(n − 1,) angles (rad) between consecutive unit axes (n, 3): atan2(|a × b|, a · b),
    accurate also for small angles (arccos of the dot product loses half the digits)."""
    a = np.asarray(axes, float)
    if len(a) < 2:
        return np.zeros(0)
    return np.arctan2(np.linalg.norm(np.cross(a[:-1], a[1:]), axis=1),
                      np.einsum("ij,ij->i", a[:-1], a[1:]))


def bound_turn(tips, axes, max_step: float):
    """Poses (tips (n, 3) mm, unit axes (n, 3)) with poses inserted where consecutive axes
    turn by more than ``max_step`` (rad): k − 1 poses between two that are ω apart,
    k = ⌈ω / max_step⌉, tips on the straight move between them and axes on the great circle
    at equal angles (module docstring). Returns (tips, axes, inserted); the input arrays
    themselves when nothing is inserted."""
    tips = np.asarray(tips, float)
    axes = np.asarray(axes, float)
    if len(tips) < 2 or not math.isfinite(max_step):
        return tips, axes, 0
    w = turn_angles(axes)
    # a hair under the bound, so that ω / k never rounds above it
    k = np.maximum(1, np.ceil(w / (max_step * (1.0 - 1e-9)))).astype(np.int64)
    if (k == 1).all():
        return tips, axes, 0
    seg = np.repeat(np.arange(len(w)), k)
    j = np.arange(int(k.sum())) - np.repeat(np.cumsum(k) - k, k)
    t = (j / k[seg])[:, None]
    p = tips[seg] + t * (tips[seg + 1] - tips[seg])
    om = w[seg][:, None]
    with np.errstate(invalid="ignore", divide="ignore"):
        s = np.sin(om)
        c0 = np.where(j[:, None] > 0, np.sin((1.0 - t) * om) / s, 1.0)
        c1 = np.where(j[:, None] > 0, np.sin(t * om) / s, 0.0)
    a = c0 * axes[seg] + c1 * axes[seg + 1]
    a /= np.linalg.norm(a, axis=1)[:, None]
    # the original poses unchanged (bit for bit)
    a[j == 0] = axes[seg[j == 0]]
    return (np.concatenate([p, tips[-1:]]), np.concatenate([a, axes[-1:]]),
            int(k.sum() - len(w)))


def tilted_axes(axis, theta, lead: float, side):
    """(radial directions (k, 3), unit tool axes (k, 3)) at the angles ``theta`` (k,) rad
    about the blisk ``axis`` (:class:`..geometry.axis.Axis`): the radial direction tilted by
    ``lead`` (rad) toward +z and ``side`` (k,) rad toward +θ."""
    e1, e2, d = axis.angular_frame()
    u = np.cos(theta)[:, None] * e1 + np.sin(theta)[:, None] * e2
    t = -np.sin(theta)[:, None] * e1 + np.cos(theta)[:, None] * e2
    a = u + np.tan(side)[:, None] * t + math.tan(lead) * d
    return u, a / np.linalg.norm(a, axis=1)[:, None]
