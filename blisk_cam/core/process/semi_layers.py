"""Semi-finishing in offset layers: the blade taken from the roughing's stock down to the
semi-finishing allowance in K depth steps, each a whole pass set (paper 003 §5 leaves 0.1 mm
for finishing after roughing left 0.5 mm; its "25 layers" of semi-finishing are its cutting
layers — the passes round the blade —, which the cusp spaces here).

Layer i (1 … K) is a whole LMC finishing pass set of the blade offset by its allowance

    a_i = a + (a_0 − a) (K − i) / K,

a the allowance left at the end (the last layer's), a_0 the stock on the blade before
(``offset_from``: the roughing's allowance, 0.5 mm by default): each layer removes
(a_0 − a)/K more. :func:`layer_allowances` gives them; the blade finishing operation
(:mod:`.blade_finish`) plans each layer as its own semi-finishing path and
:func:`join_programs` runs them one after another: between two layers the tool leaves the
last layer's clearance point radially to the larger of the two layers' clearance radii, goes
round the blisk axis on that cylinder as rapids (the shorter way, steps of at most the
linking's rapid step about the axis, height linear, tool axis slerped — as the linker's own
rapids along the clearance surface) and enters the next layer's program at its first
clearance point. Units mm, radians.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import ToleranceError
from ..geometry.axis import Axis, cylindrical, from_cylindrical
from ..geometry.vectors import slerp
from ..toolpath.types import MOVE_RAPID, Program

__all__ = ["join_programs", "layer_allowances", "merge_layer_stats"]

#: stats summed over the layers (counts, lengths); the others are the last layer's
_SUMMED = ("passes", "curves", "poses", "links_rerouted", "links_rerouted_still_cutting",
           "clearance_routes_cutting", "zero_speed_poses")


def layer_allowances(allowance: float, start: float, layers: int) -> list[float]:
    """[a_1 … a_K] (mm), from the thickest layer to ``allowance`` (module docstring).
    ToleranceError when ``layers`` is not a whole number ≥ 1 or, with more than one layer,
    ``start`` (the stock before) is not more than ``allowance``."""
    if isinstance(layers, bool) or int(layers) != layers or layers < 1:
        raise ToleranceError(f"offset layers must be a whole number ≥ 1, got {layers!r}")
    k, a, a0 = int(layers), float(allowance), float(start)
    if k == 1:
        return [a]
    if not (math.isfinite(a0) and a0 > a):
        raise ToleranceError(
            f"{k} offset layers go from the stock before semi-finishing (offset from, {a0:g} "
            f"mm) down to the allowance {a:g} mm: give an offset from more than the allowance "
            "(the roughing's allowance, e.g. 0.5 mm), or one layer")
    return [round(a + (a0 - a) * (k - i) / k, 9) for i in range(1, k + 1)]


def _route(p, a, q, b, axis: Axis, rapid_step: float):
    """Rapid rows (tips (m, 3), axes (m, 3)) from pose (p, a) to just before (q, b): out
    radially to the larger of the two radii, round the axis on that cylinder."""
    r, th, z, frame = cylindrical(np.vstack([p, q]), axis)
    R = float(r.max())
    rows_t, rows_a = [], []
    if r[0] < R - 1e-9:
        rows_t.append(from_cylindrical(np.array([R]), th[:1], z[:1], axis, frame)[0])
        rows_a.append(np.asarray(a, float))
    dth = float((th[1] - th[0] + math.pi) % (2 * math.pi) - math.pi)
    n = max(1, int(math.ceil(abs(dth) / float(rapid_step))))
    t = np.arange(1, n + 1) / n
    along = from_cylindrical(np.full(n, R), th[0] + t * dth, z[0] + t * (z[1] - z[0]), axis,
                             frame)
    axes = slerp(np.asarray(a, float), np.asarray(b, float), t)
    keep = np.linalg.norm(along - q, axis=1) > 1e-9  # the last one is q when r(q) = R
    rows_t.extend(along[keep])
    rows_a.extend(axes[keep])
    return np.asarray(rows_t, float).reshape(-1, 3), np.asarray(rows_a, float).reshape(-1, 3)


def join_programs(programs, curve_counts, axis: Axis, rapid_step: float) -> Program:
    """One program of the layers' ``programs`` (each a linked :class:`Program` that starts
    and ends on its clearance surface) in order, joined by rapids (module docstring);
    ``curve_counts`` (K,) the passes of each layer: layer i's pass c becomes pass
    Σ_{j<i} counts_j + c."""
    parts = []
    offset = 0
    prev = None
    for prog, n in zip(programs, curve_counts, strict=True):
        if prev is not None:
            t, a = _route(prev.tip[-1], prev.axis[-1], prog.tip[0], prog.axis[0], axis,
                          rapid_step)
            m = len(t)
            parts.append((t, a, np.full(m, MOVE_RAPID, np.int8), np.full(m, -1, np.int64),
                          np.full(m, -1, np.int64), np.zeros(m, np.uint8)))
        curve = np.where(prog.curve >= 0, prog.curve + offset, -1).astype(np.int64)
        parts.append((prog.tip, prog.axis, np.asarray(prog.move, np.int8), curve,
                      np.asarray(prog.index, np.int64), np.asarray(prog.flags, np.uint8)))
        offset += int(n)
        prev = prog
    cols = [np.concatenate([p[k] for p in parts]) for k in range(6)]
    return Program(cols[0].reshape(-1, 3), cols[1].reshape(-1, 3), *cols[2:])


def merge_layer_stats(stats, allowances, curve_counts) -> dict:
    """The stats of a layered path: the last layer's, the counts of :data:`_SUMMED` summed,
    ``offset_layers`` K, ``layer_allowances`` (mm) and ``layer_curves`` (the passes of each layer,
    in the path's order)."""
    out = dict(stats[-1])
    for key in _SUMMED:
        vals = [s[key] for s in stats if isinstance(s.get(key), (int, float))]
        if vals:
            out[key] = type(vals[0])(sum(vals))
    out["offset_layers"] = len(allowances)
    out["layer_allowances"] = [float(a) for a in allowances]
    out["layer_curves"] = [int(n) for n in curve_counts]
    return out
