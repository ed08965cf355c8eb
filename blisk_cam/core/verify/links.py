"""What verify measures as cut, and the moves between the cuts (issue 28).

:func:`cut_runs` splits the passes into the runs of poses joined by cut moves, which
:mod:`.measure` measures; every other row of the program (links, approaches, retracts,
rapids) is a move the cutter also makes near the part, so it is judged too
(:func:`link_checks`): how deep the posed cutter goes below the mesh along each such move
(sampled, the axis interpolated), with the program row it ends at. The material those
moves leave at given points (:func:`link_material_left`) completes the cuts' material left
where a link passes closer to the part than the cuts (what a stock simulation of the whole
program sees).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..geometry.vectors import slerp
from ..runtime import check_cancel
from ..tool.cutter import as_cutter
from ..toolpath.types import MOVE_CUT
from .sweep import swept_cutter

__all__ = ["CutRun", "cut_runs", "link_checks", "link_material_left"]


@dataclass
class CutRun:
    """A run of consecutive cutting poses of one pass (what verify measures)."""

    s: float
    closed: bool
    cc: np.ndarray
    normal: np.ndarray
    tip: np.ndarray
    axis: np.ndarray
    ratio: np.ndarray  # (k,) morph ratio of each pose


def cut_runs(curves) -> list[CutRun]:
    """The cutting parts of passes: maximal runs of poses joined by cut moves.

    Pose j's move code (``PassCurve.move``, missing = all "cut", code 0) is the kind of the
    motion that ends at pose j, so the segment j−1 → j is cut when ``move[j]`` is 0 and the
    closing segment of a closed pass when ``move[0]`` is. A pass cut all round stays closed."""
    out = []
    for c in curves:
        k = len(c.cc)
        if k == 0:
            continue
        arr = [np.asarray(x, dtype=np.float64).reshape(-1, 3) for x in (c.cc, c.normal, c.tip,
                                                                         c.axis)]
        ratio = getattr(c, "ratio", None)
        ratio = (np.full(k, float(c.s)) if ratio is None
                 else np.asarray(ratio, dtype=np.float64).reshape(-1))
        move = getattr(c, "move", None)
        cutm = (np.ones(k, bool) if move is None or len(move) != k
                else np.asarray(move).astype(np.int64) == 0)
        if k == 1 or np.all(cutm):
            out.append(CutRun(float(c.s), bool(c.closed) and k > 2, *arr, ratio))
            continue
        # segment j−1 → j is cut where cutm[j]; a closed pass's closing segment k−1 → 0 where
        # cutm[0]: then start the pass at a pose reached by a non-cut move (runs never wrap)
        if c.closed and k > 2 and cutm[0]:
            order = np.roll(np.arange(k), -int(np.nonzero(~cutm)[0][0]))
            arr = [x[order] for x in arr]
            ratio, cutm = ratio[order], cutm[order]
        seg = cutm[1:]
        j = 0
        while j < len(seg):
            if not seg[j]:
                j += 1
                continue
            e = j
            while e < len(seg) and seg[e]:
                e += 1
            idx = np.arange(j, e + 1)  # poses j..e (segments j → e)
            out.append(CutRun(float(c.s), False, *(x[idx] for x in arr), ratio[idx]))
            j = e
    return out


def link_checks(md, program, cutter, rho, subsamples):
    """(depth mm ≥ 0, where (3,) or None, program row or None, moves measured) of the
    program's non-cut moves (:class:`.measure.VerifyReport`, "Links"); ``md`` the mesh's
    :class:`..geometry.distance.MeshDistance`, ``cutter`` the path's cutter (ρ its radius for a
    ball): each move j−1 → j whose
    ``move[j]`` is not a cut, sampled at ``subsamples`` + 1 poses (ends included), the tip
    and the axis interpolated linearly (the axis renormalised)."""
    if program is None or len(program) < 2:
        return 0.0, None, None, 0
    move = np.asarray(program.move)
    rows = np.flatnonzero(move[1:] != MOVE_CUT) + 1
    if not len(rows):
        return 0.0, None, None, 0
    tip = np.asarray(program.tip, dtype=np.float64)
    ax = np.asarray(program.axis, dtype=np.float64)
    t = np.linspace(0.0, 1.0, max(int(subsamples), 1) + 1)
    T = tip[rows - 1][:, None, :] * (1 - t)[None, :, None] + tip[rows][:, None, :] * t[None, :,
                                                                                        None]
    A = ax[rows - 1][:, None, :] * (1 - t)[None, :, None] + ax[rows][:, None, :] * t[None, :,
                                                                                       None]
    T, A = T.reshape(-1, 3), A.reshape(-1, 3)
    A = A / np.maximum(np.linalg.norm(A, axis=1), 1e-300)[:, None]
    row_of = np.repeat(rows, len(t))
    check_cancel()
    if cutter.type == "ball":
        q = md.query(T + rho * A)
        depth = rho - q.signed_distance
    else:
        q = md.query(T + float(cutter.radius) * A)
        depth = -cutter.signed_distance(q.point, T, A)
    k = int(np.argmax(depth))
    d = max(0.0, float(depth[k]))
    return d, (np.asarray(q.point[k]) if d > 0 else None), int(row_of[k]), int(len(rows))


@dataclass
class _MoveRun:
    """Consecutive non-cut moves as one polyline of poses (what :func:`swept_cutter` sweeps)."""

    tip: np.ndarray
    axis: np.ndarray
    closed: bool = False


def link_material_left(program, tool, points, *, tolerance: float = 1e-3,
                       method: str = "fast") -> np.ndarray:
    """(k,) signed distance (mm) from ``points`` (k, 3) to the volume the cutter sweeps along
    the program's non-cut moves (links, approaches, retracts, rapids): the material those
    moves leave there (> 0) or their gouge (< 0), as :class:`.measure.VerifyReport`'s
    ``vertex_values`` is the cuts'; ``inf`` without such moves. The material the whole
    program leaves is the smaller of the two (``np.fmin``): where a link passes closer to
    the part than the cuts, a simulation of every row (the stock, :mod:`..stock`) cuts
    there too.

    Each move j−1 → j with ``move[j]`` not a cut runs as the machine moves (the stock
    simulation's model): the tip linear, the axis slerped, the move subdivided so that the
    chords of the cutter's reach (ρ for a ball: its centre) stray at most ``tolerance`` mm
    from the arc; the swept volume is verify's (:func:`.sweep.swept_cutter`, ``method`` as
    there: a ball exact)."""
    P = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    out = np.full(len(P), np.inf)
    if program is None or len(program) < 2 or not len(P):
        return out
    cutter = as_cutter(tool)
    move = np.asarray(program.move)
    rows = np.flatnonzero(move[1:] != MOVE_CUT) + 1
    if not len(rows):
        return out
    tip = np.asarray(program.tip, dtype=np.float64)
    ax = np.asarray(program.axis, dtype=np.float64)
    ax = ax / np.maximum(np.linalg.norm(ax, axis=1), 1e-300)[:, None]
    reach = float(cutter.radius) if cutter.type == "ball" else math.hypot(
        float(cutter.h), float(cutter.max_radius))
    step = math.sqrt(8.0 * float(tolerance) / max(reach, 1e-9))  # rad per chord
    runs = []
    for grp in np.split(rows, np.flatnonzero(np.diff(rows) != 1) + 1):
        tips, axes = [tip[grp[0] - 1]], [ax[grp[0] - 1]]
        for j in grp:
            ang = math.acos(min(1.0, max(-1.0, float(ax[j - 1] @ ax[j]))))
            t = np.arange(1, max(1, math.ceil(ang / step)) + 1) / max(1, math.ceil(ang / step))
            tips.append(tip[j - 1] + t[:, None] * (tip[j] - tip[j - 1]))
            axes.append(slerp(ax[j - 1], ax[j], t))
        runs.append(_MoveRun(np.vstack(tips), np.vstack(axes)))
    check_cancel()
    return np.asarray(swept_cutter(cutter, runs, method=method).distance(P), dtype=np.float64)
