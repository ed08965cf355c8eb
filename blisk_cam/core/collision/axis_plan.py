"""Tool axes through the channel: an axis planner over the whole pass (collision avoidance by
shortest path, the ``"plan"`` method of ``--collisions avoid``).

Paper 004 §3 turns each colliding pose by its own smallest rotation and smooths afterwards
(:mod:`.avoid`, method ``"rotate"``); neighbouring poses may then turn by tens of degrees and
the ball leaves the surface between them. Here the axis of every pose of a pass is chosen
*together* (the axis-field idea of commercial 5-axis CAM: interpolate the axis through the
channel under a maximum angle step).

**Path length.** The turn limit is per mm of the *tool's* path, not the contact's: the
machine feeds along the tool's own path (with TCPM the programmed tip), and the rotary speed
it sees is the turn ÷ (tool path length ÷ feed). The length between two poses is the distance
between their corner centres at the contact, cc + r·n (a ball's centre, which every axis of a
ball keeps), never less than the contact's own distance (:func:`.axis_field.path_steps`
says why that point). Round a blade edge of radius ~0.5 mm a Ø12 ball's centre travels
~π·6.5 ≈ 20 mm while the contact travels ~1.6 mm: measured along the contact, the limit let
the lean change by a fraction of a degree per pose there. The turn the limit adds per pose
is capped too (``max_turn``;
``CollisionOptions.plan_max_turn``, 5° by default): between two poses the machine turns the
axis uniformly while the tip goes straight, so a ball's centre leaves the straight line by
R·(1 − cos(θ/2)). Every "arc" and "path" below is this length, accumulated as the limit
allows turn along it (:meth:`.axis_states._Planner.arc`: where the cap binds, the cap ÷
turn_per_mm). The steps:

1. **Window.** Poses whose planned axis collides (clearance < ds), widened along the pass by
   the path length the widest lean swing needs at the turn limit (``30° / turn_per_mm``):
   the ramps in and out. Outside the window the planned axis is kept.
2. **States.** Per window pose the states: deviations (u, v) of the pose's reference axis
   (the planned axis, or the channel reference below), a square grid of ±60° in 5° steps,
   the axis the reference turned by hypot(u, v) toward u·e1 + v·e2 (:func:`.axis_field.
   deviation_axes`), where (e1, e2) is carried along the run by parallel transport
   (:func:`.axis_field.transported_frames`). A state held along the pass then turns between
   two poses by at most the reference's own turn, and a state step δ adds at most δ: the turn
   limit bounds the state steps whatever the surface frame does. (Leads and tilts offsets in
   the surface frame, the first design, cannot hold a deviation through a blade edge, where
   the normal swings 180° within a millimetre: on Rotor 37 × 36 half the unresolved poses were
   edge poses "out of reach of the turn limit".) A state is valid when its axis lies within
   the lean limits (``|lead| ≤ max_lead``, ``|tilt| ≤ max_tilt`` from the surface normal as in
   :mod:`..paths.gouge`; a plan that leans further keeps its own lean as the limit), the
   cutter can touch the surface with it and (a machine given) the rotaries can produce it
   (:func:`..machine.kinematics.reachable_axes`). A state's tip keeps the contact (ball: the
   centre fixed; bull nose / flat / taper: :meth:`~..tool.cutter.Cutter.cl_points` from the
   CC point and normal, plus the plan's few-µm lift λ along the normal).
3. **Stations and clearance.** The shortest path runs over stations: the poses one lean step
   of path apart (5° / turn_per_mm) or where the planned axis itself has turned by a step (the
   edges). At each station a coarse 10° grid is measured by
   :meth:`.scene.CollisionScene.detect` — every station of every pass in one batched call —
   and interpolated onto the states. Poses the plan leaves colliding become stations whose
   states are all known exactly: measured, or, for a ball, proved colliding by the Lipschitz
   bound of the clearance in the axis angle (no tool point moves further than its distance
   from the ball's centre, about which the axis turns).
4. **Shortest path (Viterbi).** Along each run of window poses the state sequence minimising

       Σ_stations [ C·[clr < ds] (C ≫ any lean cost; then the least deep) + u² + v² ]

   with the exact turn between the states of consecutive stations within the sum of the
   poses' limits between them (:func:`turn_limits`: the planned turn plus ``turn_per_mm`` ×
   the path step, the added part capped by ``max_turn`` per pose when given; and from/to
   the fixed planned poses around the run). Between stations the state is linear in path
   length; a pose pair that still turns faster than its limit is
   clamped (sweeps forward and backward; the last sweeps hold the turn limit even where
   that leaves an axis a little past a lean limit).
   Since a colliding state costs more than any lean, the path leaves as few stations
   colliding as the limits allow. The turn limit is a hard constraint everywhere, between
   unresolved poses too: an unresolved pose takes the least deep axis the limit lets the
   path reach (issue 25: no two consecutive poses turn more than the limit). **Jumps**
   (``jumps=True``, ``CollisionOptions.turn_jumps``, not the default): between two
   consecutive poses that are both stations whose states are known exactly to collide, the
   path may turn past the limit (cost :data:`_JUMP`: more than any lean, far less than a
   colliding pose), so it re-enters the clear axes right after an unresolved stretch
   instead of ramping out of it at the turn limit; every such turn has two unresolved poses
   at its ends (the report counts them apart, ``turns_between_unresolved``). Measured along
   the contact, the bound cost poses where a lean must change within a blade edge (the
   planned axis swings by tens of degrees within a millimetre of contact); along the tool's
   path (``bench/bench_axis_planner.py``, unresolved pass poses bounded / with jumps, the
   5° per-pose cap — without it): Rotor 37 × 36 about 908 / 821 — 850 / 819 (along the
   contact 1154 / 991), the demo about 887 / 584 — 804 / 586 (806 / 581); paper 004's
   per-pose rotation leaves 1010 and 971, and turns past the limit besides.
5. **Verification.** Every planned pose and the motion between consecutive poses (the tip
   linear, the axis turned uniformly, :data:`_MOTION_SAMPLES` points inside) are measured
   exactly; poses left colliding become exact stations and the runs are planned again
   (:data:`_ROUNDS` rounds).

**Channel reference.** With ``reference="channel"`` the lean cost is measured from the axis
interpolated between the two blade sides of the gap: the radial direction of the channel's
mid-plane at the pose (the meridional plane turned from the CC point's by half the pitch
360°/N toward the side the surface normal faces), brought inside the lean limits, plus
``edge_lead`` of extra lead where the pose lies within one tool diameter of the pass ends
(leading and trailing edges of a blade pass).

**Fixed or per-pass reference.** ``reference="fixed"`` measures the lean cost from one
direction for every pose (``direction``, the part's frame), ``reference="pass"`` from one
direction per pass, the mean of its planned axes: where the limits allow, a pass is then held
at one axis and the rotaries stay still (:func:`reference_axes`). Both are brought inside the
lean limits like the channel's; ``edge_lead`` adds to any reference.

**Unresolved poses** (clearance < ds at the chosen axis) come as ranges per pass (pass,
first, last pose, why): "no axis within the limits clears" (the pose is a fact about the tool
and holder), "the turn limit" (a clear axis exists, or was not ruled out, but no sequence
within the turn limit reaches it; "or the machine's reach" when a machine is given), or "the
motion from the pose before collides" (only from a clear pose: the motion out of an unresolved
pose starts colliding and belongs to that pose's range). "No axis" is claimed only for poses
whose every state is known exactly to collide and where a 2.5° grid of leads and tilts over
the whole lean box holds no clear axis either (:func:`_no_axis`, measured level by level,
the deep collisions proving their neighbours by the Lipschitz bound).

The states, their clearance and the shortest path live in :mod:`.axis_states`.

Lengths mm, angles radians; numpy only (the distance machinery of :mod:`.scene`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import CollisionError
from ..geometry.vectors import unit
from ..machine.kinematics import reachable_axes
from ..paths.orientation import clamp_turn, lead_tilt_axes, lead_tilt_of
from .axis_field import (
    channel_reference,
    sample_motion,
    turn_limits,
)
from .axis_states import (
    _MOTION_SAMPLES,
    _ROUNDS,
    _SWING,
    _Planner,
    _Run,
    _touch_ok,
)
from .options import AXIS_REFERENCES

__all__ = ["AxisPlan", "UnresolvedRange", "channel_reference", "plan_axes", "reference_axes",
           "sample_motion", "turn_limits"]

#: default turn limit per mm of path, rad/mm
DEFAULT_TURN_PER_MM = math.radians(2.0)
#: the window's ramp: the arc a turn of this angle needs at the turn limit, rad
_RAMP = math.radians(30.0)
#: sweeps of the per-pose turn clamp (forward, backward, …)
_SWEEPS = 6

REASON_NO_AXIS = "no axis within the lean limits clears"
REASON_TURN = "the turn limit keeps the clear axes out of reach"
REASON_MOTION = "the motion from the pose before collides"


@dataclass
class UnresolvedRange:
    """A run of unresolved poses of one pass: ``curve`` (pass index), ``first``/``last``
    (pose indices, inclusive), ``why`` (one of the REASON_* texts), ``min_clearance`` mm."""

    curve: int
    first: int
    last: int
    why: str
    min_clearance: float

    def as_dict(self) -> dict:
        return {"pass": int(self.curve), "from": int(self.first), "to": int(self.last),
                "why": self.why, "min_clearance": float(self.min_clearance)}


@dataclass
class AxisPlan:
    """What :func:`plan_axes` chose: ``tip``, ``axis`` (n, 3) per pose (the input order),
    ``clearance`` (n,) mm at the chosen pose, ``unresolved`` (n,) bool, ``ranges`` (list of
    :class:`UnresolvedRange`), ``motion_clearance`` (n,) mm — the smallest clearance sampled
    on the motion from the pose before (inf for a pass's first pose), ``n_candidates`` (the
    candidate poses evaluated), ``n_window`` (poses planned)."""

    tip: np.ndarray
    axis: np.ndarray
    clearance: np.ndarray
    unresolved: np.ndarray
    ranges: list = field(default_factory=list)
    motion_clearance: np.ndarray | None = None
    n_candidates: int = 0
    n_window: int = 0


# ====================================================================== the planner
def _windows(offs, arc_of, colliding, reach_mm, closed):
    """(n,) bool: poses within ``reach_mm`` of arc (``arc_of``: :meth:`_Planner.arc`) of a
    colliding pose of their pass (around the closing cut of a closed pass, ``closed`` (p,)
    bool)."""
    out = np.zeros(len(colliding), bool)
    for ci in range(len(offs) - 1):
        s, e = offs[ci], offs[ci + 1]
        hit = np.nonzero(colliding[s:e])[0]
        if len(hit) == 0:
            continue
        arc = arc_of(np.arange(s, e))
        h = arc[hit]
        if closed[ci]:
            L = arc[-1] + float(arc_of(np.asarray([e - 1, s]))[1])
            h = np.concatenate([h - L, h, h + L])
        lo = np.searchsorted(arc, h - reach_mm, side="left")
        hi = np.searchsorted(arc, h + reach_mm, side="right")
        mark = np.zeros(e - s + 1, np.int64)
        np.add.at(mark, lo, 1)
        np.add.at(mark, hi, -1)
        out[s:e] = np.cumsum(mark)[:-1] > 0
    return out


def _arc(cc):
    """(k,) the contact's arc length along the poses ``cc`` (k, 3) from the first, mm."""
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(cc, axis=0), axis=1))])


