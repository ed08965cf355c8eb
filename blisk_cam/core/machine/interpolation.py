"""Constant machining error linear interpolation: which dense poses become NC blocks
(paper 002, Wang et al., *Machines* 2025, 13, 768, §3.2 and Fig. 11).

A 5-axis machine moves its joints linearly between two blocks, so the cutter's real
deviation between blocks depends on the rotary motion as much as on the tip path. Choosing
blocks by the chord height of the tip path in the part frame (:func:`search_chord`, the
baseline) therefore leaves some blocks far below the tolerance and others near it. The
constant-error search (:func:`search_constant_error`) instead walks each densely planned pass
and makes every block as long as the error bound of :mod:`.block_error` (paper 002
Eqs. 1–14) allows: the bound of each block ends up just below the permissible error [d_M],
so the measured error of every block is near [d_M] and far fewer blocks are needed.

Pipeline per pass (:func:`prepare_pass`): the pass's poses (a small chord, e.g. 0.002 mm) are
solved for the machine (:func:`.kinematics.solve_poses`), then resampled to at most
``max_spacing`` mm / ``max_turn`` rad between poses along the planned path (tip linear, axis
on the great circle, each inserted pose solved); Jacobians and error gradients are
precomputed per dense pose. Several passes are searched together (:func:`concat_passes`):
each step advances every pass by one block, so the numpy calls are shared.

A block runs from dense position ``s`` to ``e`` (floats: block ends may fall anywhere on the
dense polyline; the joints there are interpolated between the two dense poses and the tip and
axis follow by forward kinematics). Its bound (:func:`block_bounds`, vectorised over many
candidate ends, :func:`block_bounds_rows`) is evaluated at every dense pose inside the block.
The search grows blocks by galloping on the block length with the cheap Jacobian model
(Eq. 7), checks the bracket with the exact pose deviation, then refines the end by two rounds
of 8-way vectorised bisection (:func:`_search`). Corner transitions (Fig. 11): the thresholds
[ε_m,T], [ε_m,R] start at the mean trajectory deviation of a pass's first two blocks and
shrink wherever the corner error they allow would exceed the adjoining blocks' error; they are
reported (the CNC's corner blending tolerances), the block ends do not depend on them.

The exact evaluation (:func:`measure_blocks`) does not use the bound: it samples each
block's joint motion, runs forward kinematics and takes the signed distance from the cutter
(the centre of its corner circle, minus the corner radius) to the mesh, minus the same quantity
on the planned dense path: the per-block maximum over/undercut.

Against the part (issue 28): the bound above is the machine's deviation from the planned
dense path, but the planned path itself strays from the part (tip linear and axis on the
great circle between its poses, poses on a faceted or noisy mesh). ``part`` budgets that own
deviation in every block (:func:`budget_own_deviation`): from the part's mesh, the cutter's
signed clearance at every dense pose and half-way between them enters each pose's error
(``|d_M + own|``); without the mesh the path's chord tolerance is subtracted from [d_M]
whole. The NC hook (:func:`..post.export.interpolate_for_nc`) always budgets.

Units: mm and radians; joint vectors are (X, Y, Z, θ1, θ2).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

import numpy as np

from ..geometry.distance import MeshDistance
from ..geometry.vectors import slerp, unit
from ..toolpath.types import MOVE_CUT, Program, ToolPath
from .block_error import contact_lever, error_gradients, machine_jacobian
from .block_search import (
    ALLOWANCE,
    ALLOWANCE_TORUS,
    BOUNDS,
    FLOOR,
    FLOOR_TORUS,
    DensePass,
    InterpolationError,
    _check_positive,
    block_bounds_rows,
    cutter_clearance,
    measure_blocks,
    search_chord,
    search_constant_error,
)
from .description import Machine, forward, load_machine
from .kinematics import solve_poses

__all__ = [
    "block_segments",
    "budget_own_deviation",
    "METHODS",
    "BlockSet",
    "InterpolationReport",
    "interpolate_program",
    "prepare_pass",
]

METHODS = ("constant-error", "chord")


def prepare_pass(machine: Machine, cutter, tip, axis, normal, *, max_spacing: float = 0.1,
                 max_turn: float = math.radians(0.1), prev=None, q=None,
                 planned: bool = True) -> DensePass:
    """Solve and resample one pass (module docstring).

    ``planned`` (default): the inserted dense poses lie on the planned path in the part frame
    (tip linear, axis on the great circle) and are solved by IK, so the blocks' error is
    measured from the path as planned (the joint-linear motion between the planned poses
    strays from it too: that is what linearization used to fix). False: the inserted poses
    are ``forward`` of the interpolated joints (the planned poses run joint-linearly).

    tip (k, 3) mm, axis (k, 3) unit, normal (k, 3) unit surface normals at the CC points, in
    the paths' frame, k ≥ 2. ``prev`` (2,) rad seeds the IK branch; ``q`` (k, 5) joints if
    already solved. Raises ReachError for an unreachable pose."""
    tip = np.asarray(tip, dtype=np.float64).reshape(-1, 3)
    axis = unit(np.asarray(axis, dtype=np.float64).reshape(-1, 3), keep_zero=False)
    normal = unit(np.asarray(normal, dtype=np.float64).reshape(-1, 3), keep_zero=False)
    k = len(tip)
    if k < 2:
        raise InterpolationError("a pass needs at least two poses")
    if q is None:
        ik = solve_poses(machine, tip, axis, prev=prev)
        q = np.hstack([ik.xyz, ik.angles])
    q = np.asarray(q, dtype=np.float64)
    seg = np.linalg.norm(np.diff(tip, axis=0), axis=1)
    turn = np.arccos(np.clip(np.einsum("ij,ij->i", axis[1:], axis[:-1]), -1, 1))
    rot = np.abs(np.diff(q[:, 3:], axis=0)).max(axis=1)
    nsub = np.maximum.reduce([np.ceil(seg / max_spacing), np.ceil(turn / max_turn),
                              np.ceil(rot / max_turn), np.ones(k - 1)]).astype(np.int64)
    # dense positions in the input pass: i + j / nsub_i
    starts = np.concatenate([[0], np.cumsum(nsub)])
    m = int(starts[-1]) + 1
    seg_id = np.repeat(np.arange(k - 1), nsub)
    frac = (np.arange(m - 1) - starts[seg_id]) / nsub[seg_id]
    src = np.concatenate([seg_id + frac, [k - 1]])
    i0 = np.minimum(np.floor(src).astype(np.int64), k - 2)
    f = (src - i0)[:, None]
    qd = q[i0] * (1 - f) + q[i0 + 1] * f
    nd = unit(normal[i0] * (1 - f) + normal[i0 + 1] * f, keep_zero=False)
    if planned:
        # the planned path in the part frame (tip linear, axis great circle), solved
        td = tip[i0] * (1 - f) + tip[i0 + 1] * f
        # the unit axes renormalised once more, as the machine's slerp always did (its bits)
        ad = slerp(unit(axis[i0], keep_zero=False), unit(axis[i0 + 1], keep_zero=False), f[:, 0])
        ins = f[:, 0] > 0
        if ins.any():
            res = solve_poses(machine, td[ins], ad[ins], prev=qd[ins, 3:], sequential=False)
            qd[ins] = np.hstack([res.xyz, res.angles])
        ad[~ins] = axis[i0[~ins]]
        td[~ins] = tip[i0[~ins]]
    else:
        td, ad = forward(machine, qd[:, :3], qd[:, 3:])
        exact = f[:, 0] == 0
        td[exact] = tip[i0[exact]]
    last = src == k - 1
    td[last] = tip[-1]
    ad[last] = axis[-1]
    qd[last] = q[-1]
    lever = contact_lever(cutter, nd, ad)
    JP, JO = machine_jacobian(machine, qd)
    gP, gT, Jc = error_gradients(JP, JO, nd, ad, lever)
    rho = float(cutter.r) if cutter.r > 0 else float(cutter.radius)
    return DensePass(q=qd, tip=td, axis=ad, normal=nd, lever=lever, centre=td + lever, gP=gP,
                     gT=gT, Jc=Jc, source=src, rho=rho, machine=machine,
                     allowance=ALLOWANCE_TORUS if float(cutter.e) > 1e-12 else ALLOWANCE,
                     floor=FLOOR_TORUS if float(cutter.e) > 1e-12 else FLOOR)


# ====================================================================== program hook
@dataclass
class BlockSet:
    """Chosen blocks of one pass: ``ends`` (B + 1,) dense positions, ``bound`` (B,) mm,
    ``measured`` (B,) mm max |error| (or None), ``dense`` : DensePass."""

    ends: np.ndarray
    bound: np.ndarray
    measured: np.ndarray | None
    dense: DensePass


def block_segments(report) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The chosen blocks of an :class:`InterpolationReport` for display: start and end tips
    (B, 3) mm (the dense pass interpolated at the block ends) and each block's measured
    maximum error as a fraction of the reference error (the max error; NaN where not
    measured)."""
    ref = report.max_error if report.max_error else report.measured_max
    a, b, r = [], [], []
    for bs in report.sets:
        tips = bs.dense.tip
        pos = np.arange(len(tips), dtype=np.float64)
        at = np.column_stack([np.interp(bs.ends, pos, tips[:, k]) for k in range(3)])
        a.append(at[:-1])
        b.append(at[1:])
        m = (np.full(len(bs.ends) - 1, np.nan) if bs.measured is None
             else np.asarray(bs.measured, dtype=np.float64))
        r.append(m / ref if ref else np.full(len(m), np.nan))
    if not a:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0)
    return np.vstack(a), np.vstack(b), np.concatenate(r)


