"""Display values of a result, as arrays: colour ramps and bins of the path curves, the
material-left colours of the verify map, the poses shown as empties, the measured cusp per
pass, and the per-pose move codes and flags of a path. Pure numpy;
``blisk_cam.blender.path_objects`` turns
them into Blender materials and attributes."""

from __future__ import annotations

import numpy as np

from .errors import MeshError
from .geometry.axis import Axis
from .toolpath.types import MOVE_NAMES

__all__ = [
    "COLOR_BINS",
    "MOVE_TYPES",
    "curve_cusp",
    "flags_of",
    "move_codes_of",
    "pose_indices",
    "ramp",
    "spline_bins",
    "spline_pieces",
    "verify_colors",
    "verify_legend",
    "COLLISION_STATUS_NAMES",
    "COLLISION_STATUS_RGBA",
    "pressure_side_view",
    "side_concavity",
]

#: number of colour bins of the path curves (one material each)
COLOR_BINS = 12

#: hard cap on the pose empties (Blender objects) a path is shown with; every pose is in the
#: point cloud anyway
MAX_POSE_EMPTIES = 10_000
#: move type names, index = code, as in ``core.toolpath``
MOVE_TYPES = tuple(MOVE_NAMES)

#: the collision status of a pose (``collision_status`` 0, 1, 2) as named in the summary, the
#: panel and a preview's legend, and its colour (RGBA) on the pose points
COLLISION_STATUS_NAMES = ("clear", "corrected", "unresolved")
COLLISION_STATUS_RGBA = (
    (0.10, 0.80, 0.20, 1.0),
    (1.00, 0.45, 0.02, 1.0),
    (0.95, 0.03, 0.03, 1.0),
)

_RAMP = np.array(
    [  # blue → cyan → green → yellow → red
        (0.10, 0.25, 1.00),
        (0.05, 0.80, 0.95),
        (0.15, 0.85, 0.25),
        (0.98, 0.85, 0.10),
        (0.95, 0.15, 0.10),
    ]
)


def ramp(t):
    """(n,) values in [0, 1] → (n, 3) RGB along ``_RAMP``."""
    t = np.clip(np.asarray(t, dtype=np.float64), 0.0, 1.0) * (len(_RAMP) - 1)
    i = np.minimum(t.astype(int), len(_RAMP) - 2)
    w = (t - i)[:, None]
    return (1.0 - w) * _RAMP[i] + w * _RAMP[i + 1]


def spline_bins(mode: str, s, cusp, cusp_tolerance: float) -> np.ndarray:
    """Material bin (index into the ramp materials) of each spline.

    mode : "SOLID" (all 0 — the single solid material), "MORPH" (s in [0, 1] → bins) or
    "CUSP" (measured cusp / tolerance in [0, 1] → bins; unknown cusp → bin 0).
    """
    s = np.asarray(s, dtype=np.float64)
    if mode == "SOLID":
        return np.zeros(len(s), dtype=np.int64)
    if mode == "CUSP":
        c = np.asarray(cusp, dtype=np.float64)
        t = np.where(np.isfinite(c) & (c >= 0), c / max(cusp_tolerance, 1e-12), 0.0)
    else:
        t = s
    return np.clip((np.clip(t, 0.0, 1.0) * COLOR_BINS).astype(np.int64), 0, COLOR_BINS - 1)


def spline_pieces(path, key: str = "cc", cusp=None):
    """The splines of a path's curve object: (point sets (k, 3) mm, closed flags, s, cusp).

    One spline per pass curve — except a spiral (a curve whose ``ratio`` varies per pose),
    which is cut where its ratio enters another colour bin (:data:`COLOR_BINS`), so that
    "Morph Ratio" colours it along its ratio instead of with the one colour of its first
    pose; consecutive pieces share their end point, so the spiral stays unbroken. Each
    piece's s is the mean ratio of its poses."""
    cusp = np.full(len(path.curves), np.nan) if cusp is None else np.asarray(cusp, float)
    sets, closed, s, sc = [], [], [], []
    for c, cv in zip(path.curves, cusp, strict=True):
        pts = np.asarray(getattr(c, key), dtype=np.float64)
        if c.ratio is None or len(pts) < 3:
            sets.append(pts)
            closed.append(bool(c.closed))
            s.append(float(c.s))
            sc.append(float(cv))
            continue
        r = np.asarray(c.ratio, dtype=np.float64)
        b = np.clip((np.clip(r, 0.0, 1.0) * COLOR_BINS).astype(np.int64), 0, COLOR_BINS - 1)
        bounds = np.concatenate([[0], np.nonzero(np.diff(b))[0] + 1, [len(pts)]])
        ring = np.vstack([pts, pts[:1]]) if c.closed else pts
        for a, z in zip(bounds[:-1], bounds[1:], strict=True):
            sets.append(ring[a : z + 1])  # up to the next piece's first point
            closed.append(False)
            s.append(float(r[a:z].mean()))
            sc.append(float(cv))
    return sets, closed, s, sc