def reference_axes(reference, P, offs, w, *, blisk_axis=None, blade_count=None,
                   direction=None):
    """(len(w), 3) unit axes the lean cost of the window poses ``w`` is measured from, or None
    for ``"planned"`` (the planned axes themselves). ``"channel"``: the axis interpolated
    between the two blade sides of the gap (:func:`.axis_field.channel_reference`);
    ``"pass"``: one direction per pass, the mean of its planned axes (a pass held at one axis
    where the limits allow: the rotaries move least); ``"fixed"``: ``direction`` (3,) for every
    pose (in the part's frame, e.g. a machine's preferred head direction). Each is brought
    inside the lean limits by the caller."""
    if reference == "planned":
        return None
    if reference == "channel":
        if blisk_axis is None or not blade_count:
            return None
        return channel_reference(P.cc[w], P.nrm[w], blisk_axis, blade_count)
    if reference == "pass":
        o = np.asarray(offs, dtype=np.int64)
        which = np.searchsorted(o, w, side="right") - 1
        mean = np.add.reduceat(P.ax0, o[:-1], axis=0)
        return unit(mean[which], keep_zero=False)
    if reference == "fixed":
        d = np.asarray(direction, dtype=np.float64).reshape(3)
        return np.repeat(unit(d[None], keep_zero=False), len(w), axis=0)
    raise CollisionError(f"axis reference must be one of {', '.join(AXIS_REFERENCES)}, got "
                         f"{reference!r}")