@dataclass
class InterpolationReport:
    """What :func:`interpolate_program` did.

    method; max_error (mm, constant-error) or chord_height (mm, chord); passes : cut runs
    thinned; original : cut poses before; blocks : cut blocks after; dense : dense poses
    searched; seconds_prepare, seconds_search : wall time; bound_band, measured_band :
    (min, max) of the per-block maxima as fractions of the reference error (max_error; for
    chord, the measured maximum); measured_max : mm; measured_kind : "mesh" or "path";
    corner : (linear mm, rotary rad) smallest corner-transition thresholds of the passes
    (paper 002 Fig. 11; the CNC's corner blending tolerances that keep the corner error below
    the block's); sets : per-pass BlockSet.
    """

    method: str
    max_error: float | None
    chord_height: float | None
    passes: int = 0
    original: int = 0
    blocks: int = 0
    dense: int = 0
    input_poses: int = 0
    seconds_prepare: float = 0.0
    seconds_search: float = 0.0
    bound_band: tuple = (0.0, 0.0)
    measured_band: tuple = (0.0, 0.0)
    measured_max: float = 0.0
    measured_kind: str = "path"
    corner: tuple = (0.0, 0.0)
    #: what of the planned path's own deviation from the part the blocks budget (issue 28):
    #: "" (none: the error from the planned path), "part mesh", "chord tolerance"
    budget: str = ""
    sets: list = field(default_factory=list, repr=False)

    @property
    def poses_per_second(self) -> float:
        """Dense (resampled) poses searched per second."""
        return self.dense / max(self.seconds_search, 1e-9)

    @property
    def input_poses_per_second(self) -> float:
        """Poses of the input program's cut runs searched per second."""
        return self.input_poses / max(self.seconds_search, 1e-9)

    def as_dict(self) -> dict:
        return {
            "method": self.method, "max_error_mm": self.max_error,
            "chord_height_mm": self.chord_height, "passes": self.passes,
            "cut_poses_before": self.original, "cut_blocks": self.blocks,
            "dense_poses": self.dense, "search_s": round(self.seconds_search, 4),
            "dense_poses_per_s": round(self.poses_per_second),
            "input_poses_per_s": round(self.input_poses_per_second),
            "measured_max_mm": self.measured_max, "measured_kind": self.measured_kind,
            "measured_band_pct": [round(100 * x, 1) for x in self.measured_band],
            "bound_band_pct": [round(100 * x, 1) for x in self.bound_band],
            "corner_tolerance": {"linear_mm": self.corner[0],
                                 "rotary_deg": math.degrees(self.corner[1])},
            "own_deviation_budget": self.budget or None,
        }

    def summary(self) -> str:
        ref = "[dM]" if self.method == "constant-error" else "max"
        tol = (f"[dM] {self.max_error:g} mm" if self.method == "constant-error"
               else f"chord height {self.chord_height:g} mm")
        return (f"interpolation {self.method} ({tol}): {self.blocks} cut blocks from "
                f"{self.original} poses in {self.passes} pass(es); measured ({self.measured_kind}) "
                f"max {1000 * self.measured_max:.1f} µm, per-block maxima "
                f"{100 * self.measured_band[0]:.1f}–{100 * self.measured_band[1]:.1f} % of {ref}; "
                f"corner tolerance {1000 * self.corner[0]:.1f} µm / "
                f"{math.degrees(self.corner[1]):.4f}°")

    def budget_line(self) -> str:
        """One line on what of the planned path's own deviation from the part the blocks
        budget ("" when none)."""
        if self.budget == "part mesh":
            return ("constant-error against the part: the planned path's own deviation from "
                    f"the part's mesh is counted in every block's [dM] {self.max_error:g} mm")
        if self.budget == "chord tolerance":
            return ("constant-error against the part: the planned path's chord tolerance is "
                    f"budgeted in every block's [dM] {self.max_error:g} mm (no mesh at hand; "
                    "a scan-like mesh can exceed it: give the part's mesh)")
        return ""


