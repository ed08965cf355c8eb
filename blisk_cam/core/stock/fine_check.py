"""Crashes thinner than the stock's cells: the rows a coarse stock finds *near* material
re-judged on a fine stock of the region round them.

A stock of resolution h knows its surface between rays only to about h/2, so
:func:`.removal.simulate_moves` calls a rapid or the body a crash only when the solid shrunk
by h/2 still meets material: a thinner crash (a rapid through a roughing cusp, a shank
grazing a rib 0.5 mm deep) passes unseen. Such rows are still told apart: their whole solid
met material (``near``, collected by ``simulate_moves``). This module judges them again at a
finer resolution, locally, from the history:

1. the **region**: the coarse rays the near rows' solids, grown by one cell, meet in the
   stock as it was when they ran, and their neighbours (one cell round), each with its span
   of radii;
2. the **fine stock**: the blank at the fine resolution, kept only inside the region (the
   material elsewhere is not judged — what the coarse check saw there was air);
3. the **history**: every move of every program run so far (the earlier operations', then
   this one's up to its last near row) whose flute can reach the region (its bounding
   cylinder over the move against the region's rays, a summed-area table) runs on the fine
   stock in order, each program with its own cutter; this program's selected rows with its
   body, so a rapid or the body meeting the region's material at the fine resolution is a
   crash (the same test as the coarse one, at half the fine cell).

The region is exact in its material (every move that reaches it is run), so a crash found
there is one; the cost is the few moves round the near rows, not a fine stock of the whole
sector. Not seen: material thinner than a coarse cell that the unshrunk solid meets on no
coarse ray at all.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import maximum_filter, minimum_filter

from ..runtime import check_cancel
from ..tool.assembly import ToolAssembly
from ..tool.cutter import as_cutter
from ..toolpath.types import Program
from .dexels import RadialDexels
from .removal import (
    _candidate_boxes,
    _cut,
    _shrink,
    _slerp_rows,
    _sub_poses,
    body_assembly,
    cutter_halfplanes,
    frustum_halfplanes,
    remove_program,
)

__all__ = ["FineCheck", "RunProgram", "fine_crashes", "near_region"]


@dataclass
class RunProgram:
    """A program run on the stock, with the tool that ran it: its ``cutter`` and ``body``
    (None: the cutter's own, :func:`.removal.body_assembly`)."""

    program: Program
    cutter: object
    body: ToolAssembly | None = None


def _solids(run: RunProgram, kind: str):
    """[(half-planes, z_lo, z_hi, radius)] of the flute (``kind`` "rapid") or the body."""
    c = as_cutter(run.cutter)
    if kind == "rapid":
        return [(cutter_halfplanes(c), 0.0, c.h, c.max_radius)]
    body = run.body or body_assembly(c)
    return [(frustum_halfplanes(*f), f[0], f[2], max(f[1], f[3])) for f in body.frustums()]


def near_region(dex: RadialDexels, run: RunProgram, near, grow: float | None = None) -> tuple:
    """The region of the ``near`` rows (``(row, kind, (lo, hi))`` of
    :func:`.removal.simulate_moves`) of ``run`` on the grid of ``dex``: (n_rays,) radii
    ``r_lo``, ``r_hi`` (mm; r_lo > r_hi outside it) — the rays whose material (the stock before
    the row's batch) the solid grown by ``grow`` mm (default one cell) meets over the row's
    move, and their neighbours one cell round."""
    g = dex.resolution if grow is None else max(float(grow), dex.resolution)
    r_lo = np.full(dex.n_rays, np.inf)
    r_hi = np.full(dex.n_rays, -np.inf)
    tip = np.asarray(run.program.tip, float)
    axis = np.asarray(run.program.axis, float)
    axis = axis / np.linalg.norm(axis, axis=1)[:, None]
    for row, kind, (lo, hi) in near:
        snap = RadialDexels(dex.axis, dex.blade_count, dex.theta0, dex.z0, dex.n_theta,
                            dex.n_z, dex.resolution, dex.r_max, lo, hi)
        for planes, z0, z1, rad in _solids(run, kind):
            reach = math.hypot(max(abs(z0), abs(z1)), rad)
            tips, axes, _ = _sub_poses(tip, axis, np.array([row]), True, 0.5 * g, reach)
            rays, a, b, _, _ = _cut(snap, tips, axes, _shrink(planes, -g), z0 - g, z1 + g,
                                    rad + g)
            np.minimum.at(r_lo, rays, a - g)
            np.maximum.at(r_hi, rays, b + g)
    # one cell round (θ wraps, z does not)
    L = r_lo.reshape(dex.n_z, dex.n_theta)
    H = r_hi.reshape(dex.n_z, dex.n_theta)
    L2 = minimum_filter(L, size=3, mode=("constant", "wrap"), cval=np.inf)
    H2 = maximum_filter(H, size=3, mode=("constant", "wrap"), cval=-np.inf)
    return L2.ravel(), H2.ravel()


def _reaching_rows(dex: RadialDexels, run: RunProgram, inside: np.ndarray, r_span) -> np.ndarray:
    """(m,) bool: the rows of ``run`` whose flute, over the move that ends there, can reach a
    ray of the region ``inside`` ((n_rays,) bool on ``dex``'s grid) within radii ``r_span``."""
    c = as_cutter(run.cutter)
    tip = np.asarray(run.program.tip, float)
    axis = np.asarray(run.program.axis, float)
    axis = axis / np.linalg.norm(axis, axis=1)[:, None]
    prev = np.r_[0, np.arange(len(tip) - 1)]
    t0, a0 = tip[prev], axis[prev]
    ang = np.arccos(np.clip(np.einsum("ij,ij->i", a0, axis), -1.0, 1.0))
    dist = np.linalg.norm(tip - t0, axis=1)
    reach = math.hypot(c.h, c.max_radius)
    # every pose of the move lies within this of its mid pose (as the compiled sweep's box)
    grow = 0.5 * (dist + reach * ang) + dex.resolution
    c0, c1, w0, w1, lo, hi, nc, _ = _candidate_boxes(
        dex, 0.5 * (t0 + tip), _slerp_rows(a0, axis, np.full(len(tip), 0.5)),
        (0.0 - grow)[:, None], (c.h + grow)[:, None], c.max_radius + grow)
    n = dex.n_theta
    m = inside.reshape(dex.n_z, n).astype(np.int64)
    sat = np.zeros((dex.n_z + 1, 2 * n + 1), np.int64)  # the region twice round: wrapped boxes
    sat[1:, 1:] = np.hstack([m, m]).cumsum(0).cumsum(1)
    whole = nc >= n
    a = np.where(whole, 0, np.mod(c0, n))
    b = np.where(whole, n - 1, a + (c1 - c0))
    ok = (nc > 0) & (w1 >= w0) & (lo <= r_span[1]) & (hi >= r_span[0])
    w0c, w1c = np.clip(w0, 0, dex.n_z - 1), np.clip(w1, 0, dex.n_z - 1)
    cnt = (sat[w1c + 1, b + 1] - sat[w0c, b + 1] - sat[w1c + 1, a] + sat[w0c, a])
    return ok & (cnt > 0)


def _run_rows(fine: RadialDexels, run: RunProgram, rows: np.ndarray, *, check: bool) -> list:
    """Run the moves of ``run`` ending at ``rows`` (sorted) on ``fine``, each from its own
    start pose; with ``check`` the crashes (rows numbered as in ``run``)."""
    if not len(rows):
        return []
    p = run.program
    prev = np.maximum(rows - 1, 0)
    both = np.stack([prev, rows], 1).ravel()
    moving = np.zeros(len(both), bool)
    moving[1::2] = rows > 0
    moving[0] = rows[0] == 0  # the program's first pose: its own pose
    move = np.repeat(np.asarray(p.move)[rows], 2)
    sub = Program(np.asarray(p.tip)[both], np.asarray(p.axis)[both], move,
                  np.full(len(both), -1), np.full(len(both), -1),
                  np.zeros(len(both), np.uint8))
    res = remove_program(fine, sub, run.cutter, run.body, check_body=check, moving=moving)
    if not check:
        return []
    out = []
    for c in res.crashes:
        c.row = int(both[c.row])
        out.append(c)
    return out


@dataclass
class FineCheck:
    """The fine re-check of a job: ``blank`` the job's blank at the fine resolution and the
    programs run so far (``history``, in order)."""

    blank: RadialDexels
    history: list

    def crashes(self, coarse: RadialDexels, program: Program, cutter, body, near, *,
                grow: float | None = None) -> list:
        """The crashes of ``program`` (run with ``cutter`` and ``body`` on ``coarse``, after
        ``history``) at the fine resolution in its ``near`` rows' region (module docstring):
        a list of :class:`.removal.Crash`, rows of ``program``, found at the fine resolution
        (``Crash.resolution``); ``grow``: :func:`near_region`'s."""
        found = fine_crashes(self.blank, self.history, coarse,
                             RunProgram(program, cutter, body), near, grow=grow)
        for c in found:
            c.resolution = self.blank.resolution
        return found


def fine_crashes(blank: RadialDexels, history, coarse: RadialDexels, run: RunProgram,
                 near, *, grow: float | None = None) -> list:
    """:meth:`FineCheck.crashes` (module docstring): ``blank`` the blank at the fine
    resolution, ``history`` the RunPrograms before ``run``, ``coarse`` the stock whose grid
    ``near`` was found on."""
    if not near:
        return []
    first: dict = {}
    for rec in near:  # a row once per kind (a batch may note it more than once)
        first.setdefault(rec[:2], rec)
    near = list(first.values())
    r_lo, r_hi = near_region(coarse, run, near, grow)
    inside = r_hi > r_lo
    span = (float(r_lo[inside].min()), float(r_hi[inside].max()))
    # the blank kept inside the region (each fine ray clipped to its coarse cell's radii)
    fine = blank.copy()
    i = np.arange(fine.n_theta)
    th = np.mod(fine.ray_theta(i) - coarse.theta0, coarse.pitch)
    ci = np.minimum((th / coarse.d_theta).astype(np.int64), coarse.n_theta - 1)
    cj = np.floor((fine.ray_z(np.arange(fine.n_z)) - coarse.z0) / coarse.dz).astype(np.int64)
    in_z = (cj >= 0) & (cj < coarse.n_z)
    cell = (np.clip(cj, 0, coarse.n_z - 1)[:, None] * coarse.n_theta + ci[None]).ravel()
    lo_c = np.where(np.repeat(in_z, fine.n_theta), r_lo[cell], np.inf)[:, None]
    hi_c = np.where(np.repeat(in_z, fine.n_theta), r_hi[cell], -np.inf)[:, None]
    L, H = np.maximum(fine.lo, lo_c), np.minimum(fine.hi, hi_c)
    keep = H > L
    fine.lo, fine.hi = np.where(keep, L, 0.0), np.where(keep, H, 0.0)
    last = max(row for row, _, _ in near)
    for past in history:
        check_cancel()
        _run_rows(fine, past, np.flatnonzero(_reaching_rows(coarse, past, inside, span)),
                  check=False)
    sel = _reaching_rows(coarse, run, inside, span)
    sel[[row for row, _, _ in near]] = True
    sel[last + 1:] = False
    return _run_rows(fine, run, np.flatnonzero(sel), check=True)