def plan_axes(scene, curves, offs, P, lim, colliding, *, turn_per_mm=DEFAULT_TURN_PER_MM,
              max_turn=None, machine=None, reference="planned", blisk_axis=None,
              blade_count=None, edge_lead=0.0, jumps=False, progress=None,
              direction=None) -> AxisPlan:
    """Plan the tool axes of the passes (module docstring).

    Parameters
    ----------
    scene : CollisionScene
    curves : list of PassCurve; offs : (p + 1,) pose offsets of the passes in the stacked rows
    P : the stacked poses (``cc``, ``nrm``, ``tip0``, ``ax0``, ``off0`` (n, 3))
    lim : (f, k_side (n, 3), lim_lead, lim_tilt (n,) rad) — frames and lean limits
    colliding : (n,) bool — the planned poses that collide
    turn_per_mm : float, rad/mm; max_turn : float or None, rad per pose
    machine : Machine or None — axes outside its rotaries' reach are excluded
    reference : "planned" | "channel" | "pass" | "fixed" (:func:`reference_axes`);
        blisk_axis, blade_count: for "channel"; direction (3,): for "fixed"
    edge_lead : float, rad — extra lead at the pass ends (a tool diameter in from each end)
    progress : callable(fraction) or None

    Returns
    -------
    AxisPlan
    """
    cc, nrm, tip0, ax0 = P.cc, P.nrm, P.tip0, P.ax0
    n = len(cc)
    f, k_side, lim_lead, lim_tilt = lim
    closed = [bool(c.closed) and offs[i + 1] - offs[i] > 2 for i, c in enumerate(curves)]
    pl = _Planner(scene, P, lim, turn_per_mm, max_turn, machine, _SWING, jumps)
    win = _windows(offs, pl.arc, colliding, _RAMP / max(turn_per_mm, 1e-9) + 1e-9, closed)
    tip, axis = tip0.copy(), ax0.copy()
    clear = np.full(n, np.inf)
    if not win.any():
        return AxisPlan(tip, axis, clear, np.zeros(n, bool), [], np.full(n, np.inf), 0, 0)
    l0, t0 = lead_tilt_of(ax0, f, nrm, k_side)
    l0, t0 = np.nan_to_num(l0), np.nan_to_num(t0)
    ref_l, ref_t = l0.copy(), t0.copy()
    w = np.nonzero(win)[0]
    R = reference_axes(reference, P, offs, w, blisk_axis=blisk_axis, blade_count=blade_count,
                       direction=direction)
    if R is not None:  # the reference's lead and tilt, brought inside the lean limits
        cl, ct = lead_tilt_of(R, f[w], nrm[w], k_side[w])
        good = np.isfinite(cl) & np.isfinite(ct)
        ref_l[w] = np.where(good, np.clip(cl, -lim_lead[w], lim_lead[w]), ref_l[w])
        ref_t[w] = np.where(good, np.clip(ct, -lim_tilt[w], lim_tilt[w]), ref_t[w])
    if edge_lead:
        ref_l[w] = np.clip(ref_l[w] + _edge_weight(offs, cc, w, scene.cutter) * edge_lead,
                           -lim_lead[w], lim_lead[w])
    runs = []
    for ci in range(len(offs) - 1):
        s, e = offs[ci], offs[ci + 1]
        here = np.nonzero(win[s:e])[0]
        if len(here) == 0:
            continue
        k = e - s
        parts = np.split(here, np.nonzero(np.diff(here) > 1)[0] + 1)
        if closed[ci] and len(parts) > 1 and parts[0][0] == 0 and parts[-1][-1] == k - 1:
            parts = [np.r_[parts[-1], parts[0]]] + parts[1:-1]  # across the closing cut
        for run in parts:
            if closed[ci] and len(run) == k:  # a whole closed pass: opened where it is clear
                run = np.roll(run, -_open_at(colliding[s:e]))
            g = s + run
            arc = pl.arc(g)
            if closed[ci]:
                cyc = len(run) == k
                pre, post = (None, None) if cyc else (s + (run[0] - 1) % k, s + (run[-1] + 1) % k)
            else:
                cyc, pre = False, s + run[0] - 1 if run[0] > 0 else None
                post = s + run[-1] + 1 if run[-1] + 1 < k else None
            runs.append(_Run(g, arc, pl.stations(g, arc), pre, post, cyc))
    ref_axes = ax0.copy()
    if R is not None or edge_lead:
        ref_axes[w] = lead_tilt_axes(f[w], nrm[w], k_side[w], ref_l[w], ref_t[w])
    pl.set_frames(runs, ref_axes)
    # the coarse grid at every station of every run: one batched measurement
    pl.measure_coarse(np.concatenate([r.g[r.st] for r in runs]))
    if progress is not None:
        progress(0.5)
    chosen = [None] * len(runs)
    dirty = [True] * len(runs)  # a run is planned again only when its stations or priced
    base = [r.st.copy() for r in runs]  # motions changed (everything else it reads stays)
    hot = [np.zeros(0, np.int64) for _ in runs]  # poses of each run left colliding before
    best = [None] * len(runs)
    result = None
    for rnd in range(_ROUNDS):
        redo = list(dirty)
        for ri, r in enumerate(runs):
            if dirty[ri]:
                chosen[ri] = pl.plan_run(r)
        dirty = [False] * len(runs)
        result = _evaluate_again(pl, runs, chosen, result, redo)
        for ri, r in enumerate(runs):  # each run keeps its best round
            if not redo[ri]:
                continue  # planned as before: the same poses, the same score
            snap = _snapshot(pl, r, result)
            if best[ri] is None or snap["score"] <= best[ri]["score"]:
                best[ri] = snap
        if rnd == _ROUNDS - 1:
            break
        # poses the plan leaves colliding: made stations (with those of the round before;
        # the other stations the lean steps and the edges ask for), all their states known
        # exactly, and the runs planned again — a pose that clears again stops being a
        # station, or the lean could not change across a stretch of stations closer than
        # one state step at the turn limit;
        # poses whose motion from the pose before collides: both ends made stations, known
        # exactly, and the motion between them priced per state pair in the next plan
        todo, new_pairs = [], 0
        for ri, r in enumerate(runs):
            bad = np.nonzero(result["clr"][r.g] < pl.safety)[0]
            chain = _chain(r)
            mb = np.nonzero((result["motion"][chain[1:]] < pl.safety)
                            & (result["clr"][chain[:-1]] >= pl.safety))[0]
            pairs = [(int(chain[i]), int(chain[i + 1])) for i in mb
                     if (int(chain[i]), int(chain[i + 1])) not in pl.mpairs]
            pl.mpairs.update(pairs)
            new_pairs += len(pairs)
            ends = np.asarray([x for p in pl.mpairs for x in p], np.int64)
            ends = np.nonzero(np.isin(r.g, ends))[0]
            st = np.union1d(np.union1d(base[ri], bad), np.union1d(hot[ri], ends))
            st = st.astype(np.int64)
            hot[ri] = bad
            dirty[ri] = bool(pairs) or len(st) != len(r.st) or bool(np.any(st != r.st))
            r.st = st
            new = np.union1d(bad, ends).astype(np.int64)
            new = new[[int(r.g[i]) not in pl.exact for i in new]]
            if len(new):
                todo.append(r.g[new])
        if not any(dirty):
            break
        if todo:
            pl.measure_exact(np.concatenate(todo))
        if progress is not None:
            progress(0.5 + 0.1 * (rnd + 1))
    result = _assemble(pl, runs, best)
    idx = np.nonzero(win)[0]
    tip[idx], axis[idx] = result["tip"][idx], result["axis"][idx]
    clear[idx] = result["clr"][idx]
    motion = result["motion"]
    # a motion counts against its later pose only when it starts from a clear pose: the
    # motion out of an unresolved pose belongs to that pose's range (it starts colliding)
    start = result["motion_from"]
    start_clear = np.ones(n, bool)
    has = start >= 0
    start_clear[has] = clear[start[has]] >= pl.safety
    motion = np.where(start_clear, motion, np.inf)
    unresolved = (clear < pl.safety) | (motion < pl.safety)
    for a, b in result["jumps"]:  # both ends of a jump are unresolved (their states collide)
        unresolved[[a, b]] = True
    why = np.full(n, REASON_TURN, dtype=object)
    cand = [int(gi) for gi in np.nonzero(unresolved)[0] if int(gi) in pl.exact
            and not np.any(pl.known[int(gi)] >= pl.safety)]
    for gi, w in _no_axis(pl, cand).items():
        if w is not None:
            why[gi] = w
    why[(clear >= pl.safety) & (motion < pl.safety)] = REASON_MOTION
    if machine is not None:
        why[(why == REASON_TURN) & unresolved] = REASON_TURN + " or the machine's reach"
    ranges = _ranges(offs, unresolved, why, np.minimum(clear, motion))
    return AxisPlan(tip, axis, clear, unresolved, ranges, motion, pl.n_eval, int(win.sum()))


