"""The axis planner's states and its shortest path (:mod:`.axis_plan` describes the method):
per pose the lean states — deviations (u, v) of the reference axis in the frame carried along
the pass (:func:`.axis_field.transported_frames`) —, the clearance known of each (the coarse
grid interpolated, or every state measured or proved colliding), the motion between states of
consecutive poses priced, and the Viterbi recursion over the stations of a run (the turn limit
between stations exact; jumps only between two consecutive poses both known to collide).

Lengths mm, angles radians; numpy only (the distance machinery of :mod:`.scene`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..geometry.vectors import angle_between
from ..machine.kinematics import reachable_axes
from ..paths.orientation import lead_tilt_axes, lead_tilt_of
from ..tool.cutter import Cutter
from .axis_field import (
    deviation_axes,
    deviation_of,
    sample_motion,
    transported_frames,
    turn_allowance,
    turn_limits,
)

#: the lean states' step and the coarse grid's (measured at every station), rad. Finer
#: steps helped near the blade edges while the turn limit was measured along the contact,
#: which lets a lean change there by a fraction of a degree per pose (Rotor 37 × 36, turn
#: bounded everywhere: 2.5° steps to ±40° left 1101 poses unresolved against 1154), but cost
#: about twice the candidates on the demo for no gain there (822 against 806); measured
#: along the tool's path (:func:`.axis_field.path_steps`) the limit lets the lean change
#: round an edge as the ball's centre goes round it
_STEP = math.radians(5.0)
_COARSE = 2
#: widest lean swing searched about the reference (where the limits allow), rad
_SWING = math.radians(60.0)
#: cost of a colliding state (the lean costs are ≤ a few rad²)
_COLLIDE = 1e3
#: largest lean step between stations, in state steps
_MAX_R = 3
#: cost of a jump — a turn past the limit between two consecutive poses, both left
#: colliding (unresolved either way): more than any lean, far less than a colliding pose
_JUMP = 10.0
#: samples inside each transition checked for the motion, and verification rounds
_MOTION_SAMPLES = 3
_ROUNDS = 4


def _touch_ok(cutter: Cutter, normal, axis):
    """(k,) bool: the cutting part can touch the surface with this axis."""
    return angle_between(normal, axis) <= cutter._g["th_hi"]


def _cl(cutter: Cutter, cc, nrm, ax, off, ball_centre):
    """(k, 3) tips keeping the contact: ball — the centre fixed; others — from the contact."""
    if ball_centre is not None:
        return ball_centre - cutter.radius * ax
    tip = cc + off
    ok = _touch_ok(cutter, nrm, ax)
    if np.any(ok):
        tip[ok] = cutter.cl_points(cc[ok], nrm[ok], ax[ok]) + off[ok]
    return tip


def _interp_matrix_idx(n, idx):
    """(n, len(idx)) linear interpolation weights from the values at the sorted indices
    ``idx`` of 0..n−1 to every index."""
    x = np.arange(n, dtype=np.float64)
    j = np.clip(np.searchsorted(idx, x, side="right") - 1, 0, len(idx) - 2)
    t = (x - idx[j]) / (idx[j + 1] - idx[j])
    M = np.zeros((n, len(idx)))
    M[np.arange(n), j] = 1 - t
    M[np.arange(n), j + 1] += t
    return M


@dataclass
class _Run:
    """A run of consecutive window poses of one pass: global indices ``g`` (r,), arc
    positions, the stations (sorted indices into ``g``), the fixed planned poses
    before/after (global indices or None); ``cycle``: the run is a whole closed pass, its
    first pose following its last (the closing cut)."""

    g: np.ndarray
    arc: np.ndarray
    st: np.ndarray
    pre: int | None
    post: int | None
    cycle: bool = False


class _Planner:
    """The state of one :func:`plan_axes` call (module docstring): the lean states, the
    clearance known per station (interpolated from the coarse grid, or exact), the batched
    evaluations."""

    def __init__(self, scene, P, lim, turn_per_mm, max_turn, machine, span, jumps=False):
        self.scene, self.P = scene, P
        self.jumps = bool(jumps)
        self.f, self.k, self.lim_l, self.lim_t = lim
        self.rate, self.max_turn, self.machine = turn_per_mm, max_turn, machine
        self.cutter = scene.cutter
        self.ball = self.cutter.type == "ball"
        self.safety = scene.safety
        # the states: deviations (u, v) from the reference, k·step up to ±span (the frame:
        # :meth:`set_frames`), the reference itself a state
        self.step = _STEP
        m = int(round(span / _STEP))
        self.off = [np.arange(-m, m + 1) * _STEP for _ in range(2)]
        # the coarse grid: every _COARSE-th state, both ends included
        self.cidx = [np.unique(np.r_[np.arange(0, len(o), _COARSE), len(o) - 1])
                     for o in self.off]
        self.M = [_interp_matrix_idx(len(o), ci) for o, ci in zip(self.off, self.cidx,
                                                                   strict=True)]
        self.shape = (len(self.off[0]), len(self.off[1]))
        self.n_eval = 0
        self.known = {}  # global pose → (Fl, Ft) clearance (−inf: not a valid state)
        self.raw = {}  # global pose → (Gl, Gt) measured clearance of the coarse grid
        # Lipschitz constant of the clearance in the axis angle (mm/rad): a ball turns about
        # its centre, so no point of the tool moves further than its distance from the centre
        a = scene.assembly
        self.lip = (math.hypot(a.top - self.cutter.radius,
                               max(a.max_radius, float(self.cutter.max_radius)))
                    if self.ball else None)
        self.exact = set()  # poses whose fine states were all measured
        self.r = self.e1 = self.e2 = self.u0 = self.v0 = None
        # consecutive pose pairs (global) whose motion was found colliding: the shortest
        # path prices their motion per state pair (:meth:`motion_cost`), cached
        self.mpairs = set()
        self.mcost = {}
        self._axes_cache, self._tips_cache, self._moves_cache = {}, {}, {}
        self._gather_cache, self._node_cache = {}, {}
        self._dev = self.off[0][:, None] ** 2 + self.off[1][None, :] ** 2  # the lean cost

    # --- poses -----------------------------------------------------------------------------
    def set_frames(self, runs, ref_axes):
        """The states' frame at every run pose: the reference axis ``ref_axes[g]`` and two unit
        vectors across it, carried along the run by parallel transport (each pose's pair is the
        one before turned by the smallest rotation taking the reference axis before to this
        one). A state (u, v) is the reference turned by hypot(u, v) toward u·e1 + v·e2, so a
        state held along the run turns between two poses by at most the reference's own turn
        there, and a state step of δ adds at most δ: the turn limit is a bound on the state
        steps, whatever the surface frame does (at the edges the normal swings by 180° within
        a millimetre, where leads and tilts held constant turn the axis far faster than the
        plan)."""
        n = len(self.P.cc)
        self.r = np.asarray(ref_axes, dtype=np.float64).copy()
        self.e1 = np.zeros((n, 3))
        self.e2 = np.zeros((n, 3))
        for run in runs:
            g = run.g
            start = self.f[g[0]]
            if np.linalg.norm(np.cross(start, self.r[g[0]])) < 1e-6:
                start = self.k[g[0]]
            arc = None
            if run.cycle:
                arc = np.r_[run.arc, run.arc[-1] + float(self.arc(g[[-1, 0]])[1])]
            self.e1[g], self.e2[g] = transported_frames(self.r[g], start, arc)
        # the planned axis in these coordinates
        self.u0, self.v0 = deviation_of(self.P.ax0, self.r, self.e1, self.e2)

    # --- the turn limit --------------------------------------------------------------------
    def arc(self, chain):
        """(m,) mm: the arc along the global pose sequence ``chain`` the planner measures in —
        the turn limit's allowance (:func:`.axis_field.turn_allowance`) accumulated, ÷
        ``turn_per_mm``: the tool path's length (:func:`.axis_field.path_steps`) where the
        per-pose cap does not bind. The window's ramps, the stations' spacing and the lean's
        interpolation between stations all read it, so a lean spread over a stretch turns
        each pose in proportion to the turn its limit allows there."""
        P, ch = self.P, np.asarray(chain, np.int64)
        add = turn_allowance(P.cc[ch], P.nrm[ch], self.cutter.corner_radius, self.rate,
                             self.max_turn)
        return np.r_[0.0, np.cumsum(add)] / self.rate

    def turn_limits(self, chain):
        """(m − 1,) rad: the turn limit between consecutive poses of the global pose sequence
        ``chain`` (:func:`.axis_field.turn_limits`: the planned turn + ``turn_per_mm`` × the
        tool path's length, the added part capped by ``max_turn``) — the one place the
        planner reads it, between run poses, to and from the fixed planned poses around a
        run, across a closed pass's closing cut and for the jumps alike."""
        P, ch = self.P, np.asarray(chain, np.int64)
        return turn_limits(P.cc[ch], P.nrm[ch], P.ax0[ch], self.cutter.corner_radius,
                           self.rate, self.max_turn)

    def turn_limit(self, ga, gb) -> float:
        """The turn limit (rad) from pose ga to the next pose gb (:meth:`turn_limits`)."""
        return float(self.turn_limits([int(ga), int(gb)])[0])

    # --- poses -----------------------------------------------------------------------------
    def axes(self, g, du, dv):
        """(k, 3) axes at poses g (k,): the reference turned by the state (du, dv) (k,) in the
        transported frame (:meth:`set_frames`); the exponential map."""
        return self.inside(g, deviation_axes(self.r[g], self.e1[g], self.e2[g], du, dv))

    def inside(self, g, ax):
        """(k, 3) the axes brought into the lean limits of poses g (lead and tilt clipped;
        unchanged where inside): the state between two valid stations may lean past a limit
        that varies along the pass."""
        lead, tilt = lead_tilt_of(ax, self.f[g], self.P.nrm[g], self.k[g])
        with np.errstate(invalid="ignore"):
            out = ~((np.abs(lead) <= self.lim_l[g] + 1e-12)
                    & (np.abs(tilt) <= self.lim_t[g] + 1e-12))
        out &= np.isfinite(lead) & np.isfinite(tilt)
        if not out.any():
            return ax
        ax = ax.copy()
        o = np.asarray(g)[out]
        ax[out] = lead_tilt_axes(self.f[o], self.P.nrm[o], self.k[o],
                                 np.clip(lead[out], -self.lim_l[o], self.lim_l[o]),
                                 np.clip(tilt[out], -self.lim_t[o], self.lim_t[o]))
        return ax

    def tips(self, g, ax):
        P = self.P
        centre = P.tip0[g] + self.cutter.radius * P.ax0[g] if self.ball else None
        return _cl(self.cutter, P.cc[g], P.nrm[g], ax, P.off0[g].copy(), centre)

    def valid(self, g, dl, dt, ax):
        """(k,) bool: the state's axis ``ax`` (brought into the lean limits by :meth:`axes`)
        lies less than one state step from the state's own (so the states within a step
        beyond a limit search the limit itself), the cutter touches and (a machine given)
        the rotaries reach."""
        own = deviation_axes(self.r[g], self.e1[g], self.e2[g], dl, dt)
        ok = np.einsum("ij,ij->i", own, ax) > math.cos(self.step) + 1e-12
        ok &= _touch_ok(self.cutter, self.P.nrm[g], ax)
        if self.machine is not None and ok.any():
            ok[ok] = reachable_axes(self.machine, ax[ok])
        return ok

    def clearance(self, tips, axes):
        self.n_eval += len(tips)
        if len(tips) == 0:
            return np.zeros(0)
        return self.scene.detect(tips, axes).clearance

    def _states(self, g, il, it):
        """(k,) poses, lead and tilt offsets of the states (il × it index grids) at poses g."""
        a, b = len(il), len(it)
        gg = np.repeat(g, a * b)
        dl = np.tile(np.repeat(self.off[0][il], b), len(g))
        dt = np.tile(np.tile(self.off[1][it], a), len(g))
        return gg, dl, dt

    def grid(self, g, il, it, need=None):
        """Measure the states il × it at poses g (one batch; only where ``need`` (s, a·b)
        when given): (s, a, b) clearance, −inf where the state is not valid."""
        gg, dl, dt = self._states(g, il, it)
        sel = np.ones(len(gg), bool) if need is None else need.ravel()
        ax = self.axes(gg[sel], dl[sel], dt[sel])
        ok = self.valid(gg[sel], dl[sel], dt[sel], ax)
        c = np.full(len(gg), -np.inf)
        cs = np.full(int(sel.sum()), -np.inf)
        cs[ok] = self.clearance(self.tips(gg[sel][ok], ax[ok]), ax[ok])
        c[sel] = cs
        return c.reshape(len(g), len(il), len(it))

    def state_axes(self, gi):
        """(Fl, Ft, 3) axes of every lean state at pose gi (cached: the frames are set once;
        read-only)."""
        gi = int(gi)
        A = self._axes_cache.get(gi)
        if A is None:
            gg, dl, dt = self._states(np.asarray([gi]), np.arange(self.shape[0]),
                                      np.arange(self.shape[1]))
            A = self.axes(gg, dl, dt).reshape(*self.shape, 3)
            A.flags.writeable = False
            self._axes_cache[gi] = A
        return A

    def state_tips(self, gi):
        """(Fl, Ft, 3) tips of every lean state at pose gi (cached; read-only)."""
        gi = int(gi)
        T = self._tips_cache.get(gi)
        if T is None:
            T = self.tips(np.full(self.shape[0] * self.shape[1], gi),
                          self.state_axes(gi).reshape(-1, 3)).reshape(*self.shape, 3)
            T.flags.writeable = False
            self._tips_cache[gi] = T
        return T

    def state_valid(self, gi):
        gg, dl, dt = self._states(np.asarray([gi]), np.arange(self.shape[0]),
                                  np.arange(self.shape[1]))
        return self.valid(gg, dl, dt, self.state_axes(gi).reshape(-1, 3)).reshape(self.shape)

    # --- stations --------------------------------------------------------------------------
    def stations(self, g, arc):
        """Indices of the stations of a run (global poses g): the first and last pose, and
        the next pose once one lean step's worth of arc (step / rate) has passed or the
        planned axis has turned by one lean step (at the edges, where the normal swings)."""
        h = self.step / self.rate
        ax = self.P.ax0[g]
        out = [0]
        for i in range(1, len(arc)):
            if arc[i] - arc[out[-1]] >= h or float(ax[i] @ ax[out[-1]]) < math.cos(self.step):
                out.append(i)
        if out[-1] != len(arc) - 1:
            out.append(len(arc) - 1)
        return np.asarray(out, np.int64)

    def measure_coarse(self, g):
        """Known clearance of poses g from the coarse grid, interpolated to the states."""
        C = self.grid(g, *self.cidx)
        for gi, c in zip(g, C, strict=True):
            self.raw[int(gi)] = c
        ok = np.isfinite(C)
        num = np.einsum("fa,sab,gb->sfg", self.M[0], np.where(ok, C, 0.0), self.M[1])
        den = np.einsum("fa,sab,gb->sfg", self.M[0], ok.astype(np.float64), self.M[1])
        # interpolated from the valid coarse neighbours only (a state next to the lean
        # limit is not made to collide by the invalid one beyond it)
        Fc = np.where(den > 1e-9, num / np.maximum(den, 1e-300), -self.safety - 50.0)
        for gi, fc in zip(g, Fc, strict=True):  # states that are not valid stay out
            self.known[int(gi)] = np.where(self.state_valid(int(gi)), fc, -np.inf)
            self._node_cache.pop(int(gi), None)

    def measure_exact(self, g):
        """Know every state of poses g exactly: measured, or (a ball) proved colliding by
        the Lipschitz bound — a state y collides when some measured state x has
        clearance(x) + L·∠(x, y) < ds (L: the farthest point of the tool from the ball's
        centre, about which the axis turns; a reported penetration is never shallower than
        the true one, so the bound holds). Level by level: the coarse grid (measured
        already) bounds every state; the states on every other index that it does not prove
        are measured and bound the rest with the coarse ones; the states still not proved
        are measured. The coarse states are known from the coarse grid itself. Batched per
        level."""
        g = np.asarray([x for x in np.unique(g) if int(x) not in self.exact], np.int64)
        if len(g) == 0:
            return
        new = np.asarray([x for x in g if int(x) not in self.raw], np.int64)
        if len(new):
            self.measure_coarse(new)
        Fl, Ft = self.shape
        nst = Fl * Ft
        coarse = np.zeros(self.shape, bool)
        coarse[np.ix_(*self.cidx)] = True
        out = np.full((len(g), Fl, Ft), -np.inf)
        for j, gi in enumerate(g):
            out[j][np.ix_(*self.cidx)] = self.raw[int(gi)]
        known = np.broadcast_to(coarse, out.shape).copy()  # measured so far
        if self.lip is not None:
            mid = np.zeros(self.shape, bool)
            mid[::2, ::2] = True
            mid[-1, ::2] = mid[::2, -1] = True
            levels = (mid & ~coarse, ~mid & ~coarse)
        else:
            levels = (~coarse,)
        for level in levels:
            need = np.broadcast_to(level, out.shape).copy()
            bound = np.full(out.shape, np.inf)
            if self.lip is not None:
                for j, gi in enumerate(g):
                    A = self.state_axes(int(gi))
                    src = known[j] & np.isfinite(out[j])
                    ang = np.arccos(np.clip(A[level] @ A[src].T, -1.0, 1.0))
                    b = np.min(out[j][src][None, :] + self.lip * ang, axis=1) if src.any() \
                        else np.full(int(level.sum()), np.inf)
                    bound[j][level] = b
                    need[j][level] = b >= self.safety
            c = self.grid(g, np.arange(Fl), np.arange(Ft), need.reshape(len(g), nst))
            proved = np.broadcast_to(level, out.shape) & ~need & np.isfinite(bound)
            out[proved] = np.minimum(bound[proved], self.safety - 1e-6)
            out[need] = c[need]
            known |= need
        for gi, o in zip(g, out, strict=True):
            self.known[int(gi)] = np.where(np.isfinite(self.known[int(gi)]), o, -np.inf)
            self._node_cache.pop(int(gi), None)
            self.exact.add(int(gi))

    # --- the shortest path -----------------------------------------------------------------
    def _moves(self, Ap, Ac, limit):
        """Offsets (o, 2) and (o, F, F) bool: the state x at the later station may follow
        the state x − offset at the earlier one (turn ≤ ``limit``, exact)."""
        (Fl, Ft), r = self.shape, _MAX_R
        offs = [(a, b) for a in range(-r, r + 1) for b in range(-r, r + 1) if a * a + b * b
                <= r * r]
        pad = np.full((Fl + 2 * r, Ft + 2 * r, 3), np.nan)
        pad[r:r + Fl, r:r + Ft] = Ap
        prev = np.stack([pad[r - a:r - a + Fl, r - b:r - b + Ft] for a, b in offs])
        cos = np.einsum("oijk,ijk->oij", prev, Ac)
        with np.errstate(invalid="ignore"):
            ok = cos >= math.cos(limit) - 1e-12
        return np.asarray(offs), ok

    def colliding_states(self, gi):
        """(Fl, Ft) bool: the valid states of pose gi known exactly to collide (none unless
        every state of the pose is known exactly, :meth:`measure_exact`)."""
        k = self.known[int(gi)]
        if int(gi) not in self.exact:
            return np.zeros(k.shape, bool)
        return np.isfinite(k) & (k < self.safety)

    def _gather(self, offs):
        """(o, Fl, Ft) flat indices into the (Fl + 2r, Ft + 2r) padded grid: the state
        x − offset for every state x and offset (cached per offsets)."""
        key = offs.tobytes()
        got = self._gather_cache.get(key)
        if got is None:
            (Fl, Ft), r = self.shape, _MAX_R
            i = np.arange(Fl)[None, :, None] + r - offs[:, 0][:, None, None]
            j = np.arange(Ft)[None, None, :] + r - offs[:, 1][:, None, None]
            got = i * (Ft + 2 * r) + j
            self._gather_cache[key] = got
        return got

    def moves(self, gp, gc, limit):
        """:meth:`_moves` between the states of poses gp and gc, cached."""
        key = (int(gp), int(gc), float(limit))
        got = self._moves_cache.get(key)
        if got is None:
            got = self._moves(self.state_axes(gp), self.state_axes(gc), limit)
            self._moves_cache[key] = got
        return got

    def _clear_states(self, gi):
        """(Fl, Ft) bool: the states of pose gi known clear."""
        return self.known[int(gi)] >= self.safety

    def _motion_penalty(self, tp, ap, tc, ac, ks=None, ke=None, D=None):
        """(k,) cost of the motions between pose rows (tip, axis) → (tip, axis): 0 when
        every sample inside clears, else C plus the depth (as a colliding state). The middle
        sample is measured first and the others only where it clears. Given the exact
        clearances ``ks``, ``ke`` (k,) of the two ends and ``D`` (k,), the farthest any tool
        point moves along the whole motion (a ball: |Δcentre| + L·θ), a sample at t is
        proved clear, not measured, where max(ks − tD, ke − (1 − t)D, mid − |t − ½|D) ≥ ds
        (the clearance is 1-Lipschitz in the displacement)."""
        k = len(tp)
        if k == 0:
            return np.zeros(0)
        tq = np.arange(1, _MOTION_SAMPLES + 1) / (_MOTION_SAMPLES + 1)
        m = _MOTION_SAMPLES // 2
        order = [m] + [i for i in range(_MOTION_SAMPLES) if i != m]
        lo = np.full((k, _MOTION_SAMPLES), -np.inf)  # a lower bound of each sample
        if D is not None:
            lo = np.maximum(ks[:, None] - tq[None] * D[:, None],
                            ke[:, None] - (1 - tq[None]) * D[:, None])
        worst = np.full(k, np.inf)
        for step, idx in enumerate((order[:1], order[1:])):
            if not idx:
                continue
            if step == 1 and D is not None:  # the middle sample bounds the others
                mid = np.where(np.isfinite(worst), worst, lo[:, m])
                lo[:, idx] = np.maximum(lo[:, idx], mid[:, None]
                                        - np.abs(tq[idx] - tq[m])[None] * D[:, None])
            todo = (worst >= self.safety)[:, None] & (lo[:, idx] < self.safety)
            rows, cols = np.nonzero(todo)
            if len(rows) == 0:
                continue
            t = tq[np.asarray(idx)[cols]]
            mt, ma = sample_motion(tp[rows], ap[rows], tc[rows], ac[rows], t, paired=True)
            c = self.clearance(mt, ma)
            np.minimum.at(worst, rows, c)
        return np.where(worst >= self.safety, 0.0, _COLLIDE + self.safety
                        - np.maximum(worst, -self.safety - 50.0))

    def motion_cost(self, gp, gc, limit):
        """(o, Fl, Ft) cost of the motion from the state x − offset at pose gp to the state x
        at the next pose gc (the offsets and turn test of :meth:`_moves`): measured for the
        pairs of clear states within the turn limit, 0 for the others (their poses collide
        and are priced already). Cached per pair."""
        key = (int(gp), int(gc))
        if key in self.mcost:
            return self.mcost[key]
        (Fl, Ft), r = self.shape, _MAX_R
        Ap, Ac = self.state_axes(gp), self.state_axes(gc)
        offs, ok = self.moves(gp, gc, limit)
        Tp, Tc = self.state_tips(gp), self.state_tips(gc)
        padA = np.full((Fl + 2 * r, Ft + 2 * r, 3), np.nan)
        padT = padA.copy()
        padK = np.zeros((Fl + 2 * r, Ft + 2 * r), bool)
        padA[r:r + Fl, r:r + Ft], padT[r:r + Fl, r:r + Ft] = Ap, Tp
        padK[r:r + Fl, r:r + Ft] = self._clear_states(gp)
        sl = [(slice(r - a, r - a + Fl), slice(r - b, r - b + Ft)) for a, b in offs]
        kp = np.stack([padK[i, j] for i, j in sl])
        sel = ok & kp & self._clear_states(gc)[None]
        pen = np.zeros(ok.shape)
        if sel.any():
            o, i, j = np.nonzero(sel)
            pi, pj = i - offs[o, 0] + r, j - offs[o, 1] + r
            tp, ap, tc, ac = padT[pi, pj], padA[pi, pj], Tc[i, j], Ac[i, j]
            ks = ke = D = None
            if self.lip is not None and int(gp) in self.exact and int(gc) in self.exact:
                # a ball: no tool point moves further than |Δcentre| + L·θ along the motion
                # (both ends known exactly: the samples bounded from them)
                ks = np.pad(self.known[int(gp)], r, constant_values=-np.inf)[pi, pj]
                ke = self.known[int(gc)][i, j]
                dc = float(np.linalg.norm(self.P.tip0[gc] + self.cutter.radius * self.P.ax0[gc]
                                          - self.P.tip0[gp] - self.cutter.radius
                                          * self.P.ax0[gp]))
                th = np.arccos(np.clip(np.einsum("ij,ij->i", ap, ac), -1.0, 1.0))
                D = dc + self.lip * th
            pen[sel] = self._motion_penalty(tp, ap, tc, ac, ks, ke, D)
        self.mcost[key] = pen
        return pen

    def motion_cost_fixed(self, g_fixed, gi, into: bool):
        """(Fl, Ft) cost of the motion between the fixed planned pose ``g_fixed`` and each
        clear state of pose gi (``into``: from the fixed pose to gi, else from gi to it)."""
        key = (int(g_fixed), int(gi)) if into else (int(gi), int(g_fixed))
        if key not in self.mcost:
            self.mcost[key] = self.motion_cost_pose(self.P.tip0[g_fixed], self.P.ax0[g_fixed],
                                                    gi, into)
        return self.mcost[key]

    def motion_cost_pose(self, tf, af, gi, into: bool):
        """(Fl, Ft) as :meth:`motion_cost_fixed`, the other pose given as tip ``tf`` and axis
        ``af`` (3,)."""
        A = self.state_axes(gi).reshape(-1, 3)
        T = self.state_tips(gi).reshape(-1, 3)
        sel = self._clear_states(gi).ravel()
        pen = np.zeros(len(A))
        k = int(sel.sum())
        tf, af = np.repeat(np.asarray(tf)[None], k, 0), np.repeat(np.asarray(af)[None], k, 0)
        pen[sel] = (self._motion_penalty(tf, af, T[sel], A[sel]) if into
                    else self._motion_penalty(T[sel], A[sel], tf, af))
        return pen.reshape(self.shape)

    def node_costs(self, gi):
        """(Fl, Ft) cost of each state at pose gi (cached until its clearance is known
        anew; read-only)."""
        got = self._node_cache.get(int(gi))
        if got is None:
            c = self.known[int(gi)]
            node = np.where(c >= self.safety, self._dev, _COLLIDE + self.safety
                            - np.maximum(c, -self.safety - 50.0))
            got = np.where(np.isfinite(c), node, np.inf)
            got.flags.writeable = False
            self._node_cache[int(gi)] = got
        return got

    def plan_run(self, r: _Run):
        """(s, 2) fine states of the stations of run r minimising the costs under the exact
        turn limit between stations (and from/to the fixed poses), or None. A whole closed
        pass (``r.cycle``) is planned open first, then again with its first station held at
        the chosen state (or the reference's, or one of its four cheapest) and its last
        station required to turn into it within the limit, the closing motion priced: the
        closing cut is bounded like any other."""
        if not r.cycle:
            return self._viterbi(r)
        first = self._viterbi(r)
        g0, gl = int(r.g[0]), int(r.g[-1])
        lim = self.turn_limit(gl, g0)
        ref = np.unravel_index(int(np.argmin(self._dev)), self.shape)
        c0 = self.node_costs(g0).ravel()
        cheap = [np.unravel_index(int(i), self.shape) for i in np.argsort(c0, kind="stable")[:4]
                 if np.isfinite(c0[i])]
        starts = ([tuple(first[0])] if first is not None else []) + [tuple(ref)] + \
            [tuple(int(x) for x in st) for st in cheap]
        best, best_cost = None, np.inf
        for st0 in dict.fromkeys(starts):
            a0 = self.state_axes(g0)[st0]
            t0 = self.tips(np.asarray([g0]), a0[None])[0]
            final = np.where(self.state_axes(gl) @ a0 >= math.cos(lim) - 1e-12, 0.0, np.inf)
            if (gl, g0) in self.mpairs:
                final = final + self.motion_cost_pose(t0, a0, gl, False)
            got = self._viterbi(r, st0, final)
            if got is not None and got[1] < best_cost:
                best, best_cost = got[0], got[1]
        return best if best is not None else first

    def _viterbi(self, r: _Run, start=None, final=None):
        """The shortest path over the stations of run r (:meth:`plan_run`): (s, 2) states, or
        None; given ``start`` (the first station's state) and ``final`` ((Fl, Ft) cost added
        at the last station), returns (states, cost) or None."""
        P, (Fl, Ft) = self.P, self.shape
        gst = r.g[r.st]
        cost = self.node_costs(gst[0])
        if start is not None:
            keep = np.full(self.shape, np.inf)
            keep[start] = 0.0
            cost = cost + keep
        if r.pre is not None:
            lim0 = self.turn_limit(r.pre, gst[0])
            first = self.state_axes(int(gst[0]))
            cost = cost + np.where(first @ P.ax0[r.pre] >= math.cos(lim0) - 1e-12, 0.0, np.inf)
            if (int(r.pre), int(gst[0])) in self.mpairs:
                cost = cost + self.motion_cost_fixed(r.pre, gst[0], True)
        backs = []
        # the turn allowed between two stations: the sum of the poses' limits between them
        # (a state held along the run turns by at most the sum of the reference's turns)
        cum = np.r_[0.0, np.cumsum(self.turn_limits(r.g))]
        for j in range(1, len(gst)):
            lim = float(cum[r.st[j]] - cum[r.st[j - 1]])
            offs, ok = self.moves(gst[j - 1], gst[j], lim)
            rr = _MAX_R
            pad = np.full((Fl + 2 * rr, Ft + 2 * rr), np.inf)
            pad[rr:rr + Fl, rr:rr + Ft] = cost
            stack = np.where(ok, pad.ravel()[self._gather(offs)], np.inf)
            if (int(gst[j - 1]), int(gst[j])) in self.mpairs:
                stack = stack + self.motion_cost(gst[j - 1], gst[j], lim)
            arg = np.argmin(stack, axis=0)
            best = np.take_along_axis(stack, arg[None], 0)[0]
            jump = None
            if self.jumps and r.st[j] == r.st[j - 1] + 1:  # may jump, both colliding
                cp, cc_ = self.colliding_states(gst[j - 1]), self.colliding_states(gst[j])
                if cp.any() and cc_.any():
                    src = int(np.argmin(np.where(cp, cost, np.inf)))
                    use = cc_ & (cost.flat[src] + _JUMP < best)
                    if use.any():
                        best = np.where(use, cost.flat[src] + _JUMP, best)
                        jump = (use, np.unravel_index(src, self.shape))
            backs.append((offs, arg, jump))
            cost = best + self.node_costs(gst[j])
        if r.post is not None:
            gl = gst[-1]
            lim1 = self.turn_limit(gl, r.post)
            last = self.state_axes(int(gst[-1]))
            cost = cost + np.where(last @ P.ax0[r.post] >= math.cos(lim1) - 1e-12, 0.0, np.inf)
            if (int(gl), int(r.post)) in self.mpairs:
                cost = cost + self.motion_cost_fixed(r.post, gl, False)
        if final is not None:
            cost = cost + final
        if not np.isfinite(cost.min()):
            return None
        out = np.empty((len(gst), 2), np.int64)
        out[-1] = np.unravel_index(int(np.argmin(cost)), cost.shape)
        for j in range(len(gst) - 1, 0, -1):
            offs, arg, jump = backs[j - 1]
            if jump is not None and jump[0][out[j, 0], out[j, 1]]:
                out[j - 1] = jump[1]
                continue
            a, b = offs[arg[out[j, 0], out[j, 1]]]
            out[j - 1] = out[j] - (a, b)
        return out if start is None else (out, float(cost.min()))