def _corner_thresholds(dp: DensePass, ends, bounds, dev_lin, dev_rot, max_error):
    """Paper 002 Fig. 11: the corner thresholds start at the mean of the first two blocks'
    largest trajectory deviations; at every later junction the corner error estimate
    ``|g_lin| ε_T + |g_rot| ε_R`` (g = g_P + g_θ of the junction pose) must not exceed the
    error of the blocks meeting there (and [d_M]): where it does, both thresholds shrink."""
    if len(bounds) == 0:
        return 0.0, 0.0
    eT = float(np.mean(dev_lin[:2]))
    eR = float(np.mean(dev_rot[:2]))
    g = dp.interp(dp.gP + dp.gT, ends[1:-1])
    gl = np.linalg.norm(g[:, :3], axis=1)
    gr = np.linalg.norm(g[:, 3:], axis=1)
    for k in range(2, len(bounds)):
        lim = min(max(bounds[k - 1], bounds[k]), max_error)
        ce = gl[k - 1] * eT + gr[k - 1] * eR
        if ce > lim > 0:
            f = lim / ce
            eT *= f
            eR *= f
    return eT, eR


def _pass_runs(prog: Program):
    """[(p0, p1)] pose ranges (inclusive) of the cut polylines: each maximal run of cut moves
    of one pass, starting at the pose before the run when it belongs to the same pass."""
    out = []
    m = np.asarray(prog.move)
    cur = np.asarray(prog.curve)
    i, n = 0, len(m)
    while i < n:
        if m[i] != MOVE_CUT:
            i += 1
            continue
        j = i
        while j + 1 < n and m[j + 1] == MOVE_CUT and cur[j + 1] == cur[i]:
            j += 1
        a = i - 1 if (i > 0 and cur[i - 1] == cur[i] and cur[i] >= 0) else i
        if j - a >= 2:
            out.append((a, j))
        i = j + 1
    return out


