"""Display values of a result, as arrays: colour ramps and bins of the path curves, the
material-left colours of the verify map, the poses shown as empties, the measured cusp per
pass, and the per-pose move codes and flags of a path. Pure numpy; ``blisk_cam.output`` turns
them into Blender materials and attributes."""

from __future__ import annotations

import numpy as np

from .toolpath import MOVE_NAMES

__all__ = ["COLOR_BINS", "MOVE_TYPES", "curve_cusp", "flags_of", "move_codes_of", "pose_indices",
           "ramp", "spline_bins", "spline_pieces", "verify_colors"]

#: number of colour bins of the path curves (one material each)
COLOR_BINS = 12
#: move type names, index = code, as in ``core.toolpath``
MOVE_TYPES = tuple(MOVE_NAMES)

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


