"""Rapids kept clear of the in-process stock: the feed moves out of (and into) the material
stretched along the tool axis until the rapids between them clear the stock.

A linked program leaves a pass by a retract at feed along the tool axis to a point the
approach distance off the *part* (:func:`..paths.linking.approach_length`), rapids (via the
clearance surface, or straight to the next pass's approach point when it is near) and
approaches the next pass at feed along its axis. Where an earlier operation left more stock
than that distance (the rough stock by the hub and in the fillet, before hub and fillet
finishing remove it), the rapid runs through material: in the template a rapid of blade
finishing went 1.3 mm deep through the rough stock by the hub. :func:`clear_rapids` lifts the
retract's end and the approach's start of such a route out along their own tool axes, by the
least multiple of ``step`` for which the cutter, grown by ``margin`` and posed every ``step``
along the rapids (axes slerped), meets no material; the feed moves stay on their lines.

The stock given is the one the operation starts on: every material it will cut is in it, so
the lift is conservative. A route that no lift up to ``lift_max`` clears is left as it was
and counted (the job's simulation then reports it). Lengths mm.
"""

from __future__ import annotations

import math

import numpy as np

from ..kernels import stock as compiled_stock
from ..tool.cutter import as_cutter
from ..toolpath.types import MOVE_APPROACH, MOVE_RAPID, MOVE_RETRACT, Program
from .dexels import RadialDexels
from .removal import (
    _cut,
    _job_compiled,
    _overlap,
    _shrink,
    _slerp_rows,
    cutter_halfplanes,
    halfplane_bounds,
    halfplane_edges,
)

__all__ = ["clear_rapids", "cutter_meets_stock"]

def cutter_meets_stock(dex: RadialDexels, cutter, tips, axes, margin: float) -> np.ndarray:
    """(k,) bool: the cutter posed at ``tips`` (k, 3) with unit ``axes``, grown by ``margin``
    mm, meets material of ``dex`` (not changed)."""
    c = as_cutter(cutter)
    out = np.zeros(len(tips), bool)
    if not len(tips):
        return out
    planes = _shrink(cutter_halfplanes(c), -float(margin))
    tips, axes = np.asarray(tips, float), np.asarray(axes, float)
    z0, z1, rad = -margin, c.h + margin, c.max_radius + margin
    if compiled_stock.available():  # each pose its own group, measured before any removal
        r_cap = float(dex.hi.max()) if dex.hi.size else 0.0
        per = _job_compiled(dex.copy(), tips, axes, np.arange(len(tips)), len(tips), planes,
                            z0, z1, rad, True, None,
                            (halfplane_bounds(planes), halfplane_edges(planes)), r_cap)[1]
        return per > 0.0
    rays, a, b, so, _ = _cut(dex, tips, axes, planes, z0, z1, rad, group=64)
    if len(rays):
        vol, _ = _overlap(dex, rays, a, b)
        out[np.unique(so[vol > 0])] = True
    return out


def _run_poses(tip, axis, step):
    """Poses every ``step`` mm along the polyline ``tip`` (k, 3) (its axes slerped), the ends
    included."""
    out_t, out_a = [tip[:1]], [axis[:1]]
    for j in range(1, len(tip)):
        d = float(np.linalg.norm(tip[j] - tip[j - 1]))
        n = max(1, int(math.ceil(d / step)))
        t = np.arange(1, n + 1) / n
        out_t.append(tip[j - 1] + t[:, None] * (tip[j] - tip[j - 1]))
        out_a.append(_slerp_rows(np.repeat(axis[j - 1:j], n, 0), np.repeat(axis[j:j + 1], n, 0),
                                 t))
    return np.vstack(out_t), np.vstack(out_a)


def clear_rapids(program: Program, dex: RadialDexels, cutter, *, margin: float,
                 step: float | None = None, lift_max: float = 20.0) -> tuple[Program, dict]:
    """``program`` with the retract and approach points round its rapids moved out along
    their tool axes until the rapids clear the stock ``dex`` by ``margin`` mm (module
    docstring); a new Program (the same rows) and figures: ``moved`` routes, the ``longest``
    lift (mm), ``still_meeting`` routes no lift up to ``lift_max`` mm clears (left as they
    were)."""
    tip = np.array(program.tip, float)
    axis = np.asarray(program.axis, float)
    axis = axis / np.linalg.norm(axis, axis=1)[:, None]
    move = np.asarray(program.move)
    step = 0.5 * dex.resolution if step is None else float(step)
    moved, longest, still = 0, 0.0, 0
    routes = []
    for m, a, b in program.runs():
        if m != MOVE_RAPID or a < 1 or b >= len(move):
            continue
        # out: the retract's end a − 1 (pose before the rapids); in: the rapids' end b − 1
        # (the approach starts there) — when the feed moves round them run along the axis
        lift = [j for j, ok in ((a - 1, move[a - 1] == MOVE_RETRACT),
                                (b - 1, move[b] == MOVE_APPROACH and b - 1 > a - 1)) if ok]
        if lift:
            routes.append((a, np.arange(a - 1, b), lift))
    # every route as planned at once; the lifts only for those meeting the stock
    poses = [_run_poses(tip[route], axis[route], step) for _, route, _ in routes]
    hit = cutter_meets_stock(dex, cutter, np.vstack([p[0] for p in poses] or [np.zeros((0, 3))]),
                             np.vstack([p[1] for p in poses] or [np.zeros((0, 3))]), margin)
    ends = np.cumsum([0] + [len(p[0]) for p in poses])
    for (a, route, lift), k0, k1 in zip(routes, ends[:-1], ends[1:], strict=True):
        if not hit[k0:k1].any():
            continue
        lifts = np.arange(step, lift_max + 0.5 * step, step)
        found = None
        for c0 in range(0, len(lifts), 16):  # 16 lifts a call
            trials = []
            for s in lifts[c0:c0 + 16]:
                t = tip[route].copy()
                for j in lift:
                    t[j - (a - 1)] += s * axis[j]
                trials.append((s, t, _run_poses(t, axis[route], step)))
            meets = cutter_meets_stock(dex, cutter, np.vstack([p[0] for _, _, p in trials]),
                                       np.vstack([p[1] for _, _, p in trials]), margin)
            cut = np.cumsum([0] + [len(p[0]) for _, _, p in trials])
            found = next(((s, t) for (s, t, _), i0, i1 in zip(trials, cut[:-1], cut[1:],
                                                               strict=True)
                          if not meets[i0:i1].any()), None)
            if found is not None:
                break
        if found is None:
            still += 1
            continue
        tip[route] = found[1]
        moved += 1
        longest = max(longest, float(found[0]))
    out = Program(tip, np.array(program.axis), move.copy(), np.array(program.curve),
                  np.array(program.index), np.array(program.flags),
                  program.collision_status, program.clearance, program.rotation_deg)
    return out, {"moved": moved, "longest_lift_mm": longest, "still_meeting": still}