def verify_colors(values, cusp: float, chord: float) -> np.ndarray:
    """RGBA (n, 4) float of material-left values (mm; > 0 left, < 0 gouge, NaN outside).

    0 → green, ``cusp`` → blue, above ``cusp + chord`` purple (out of tolerance); a gouge
    pales to red at ``-chord`` and beyond; NaN grey.
    """
    v = np.asarray(values, dtype=np.float64)
    rgb = np.empty((len(v), 3))
    nan = ~np.isfinite(v)
    left = ~nan & (v >= 0)
    gouge = ~nan & (v < 0)
    green, blue = np.array([0.15, 0.75, 0.25]), np.array([0.10, 0.30, 0.95])
    t = np.clip(v[left] / max(cusp, 1e-12), 0.0, 1.0)[:, None]
    rgb[left] = (1.0 - t) * green + t * blue
    over = left & (v > cusp + chord)
    rgb[over] = (0.65, 0.10, 0.85)
    g = np.clip(-v[gouge] / max(chord, 1e-12), 0.0, 1.0)[:, None]
    rgb[gouge] = (1.0 - g) * np.array([1.0, 0.75, 0.7]) + g * np.array([0.9, 0.0, 0.0])
    rgb[nan] = 0.5
    return np.concatenate([rgb, np.ones((len(v), 1))], axis=1)


def verify_legend(cusp: float, chord: float) -> list:
    """What the colours of :func:`verify_colors` mean, as (label, RGBA) pairs for a legend:
    the colour of each named value, computed by :func:`verify_colors` itself (mm)."""
    values = [0.0, cusp, cusp + chord + max(cusp, chord, 1e-9), -chord, np.nan]
    labels = ["0 left", f"{cusp:g} mm left", "over tolerance", f"gouge {chord:g} mm",
              "not measured"]
    rgba = verify_colors(np.array(values, dtype=np.float64), cusp, chord)
    return [(lab, tuple(float(x) for x in c)) for lab, c in zip(labels, rgba, strict=True)]


# --- helpers -----------------------------------------------------------------------------
def pose_indices(n_poses: int, count: int) -> np.ndarray:
    """Indices of ``min(count, n_poses)`` poses spread evenly over ``n_poses`` (first and
    last included), increasing and unique."""
    n, k = int(n_poses), max(int(count), 0)
    if n <= 0 or k <= 0:
        return np.zeros(0, dtype=np.int64)
    if k >= n:
        return np.arange(n, dtype=np.int64)
    if k == 1:
        return np.zeros(1, dtype=np.int64)
    return np.unique(np.round(np.linspace(0, n - 1, k)).astype(np.int64))


def _level_cusp(levels, pair_levels, pair_values) -> np.ndarray:
    """Cusp next to each level: max of the pairs it belongs to (NaN when unknown)."""
    out = np.full(len(levels), np.nan)
    for (a, b), v in zip(pair_levels, pair_values, strict=False):
        if not np.isfinite(v):
            continue
        for s in (a, b):
            i = int(np.argmin(np.abs(levels - s))) if len(levels) else -1
            if i >= 0 and abs(levels[i] - s) < 1e-9:
                out[i] = np.fmax(out[i], v)
    return out


def curve_cusp(path, verify) -> np.ndarray:
    """(n_curves,) measured cusp next to each curve's pass, mm (NaN when unknown)."""
    s = np.array([c.s for c in path.curves], dtype=np.float64)
    levels = np.unique(s)
    if verify is not None and len(getattr(verify, "pair_cusp", ())):
        pairs, vals = np.asarray(verify.pair_s), np.asarray(verify.pair_cusp)
    else:
        vals = np.asarray(path.stats.get("measured_cusp", []), dtype=np.float64)
        pairs = np.stack([levels[:-1], levels[1:]], axis=1) if len(levels) > 1 else []
        if len(vals) != len(pairs):
            return np.full(len(s), np.nan)
    lc = _level_cusp(levels, pairs, vals)
    return lc[np.searchsorted(levels, s)] if len(levels) else np.zeros(0)


def move_codes_of(path):
    """(n_poses,) int move codes and the list of names (index = code)."""
    names = list(MOVE_TYPES)
    parts = []
    for c in path.curves:
        mv = getattr(c, "move", None)
        if mv is None or len(mv) != len(c):
            parts.append(np.zeros(len(c), dtype=np.int64))
            continue
        mv = np.asarray(mv)
        if np.issubdtype(mv.dtype, np.integer):
            parts.append(mv.astype(np.int64))
            continue
        mv = mv.astype(str)
        uniq, inv = np.unique(mv, return_inverse=True)
        for u in uniq:
            if u not in names:
                names.append(str(u))
        lut = np.array([names.index(str(u)) for u in uniq], dtype=np.int64)
        parts.append(lut[inv])
    codes = np.concatenate(parts) if parts else np.zeros(0, dtype=np.int64)
    return codes, names


def flags_of(path):
    parts = []
    for c in path.curves:
        fl = getattr(c, "flags", None)
        if fl is None or len(fl) != len(c):
            parts.append(np.zeros(len(c), dtype=np.int64))
        else:
            parts.append(np.asarray(fl).astype(np.int64))
    return np.concatenate(parts) if parts else np.zeros(0, dtype=np.int64)


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