def _check_request(method, max_error, chord_height, bound, max_spacing):
    """Raise InterpolationError for an unknown method or bound, or a tolerance that is not
    positive."""
    if method not in METHODS:
        raise InterpolationError(f"unknown interpolation method {method!r}; use one of "
                                 f"{', '.join(METHODS)}")
    if method == "constant-error":
        _check_positive("max_error", max_error)
    else:
        _check_positive("chord_height", chord_height)
    if bound not in BOUNDS:
        raise InterpolationError(f"unknown bound {bound!r}; use one of {', '.join(BOUNDS)}")
    _check_positive("max_spacing", max_spacing)


def budget_own_deviation(dp: DensePass, machine, cutter, *, mesh=None, allowance=0.0,
                         chord=0.0) -> DensePass:
    """``dp`` with the planned path's own deviation from the part budgeted (issue 28: the
    error promise holds against the part). With ``mesh`` (TriMesh or MeshDistance): the
    cutter's signed clearance at every dense pose minus ``allowance`` (the planned path
    between its poses, tip linear and axis on the great circle, strays from the surface by
    up to its chord tolerance, and the planned poses sit on a faceted mesh); without it the
    deviation is not known and the path's ``chord`` tolerance is budgeted whole
    (``margin``). Every block's bound then counts it (:func:`.block_search.block_bounds_rows`)
    and :func:`.block_search.measure_blocks` measures against the part."""
    if mesh is not None:
        own = cutter_clearance(machine, cutter, mesh, dp.q, dp.normal) - float(allowance)
        # and half-way between the dense poses (a coarse mesh's facets show there): each
        # pose's value is the one of largest size among it and its two half-way points
        u = np.arange(len(dp) - 1) + 0.5
        half = cutter_clearance(machine, cutter, mesh, dp.joints_at(u),
                                dp.interp(dp.normal, u)) - float(allowance)
        cand = np.stack([own, np.append(half, own[-1]), np.insert(half, 0, own[0])])
        own = cand[np.argmax(np.abs(cand), axis=0), np.arange(len(dp))]
        jump = np.abs(np.diff(own))
        step = np.maximum(np.append(jump, 0.0), np.insert(jump, 0, 0.0))
        return replace(dp, own=own, own_step=step, margin=0.0, target=float(allowance))
    return replace(dp, own=np.zeros(len(dp)), margin=float(chord), target=float(allowance))


