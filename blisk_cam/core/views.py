"""Camera directions for pictures of a blade (numpy only).

:func:`pressure_side_view` — the direction from the blade toward a camera that looks at its
pressure side, the concave one, where a finishing path is easiest to read (the default preview
used to look from the tip toward the hub, along the blade's span, where the passes pile up).
"""

from __future__ import annotations

import numpy as np

from .cones import Axis
from .errors import MeshError

__all__ = ["pressure_side_view", "side_concavity"]


def _face_data(V, F):
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    if V.ndim != 2 or V.shape[1] != 3 or F.ndim != 2 or F.shape[1] != 3 or len(F) == 0:
        raise MeshError(f"a view needs a triangle mesh: V (n, 3), F (m, 3); got {V.shape}, "
                        f"{F.shape}")
    if not np.all(np.isfinite(V)):
        raise MeshError("the mesh has NaN or infinite coordinates")
    if F.min() < 0 or F.max() >= len(V):
        raise MeshError("the mesh's faces index vertices that do not exist")
    t = V[F]
    n2 = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])  # area-weighted normals (× 2)
    return t.mean(axis=1), n2


def side_concavity(centroids, n2, normal, radial, *, bands: int = 6):
    """Camber of one side of a blade: faces ``centroids`` (k, 3) with area-weighted normals
    ``n2`` (k, 3), the side's mean unit ``normal`` (3,) and the faces' unit ``radial``
    directions (k, 3) from the blisk axis.

    Along the chord direction u (in the side's plane, across the radial direction), a concave
    side's normals tilt toward its middle — n·u falls as u grows, slope < 0 — and a convex
    one's away from it (slope > 0). The slope (1/mm, a mean curvature along the chord) is
    fitted per band of radius (the blade twists along its span, which would otherwise mix
    in) on the middle 70 % of the chord (around a leading/trailing edge the normals turn by
    up to 90° within a millimetre), and averaged by area."""
    a = np.linalg.norm(n2, axis=1)
    keep = a > 0
    c, n, w, rad = centroids[keep], n2[keep] / a[keep, None], a[keep], radial[keep]
    span = np.average(rad, axis=0, weights=w)
    u = np.cross(span, normal)
    if np.linalg.norm(u) == 0:
        return 0.0
    u /= np.linalg.norm(u)
    r = c @ span  # position along the span
    edges = np.quantile(r, np.linspace(0.0, 1.0, bands + 1))
    b = np.clip(np.searchsorted(edges, r, side="right") - 1, 0, bands - 1)
    t_all, y_all = c @ u, n @ u
    slopes, weights = [], []
    for k in range(bands):
        m = b == k
        if m.sum() < 10:
            continue
        t, y, ww = t_all[m], y_all[m], w[m]
        lo, hi = np.percentile(t, [15.0, 85.0])
        mid = (t >= lo) & (t <= hi)
        t, y, ww = t[mid], y[mid], ww[mid]
        tm, ym = np.average(t, weights=ww), np.average(y, weights=ww)
        var = np.average((t - tm) ** 2, weights=ww)
        if var > 0:
            slopes.append(np.average((t - tm) * (y - ym), weights=ww) / var)
            weights.append(ww.sum())
    return float(np.average(slopes, weights=weights)) if slopes else 0.0


def pressure_side_view(V, F, axis: Axis, *, elevation: float = 0.35):
    """Unit direction (3,) from the blade toward a camera facing its pressure (concave) side.

    The faces are split by the sign of their normal's circumferential component (about the
    blisk ``axis``) into the two sides of the blade; the side whose normals converge (see
    :func:`side_concavity`) is the pressure side, and the camera looks along its mean normal,
    raised by ``elevation`` (radians) toward the blade tip (radially outward) so the passes,
    which run around the blade at roughly constant radius, are seen as lines, not edge-on.
    """
    cen, n2 = _face_data(V, F)
    p = cen - np.asarray(axis.o, dtype=np.float64)
    d = np.asarray(axis.d, dtype=np.float64)
    radial = p - np.outer(p @ d, d)
    rn = np.linalg.norm(radial, axis=1)
    if not np.any(rn > 0):
        raise MeshError("the blade lies on the blisk axis: no side to look at")
    radial = radial / np.where(rn > 0, rn, 1.0)[:, None]
    circ = np.cross(d, radial)
    side = np.einsum("ij,ij->i", n2, circ)
    sides = []
    for mask in (side > 0, side < 0):
        if mask.sum() < 3:
            continue
        m = n2[mask].sum(axis=0)
        if np.linalg.norm(m) == 0:
            continue
        m = m / np.linalg.norm(m)
        sides.append((side_concavity(cen[mask], n2[mask], m, radial[mask]), m))
    if not sides:
        raise MeshError("cannot tell the blade's sides apart (no faces facing around the axis)")
    normal = min(sides, key=lambda x: x[0])[1]  # the more concave side
    out = np.average(radial, axis=0, weights=np.linalg.norm(n2, axis=1))
    out = out - (out @ normal) * normal
    if np.linalg.norm(out) > 0:
        out = out / np.linalg.norm(out)
    v = np.cos(elevation) * normal + np.sin(elevation) * out
    return v / np.linalg.norm(v)
