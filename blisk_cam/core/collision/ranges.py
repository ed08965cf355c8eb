"""Unresolved poses as ranges (pass, from, to, why) and the tool body that would clear them.

A contact no tool axis within the limits can reach is a fact about the tool and its holder:
:func:`holder_hint` searches the holder diameter (the body's radii above the shank, down to
the shank's), the stick-out (the holder moved up the axis) and, when neither does, a neck
(the shank's radius down to half) that would clear the
unresolved poses at their planned or chosen axes, with the same obstacles
(:meth:`.scene.CollisionScene.with_assembly`). mm, degrees in the texts.
"""

from __future__ import annotations

import numpy as np

from ..tool.assembly import ToolAssembly
from ..toolpath.types import STATUS_UNRESOLVED
from .posed_tool import PART_FLUTE

__all__ = ["describe_ranges", "holder_hint", "unresolved_ranges"]

#: unresolved poses sampled by the holder search (evenly over them)
_HINT_POSES = 100
#: stick-out increments tried, mm
_STICK_OUT = (5.0, 10.0, 15.0, 20.0, 30.0, 40.0, 60.0, 80.0, 100.0)


def unresolved_ranges(offs, status, clearance, plan=None) -> list[dict]:
    """[{"pass", "from", "to", "why", "min_clearance"}] of the runs of unresolved pass poses
    (``status`` (n,) over the stacked passes, ``offs`` their offsets); the reasons from the
    :class:`.axis_plan.AxisPlan` where it planned the pose, else "collides"."""
    by_plan = {}
    if plan is not None:
        for r in plan.ranges:
            for i in range(r.first, r.last + 1):
                by_plan[(r.curve, i)] = r.why
    out = []
    bad = np.asarray(status) == STATUS_UNRESOLVED
    for ci in range(len(offs) - 1):
        s, e = int(offs[ci]), int(offs[ci + 1])
        u = np.nonzero(bad[s:e])[0]
        if len(u) == 0:
            continue
        w = np.asarray([by_plan.get((ci, int(i)), "collides") for i in u], dtype=object)
        cut = np.nonzero((np.diff(u) > 1) | (w[1:] != w[:-1]))[0] + 1
        for run, ws in zip(np.split(u, cut), np.split(w, cut), strict=True):
            out.append({"pass": ci, "from": int(run[0]), "to": int(run[-1]), "why": str(ws[0]),
                        "min_clearance": float(np.min(clearance[s + run]))})
    return out


def describe_ranges(ranges, limit: int = 3) -> str:
    """'pass 3 poses 10–24 (why), …' of the first ``limit`` ranges."""
    parts = [f"pass {r['pass']} poses {r['from']}–{r['to']} ({r['why']})"
             for r in ranges[:limit]]
    more = len(ranges) - limit
    return "; ".join(parts) + (f"; and {more} more range(s)" if more > 0 else "")


def _first(values, ok, largest):
    """Bisection over ascending ``values`` for a predicate that holds from some value down
    (``largest``: the largest value that holds) or up (the smallest): None if none does."""
    lo, hi = 0, len(values) - 1
    best = None
    while lo <= hi:
        mid = (lo + hi) // 2
        if ok(values[mid]):
            best = values[mid]
            if largest:
                lo = mid + 1
            else:
                hi = mid - 1
        elif largest:
            hi = mid - 1
        else:
            lo = mid + 1
    return None if best is None else float(best)


def _clears(scene, tips, axes):
    return scene.detect(tips, axes).clearance >= scene.safety


def holder_hint(scene, P, unresolved, plan=None) -> str:
    """One sentence naming the holder diameter or stick-out that would clear the unresolved
    poses (mask ``unresolved`` (n,) over the stacked pass poses ``P``), or that the flute
    itself collides (a smaller cutter is needed), or that no holder of the search clears."""
    idx = np.nonzero(unresolved)[0]
    if len(idx) == 0:
        return ""
    if len(idx) > _HINT_POSES:
        idx = idx[np.linspace(0, len(idx) - 1, _HINT_POSES).astype(np.int64)]
    poses = [(P.tip0[idx], P.ax0[idx]), (P.tip[idx], P.ax[idx])]
    det = scene.detect(P.tip[idx], P.ax[idx])
    flute = np.mean(det.part == PART_FLUTE) > 0.5
    asm = scene.assembly
    prof = np.asarray(asm.profile, dtype=np.float64)
    rs = float(prof[0, 1])

    def ok_with(profile):
        sc = scene.with_assembly(ToolAssembly(asm.flute_length, tuple(map(tuple, profile)),
                                              asm.safety))
        good = np.zeros(len(idx), bool)
        for t, a in poses:
            good |= _clears(sc, t, a)
        return bool(good.all())

    found = []
    wide = prof[:, 1] > rs + 1e-9
    if wide.any():
        rh = float(prof[wide, 1].max())

        def slim(r):
            p = prof.copy()
            p[wide, 1] = np.minimum(p[wide, 1], r)
            return p

        radii = np.arange(rh - 1.0, rs - 1e-9, -1.0)  # descending: the first that clears
        r = _first(radii[::-1], lambda r: ok_with(slim(r)), largest=True)
        if r is not None:
            found.append(f"a holder of Ø{2 * r:g} mm or less (now Ø{2 * rh:g})")
        first = int(np.argmax(wide))
        z0 = float(prof[first - 1, 0]) if first > 0 else float(prof[0, 0])

        def longer(dz):
            p = prof.copy()
            p[first:, 0] += dz
            return np.vstack([p[:first], [[z0 + dz, rs]], p[first:]])

        dz = _first(np.asarray(_STICK_OUT), lambda dz: ok_with(longer(dz)), largest=False)
        if dz is not None:
            found.append(f"the shank out to {z0 + dz:g} mm before the holder (now "
                         f"{z0:g} mm)")
    if not found:  # a slimmer neck all the way up (a necked tool, the holder kept)
        def neck(r):
            p = prof.copy()
            p[~wide, 1] = np.minimum(p[~wide, 1], r)
            return p

        necks = np.arange(0.5 * rs, rs - 0.25, 0.5)
        r = _first(necks, lambda r: ok_with(neck(r)), largest=True)
        if r is not None:
            found.append(f"a neck of Ø{2 * r:g} mm or less up to the holder (now "
                         f"Ø{2 * rs:g})")
    n = int(np.sum(unresolved))
    if found:
        return (f"{n} unresolved pose(s) would clear with " + " or with ".join(found)
                + f" ({asm.describe()})")
    if flute:
        return (f"{n} unresolved pose(s): the flute itself touches the neighbouring blade; "
                f"no holder clears them — a smaller cutter or a larger lean limit")
    return (f"{n} unresolved pose(s): no holder down to the shank's Ø{2 * rs:g} mm, no "
            f"stick-out up to {_STICK_OUT[-1]:g} mm more and no neck down to Ø{rs:g} mm "
            f"clears them — a smaller cutter or larger lean limits")