def _dense_passes(path: ToolPath, machine, runs, qall, max_spacing, max_turn, *,
                  budget=False, mesh=None):
    """The DensePass of every cut run (``qall`` (m, 6): the joints of every program row);
    with ``budget`` the planned path's own deviation budgeted (:func:`budget_own_deviation`,
    against ``mesh`` when given)."""
    prog = path.program
    dense = []
    for a, b in runs:
        c = path.curves[int(prog.curve[a])]
        normal = c.normal[np.asarray(prog.index[a:b + 1])]
        dp = prepare_pass(machine, path.tool, prog.tip[a:b + 1], prog.axis[a:b + 1],
                          normal, max_spacing=max_spacing, max_turn=max_turn,
                          q=qall[a:b + 1])
        if budget:
            dp = budget_own_deviation(dp, machine, path.tool, mesh=mesh,
                                      allowance=float(getattr(path, "allowance", 0.0) or 0.0),
                                      chord=float(path.chord))
        dense.append(dp)
    return dense


def _record_run(rep, machine, cutter, dp, ends, a, b, bound, max_error, measure, md):
    """Add run a..b's blocks (bounds, measured errors) to ``rep``; return its corner
    thresholds (linear mm, rotary rad)."""
    det = block_bounds_rows(dp, ends[:-1], ends[1:], bound=bound, detail=True)
    corner = _corner_thresholds(dp, ends, det[0], det[3], det[4],
                                max_error if max_error else float(det[0].max()))
    meas = None
    if measure:
        meas = measure_blocks(machine, cutter, dp, ends, mesh=md)[0]
    rep.sets.append(BlockSet(ends=ends, bound=det[0], measured=meas, dense=dp))
    rep.passes += 1
    rep.original += b - a
    rep.blocks += len(ends) - 1
    return corner