def _evaluate_again(pl: _Planner, runs, chosen, prev, redo) -> dict:
    """:func:`_evaluate` of the runs planned anew (``redo``), the others' poses, clearances,
    motions and jumps copied from ``prev`` (their plans did not change; None: all anew)."""
    if prev is None or all(redo):
        return _evaluate(pl, runs, chosen)
    sub = [i for i, x in enumerate(redo) if x]
    out = {k: (v.copy() if isinstance(v, np.ndarray) else set(v)) for k, v in prev.items()}
    if not sub:
        return out
    new = _evaluate(pl, [runs[i] for i in sub], [chosen[i] for i in sub])
    for i in sub:
        r = runs[i]
        nxt = _chain(r)[1:]
        gs = set(int(x) for x in r.g)
        for k in ("tip", "axis", "clr"):
            out[k][r.g] = new[k][r.g]
        for k in ("motion", "motion_from"):
            out[k][nxt] = new[k][nxt]
        out["jumps"] = {p for p in out["jumps"] if p[0] not in gs} | \
            {p for p in new["jumps"] if p[0] in gs}
    return out


def _evaluate(pl: _Planner, runs, chosen) -> dict:
    """Poses of every run from its stations' states (the lean linear in arc length between
    stations; a run without a feasible plan keeps its planned poses), their exact clearance
    and the motion's (into each run pose and into the fixed pose after it), in one batch.
    Returns dict of (n,)-indexed arrays."""
    P = pl.P
    n = len(P.cc)
    tip, axis = P.tip0.copy(), P.ax0.copy()
    gs, dls, dts = [], [], []
    for r, seq in zip(runs, chosen, strict=True):
        if seq is None:
            dl, dt = pl.u0[r.g], pl.v0[r.g]
        else:
            dl = np.interp(r.arc, r.arc[r.st], pl.off[0][seq[:, 0]])
            dt = np.interp(r.arc, r.arc[r.st], pl.off[1][seq[:, 1]])
        gs.append(r.g)
        dls.append(dl)
        dts.append(dt)
    g = np.concatenate(gs)
    dl, dt = np.concatenate(dls), np.concatenate(dts)
    ax = pl.axes(g, dl, dt)
    axis[g] = ax
    tip[g] = pl.tips(g, ax)
    same = (np.abs(dl - pl.u0[g]) < 1e-12) & (np.abs(dt - pl.v0[g]) < 1e-12)
    axis[g[same]], tip[g[same]] = P.ax0[g[same]], P.tip0[g[same]]  # the planned pose, exactly
    jumps = _jumps(pl, runs, chosen, axis)
    _limit_turns(pl, runs, tip, axis, jumps)
    prev_, next_ = [], []
    for r in runs:
        chain = _chain(r)
        prev_.append(chain[:-1])
        next_.append(chain[1:])
    a_p, a_i = np.concatenate(prev_), np.concatenate(next_)
    tq = np.arange(1, _MOTION_SAMPLES + 1) / (_MOTION_SAMPLES + 1)
    clr = np.full(n, np.nan)
    clr[g] = pl.clearance(tip[g], axis[g])
    # the motions' samples; a ball's proved clear by the Lipschitz bound from the measured
    # ends (no tool point moves further than t·D from the start, D = |Δcentre| + L·θ) are
    # not measured, their bound standing for their clearance (≥ ds)
    lo = np.full((len(a_p), _MOTION_SAMPLES), -np.inf)
    if pl.lip is not None:
        rho = float(pl.cutter.radius)
        D = np.linalg.norm(tip[a_i] + rho * axis[a_i] - tip[a_p] - rho * axis[a_p], axis=1) \
            + pl.lip * np.arccos(np.clip(np.einsum("ij,ij->i", axis[a_p], axis[a_i]), -1, 1))
        cs = np.nan_to_num(clr[a_p], nan=-np.inf)
        ce = np.nan_to_num(clr[a_i], nan=-np.inf)
        lo = np.maximum(cs[:, None] - tq[None] * D[:, None],
                        ce[:, None] - (1 - tq[None]) * D[:, None])
    rows, cols = np.nonzero(lo < pl.safety)
    mt, ma = sample_motion(tip[a_p[rows]], axis[a_p[rows]], tip[a_i[rows]], axis[a_i[rows]],
                           tq[cols], paired=True)
    samples = lo.copy()
    samples[rows, cols] = pl.clearance(mt, ma)
    clr = np.where(np.isnan(clr), np.inf, clr)
    motion = np.full(n, np.inf)
    np.minimum.at(motion, a_i, samples.min(axis=1))
    motion_from = np.full(n, -1, np.int64)
    motion_from[a_i] = a_p
    return {"tip": tip, "axis": axis, "clr": clr, "motion": motion, "jumps": jumps,
            "motion_from": motion_from}