def _kept_rows(prog: Program, sl):
    """Program rows ``sl`` as they are: (tip, axis, move, curve, index, flags)."""
    return (prog.tip[sl], prog.axis[sl], prog.move[sl], prog.curve[sl], prog.index[sl],
            prog.flags[sl])


def _run_rows(machine, prog: Program, a, b, dp, ends):
    """Run a..b's rows thinned to its blocks: its first pose as is, the machine poses at the
    block ends, its last pose: (tip, axis, move, curve, index, flags)."""
    idx = np.asarray(prog.index[a:b + 1])
    qe = dp.joints_at(ends[1:-1])
    tp, ax = forward(machine, qe[:, :3], qe[:, 3:])
    srcf = dp.interp(dp.source, ends[1:-1])
    si = np.clip(np.floor(srcf).astype(np.int64), 0, b - a)
    return (np.vstack([prog.tip[a:a + 1], tp, prog.tip[b:b + 1]]),
            np.vstack([prog.axis[a:a + 1], ax, prog.axis[b:b + 1]]),
            np.concatenate([prog.move[a:a + 1], np.full(len(tp) + 1, MOVE_CUT, np.int8)]),
            np.full(len(tp) + 2, prog.curve[a]),
            np.concatenate([prog.index[a:a + 1], idx[si], prog.index[b:b + 1]]),
            np.concatenate([prog.flags[a:a + 1], prog.flags[a + si], prog.flags[b:b + 1]]))


def _set_bands(rep, corners, method, max_error, measure):
    """The report's bound and measured bands (fractions of the reference error) and the
    smallest corner thresholds."""
    b_all = np.concatenate([s.bound for s in rep.sets])
    refv = max_error if method == "constant-error" else None
    if measure:
        m_all = np.concatenate([s.measured for s in rep.sets])
        rep.measured_max = float(m_all.max())
        refm = refv if refv else rep.measured_max
        rep.measured_band = (float(m_all.min() / refm), float(m_all.max() / refm))
    refb = refv if refv else float(b_all.max())
    rep.bound_band = (float(b_all.min() / refb), float(b_all.max() / refb))
    rep.corner = (min(c[0] for c in corners), min(c[1] for c in corners))


def interpolate_program(path: ToolPath, machine, method: str = "constant-error", *,
                        max_error: float | None = None, chord_height: float | None = None,
                        mesh=None, bound: str = "pointwise", max_spacing: float = 0.1,
                        max_turn: float = math.radians(0.1), max_rotary_step=None,
                        measure: bool = True, part=None):
    """Thin the cut poses of ``path.program`` into NC blocks for ``machine``.

    Each maximal run of cut moves of one pass (with the pose before it, when on the same
    pass) is a dense polyline; its blocks are chosen by ``method``: ``"constant-error"``
    (longest blocks with error bound ≤ ``max_error`` mm, paper 002) or ``"chord"`` (tip chord
    height ≤ ``chord_height`` mm in the part frame). Link, approach, retract and rapid poses are
    kept as they are; the first and last pose of every run too. The new cut poses are machine
    poses (``forward`` of the interpolated joints), so :func:`.post.blocks.build_blocks` solves
    them back to the same joints; it must not linearise them again (the NC hook passes a large
    chord for that).

    ``mesh`` (TriMesh or MeshDistance): the measured error is taken against it; otherwise
    against the planned path (:func:`measure_blocks`).

    ``part``: constant-error keeps its bound against the part, not only against the planned
    path (issue 28): ``part`` is the part's mesh (TriMesh or MeshDistance; True: ``mesh``)
    — every dense pose's own clearance from it is counted in the blocks' bounds
    (:func:`budget_own_deviation`) — or ``"chord"`` when the mesh is not at hand: the path's
    chord tolerance is budgeted whole. None (default): as before, the error from the planned
    path. With ``part`` the measured error is against the part too. Returns (ToolPath with
    the thinned program, :class:`InterpolationReport`). Raises InterpolationError for bad input,
    ReachError for an unreachable pose."""
    _check_request(method, max_error, chord_height, bound, max_spacing)
    if not isinstance(machine, Machine):
        machine = load_machine(machine)
    prog = path.program
    if prog is None or len(prog) == 0:
        raise InterpolationError("the paths have no linked program (link the passes first)")
    cutter = path.tool
    rep = InterpolationReport(method=method, max_error=max_error if method != "chord" else None,
                              chord_height=chord_height if method == "chord" else None)
    md = None
    if mesh is not None and measure:
        md = mesh if isinstance(mesh, MeshDistance) else MeshDistance(mesh)
        rep.measured_kind = "mesh"
    runs = _pass_runs(prog)
    # IK of the whole program once (branch continuity as the posts will solve it)
    ik = solve_poses(machine, prog.tip, prog.axis, moves=prog.move)
    qall = np.hstack([ik.xyz, ik.angles])
    t0 = time.perf_counter()
    budget = part is not None and method == "constant-error"
    part_mesh = None
    if budget and part is True:
        part_mesh = md if md is not None else mesh
    elif budget and not isinstance(part, str):
        part_mesh = part if isinstance(part, MeshDistance) else MeshDistance(part)
    if budget and part_mesh is None and not (part is True or part == "chord"):
        raise InterpolationError(f"part must be a mesh, True or 'chord', got {part!r}")
    if budget and part_mesh is None and float(path.chord) >= float(max_error):
        raise InterpolationError(
            f"constant-error --max-error {max_error:g} mm: the path's chord tolerance "
            f"{path.chord:g} mm (its own deviation from the part, budgeted whole without the "
            "part's mesh) leaves nothing for the blocks; plan with a chord well below the max "
            "error (e.g. 0.002 mm) or give the blade mesh (nc --part-mesh)")
    dense = _dense_passes(path, machine, runs, qall, max_spacing, max_turn, budget=budget,
                          mesh=part_mesh)
    if budget:
        rep.budget = "part mesh" if part_mesh is not None else "chord tolerance"
    t1 = time.perf_counter()
    if not dense:
        all_ends = []
    elif method == "constant-error":
        # budgeted against the part, a block never shorter than one dense step: where the
        # planned path's own deviation alone exceeds [dM] no block length keeps the bound
        all_ends = search_constant_error(dense, max_error, bound=bound,
                                         max_rotary_step=max_rotary_step,
                                         min_step=1.0 if budget else 1e-3)
    else:
        all_ends = search_chord(dense, chord_height, max_rotary_step=max_rotary_step)
    t2 = time.perf_counter()
    rep.seconds_prepare = t1 - t0
    rep.seconds_search = t2 - t1
    rep.dense = int(sum(len(d) for d in dense))
    rep.input_poses = int(sum(b - a + 1 for a, b in runs))
    rows = []
    pos = 0
    corners = []
    for (a, b), dp, ends in zip(runs, dense, all_ends, strict=True):
        rows.append(_kept_rows(prog, slice(pos, a)))  # poses before the run unchanged
        corners.append(_record_run(rep, machine, cutter, dp, ends, a, b, bound, max_error,
                                   measure, md))
        rows.append(_run_rows(machine, prog, a, b, dp, ends))
        pos = b + 1
    rows.append(_kept_rows(prog, slice(pos, len(prog))))
    tip, axis, move, curve, index, flags = zip(*rows, strict=True)
    new = Program(tip=np.vstack(tip), axis=np.vstack(axis),
                  move=np.concatenate(move).astype(np.int8),
                  curve=np.concatenate(curve).astype(np.int64),
                  index=np.concatenate(index).astype(np.int64),
                  flags=np.concatenate(flags).astype(np.uint8))
    if rep.sets:
        _set_bands(rep, corners, method, max_error, measure)
    return replace(path, program=new), rep