def _open_at(colliding):
    """Where a closed pass planned as one cycle starts: the middle of its longest stretch of
    clear planned poses (read cyclically), 0 when all collide. The cycle's first state is
    chosen among a few (:meth:`.axis_states._Planner.plan_run`) and its last must turn into
    it; where the pass's own first pose lies in a colliding stretch (Rotor 37's passes close
    at the leading edge) that left the stretch unresolved."""
    c = np.asarray(colliding, bool)
    k = len(c)
    if c.all() or not c.any():
        return 0
    start = int(np.argmax(c))  # a colliding pose: the clear stretches do not wrap from it
    free = ~np.roll(c, -start)
    edges = np.diff(np.r_[0, free.astype(np.int8), 0])
    lo, hi = np.nonzero(edges == 1)[0], np.nonzero(edges == -1)[0]
    j = int(np.argmax(hi - lo))
    return (start + (lo[j] + hi[j]) // 2) % k


def _snapshot(pl: _Planner, r: _Run, result) -> dict:
    """Run r's poses in one round's ``result`` and its score: the poses left colliding plus
    those whose motion from a clear pose collides."""
    chain = _chain(r)
    nxt = chain[1:]
    clr = result["clr"]
    score = int(np.sum(clr[r.g] < pl.safety)) + int(np.sum(
        (result["motion"][nxt] < pl.safety) & (clr[chain[:-1]] >= pl.safety)))
    gs = set(int(x) for x in r.g)
    return {"score": score, "g": r.g, "tip": result["tip"][r.g].copy(),
            "axis": result["axis"][r.g].copy(), "clr": clr[r.g].copy(), "nxt": nxt,
            "motion": result["motion"][nxt].copy(), "from": result["motion_from"][nxt].copy(),
            "jumps": {p for p in result["jumps"] if p[0] in gs}}


def _assemble(pl: _Planner, runs, best) -> dict:
    """The result dict of :func:`_evaluate` from each run's best round."""
    P = pl.P
    n = len(P.cc)
    out = {"tip": P.tip0.copy(), "axis": P.ax0.copy(), "clr": np.full(n, np.inf),
           "motion": np.full(n, np.inf), "motion_from": np.full(n, -1, np.int64),
           "jumps": set()}
    for b in best:
        g, nxt = b["g"], b["nxt"]
        out["tip"][g], out["axis"][g], out["clr"][g] = b["tip"], b["axis"], b["clr"]
        out["motion"][nxt], out["motion_from"][nxt] = b["motion"], b["from"]
        out["jumps"] |= b["jumps"]
    return out


def _jumps(pl: _Planner, runs, chosen, axis):
    """{(a, b)} consecutive global poses (both stations) between which the shortest path
    jumped: both states known exactly to collide and the axes turning past the limit."""
    out = set()
    if not pl.jumps:
        return out
    for r, seq in zip(runs, chosen, strict=True):
        if seq is None:
            continue
        for j in np.nonzero(np.diff(r.st) == 1)[0] + 1:
            ga, gb = int(r.g[r.st[j - 1]]), int(r.g[r.st[j]])
            if not (pl.colliding_states(ga)[tuple(seq[j - 1])]
                    and pl.colliding_states(gb)[tuple(seq[j])]):
                continue
            lim = pl.turn_limit(ga, gb)
            if float(axis[ga] @ axis[gb]) < math.cos(lim):
                out.add((ga, gb))
    return out


def _chain(r: _Run):
    """(m,) global poses of run r with the fixed planned poses before/after it (a whole
    closed pass: its first pose again at the end, the closing cut)."""
    post = [r.g[0]] if r.cycle else [r.post] if r.post is not None else []
    return np.r_[[r.pre] if r.pre is not None else [], r.g, post].astype(np.int64)


def _limit_turns(pl: _Planner, runs, tip, axis, jumps=frozenset()):
    """Where the lean interpolated between stations turns faster than the limit between two
    poses, the later axis is turned toward the earlier one (a sweep forward from the fixed
    pose before the run), then the earlier toward the later (backward from the fixed pose
    after it, or from the closing cut), the sweeps alternating until every pair holds (at
    most :data:`_SWEEPS`); tips recomputed for the contact; in place."""
    P = pl.P
    for r in runs:
        chain = _chain(r)
        m = len(chain)
        limit = pl.turn_limits(chain) * (1 - 1e-9)
        fixed = np.zeros(m, bool)
        fixed[0] = r.pre is not None or r.cycle
        fixed[-1] = r.post is not None or r.cycle
        moved = set()
        # the lean limits kept first; sweeps that still leave a pair over the turn limit
        # (the clip into a lean limit turned an axis back) are followed by sweeps that hold
        # the turn limit alone, so no two consecutive poses turn past it (the lean then
        # leaves its limit by less than that pair's excess)
        for sweep in range(2 * _SWEEPS):
            changed = False
            pairs = [(i, i + 1) for i in range(m - 1)] if sweep % 2 == 0 else \
                [(i, i - 1) for i in range(m - 1, 0, -1)]
            for a, b in pairs:  # b turned toward a
                if fixed[b]:
                    continue
                ia, ib = chain[a], chain[b]
                if (int(chain[min(a, b)]), int(chain[max(a, b)])) in jumps:
                    continue  # both poses left colliding: the path re-enters past the jump
                lim = limit[min(a, b)]
                if float(axis[ia] @ axis[ib]) < math.cos(lim):
                    axis[ib] = clamp_turn(tuple(axis[ia]), tuple(axis[ib]), lim,
                                          tuple(P.nrm[ib]))
                    if sweep < _SWEEPS:
                        axis[ib] = pl.inside(np.asarray([ib]), axis[ib][None])[0]
                    moved.add(int(ib))
                    changed = True
            if not changed:
                break
        if moved:
            mv = np.asarray(sorted(moved), np.int64)
            tip[mv] = pl.tips(mv, axis[mv])


def _no_axis(pl: _Planner, gis):
    """{pose: why or None} for poses gis whose every state is known colliding: the claim
    checked on a 2.5° grid of leads and tilts over the pose's whole lean box (the limits
    included; axes the cutter cannot touch with, or the machine cannot reach, left out), the
    contact kept. Level by level — every 8th grid point, then every 4th, every 2nd, the rest —
    a grid axis is measured unless (a ball) the Lipschitz bound from the states known and
    the grid axes measured before proves it colliding; a clear one → None (a clear axis
    exists: the turn limit keeps it out of reach), none → REASON_NO_AXIS. Batched per
    level."""
    step = math.radians(2.5)
    boxes = {}
    for gi in gis:
        ll, lt = float(pl.lim_l[gi]), float(pl.lim_t[gi])
        il = np.r_[np.arange(-ll, ll, step), ll]
        it = np.r_[np.arange(-lt, lt, step), lt]
        L, T = np.meshgrid(il, it, indexing="ij")
        I, J = np.meshgrid(np.arange(len(il)), np.arange(len(it)), indexing="ij")
        m = L.size
        g = np.full(m, gi)
        ax = lead_tilt_axes(pl.f[g], pl.P.nrm[g], pl.k[g], L.ravel(), T.ravel())
        ok = _touch_ok(pl.cutter, pl.P.nrm[g], ax)
        if pl.machine is not None and ok.any():
            ok[ok] = reachable_axes(pl.machine, ax[ok])
        I, J = I.ravel()[ok], J.ravel()[ok]
        lev = np.full(len(I), 3)
        for k, every in ((2, 2), (1, 4), (0, 8)):
            lev[(I % every == 0) & (J % every == 0)] = k
        k = pl.known[gi].ravel()
        fin = np.isfinite(k)
        boxes[gi] = {"ax": ax[ok], "lev": lev, "val": np.full(int(ok.sum()), np.nan),
                     "src_ax": pl.state_axes(gi).reshape(-1, 3)[fin], "src_val": k[fin]}
    out = {gi: REASON_NO_AXIS for gi in gis}
    for level in range(4):
        rows, owners, blocks = [], [], []
        for gi, b in boxes.items():
            if out[gi] is None:
                continue
            sel = np.nonzero(b["lev"] == level)[0]
            if pl.lip is not None and len(sel):
                done = ~np.isnan(b["val"])
                A = np.vstack([b["src_ax"], b["ax"][done]])
                V = np.r_[b["src_val"], b["val"][done]]
                if len(A):
                    ang = np.arccos(np.clip(b["ax"][sel] @ A.T, -1.0, 1.0))
                    sel = sel[np.min(V[None, :] + pl.lip * ang, axis=1) >= pl.safety]
            rows.append(sel)
            owners.append(np.full(len(sel), gi))
            blocks.append(b["ax"][sel])
        if not rows:
            break
        own = np.concatenate(owners).astype(np.int64)
        idx = np.concatenate(rows).astype(np.int64)
        ax = np.vstack(blocks)
        clr = pl.clearance(pl.tips(own, ax), ax) if len(ax) else np.zeros(0)
        for gi, i, c in zip(own, idx, clr, strict=True):
            boxes[int(gi)]["val"][i] = c
            if c >= pl.safety:
                out[int(gi)] = None
    return out


def _edge_weight(offs, cc, idx, cutter):
    """(w,) 1 at a pass's ends falling to 0 one tool diameter along the pass."""
    out = np.zeros(len(idx))
    D = 2.0 * float(cutter.max_radius)
    for ci in range(len(offs) - 1):
        s, e = offs[ci], offs[ci + 1]
        sel = (idx >= s) & (idx < e)
        if not sel.any():
            continue
        arc = _arc(cc[s:e])
        a = arc[idx[sel] - s]
        out[sel] = np.clip(1.0 - np.minimum(a, arc[-1] - a) / max(D, 1e-9), 0.0, 1.0)
    return out


def _ranges(offs, unresolved, why, clearance):
    out = []
    for ci in range(len(offs) - 1):
        s, e = offs[ci], offs[ci + 1]
        u = np.nonzero(unresolved[s:e])[0]
        if len(u) == 0:
            continue
        w = np.asarray([str(why[s + i]) for i in u], dtype=object)
        cut = np.nonzero((np.diff(u) > 1) | (w[1:] != w[:-1]))[0] + 1
        for run, ws in zip(np.split(u, cut), np.split(w, cut), strict=True):
            out.append(UnresolvedRange(ci, int(run[0]), int(run[-1]), str(ws[0]),
                                       float(np.min(clearance[s + run]))))
    return out
