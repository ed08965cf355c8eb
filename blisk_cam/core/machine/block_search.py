"""Where the NC blocks of a dense pass end: the greedy search for the longest
block whose theoretical machining error (paper 002 §3) or chord height
stays within its bound, and the measurement of blocks against the pass.
mm, radians.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from ..errors import BliskCamError
from ..geometry.distance import MeshDistance
from ..geometry.vectors import unit
from .block_error import pose_error
from .description import Machine, forward

__all__ = [
    "BOUNDS",
    "DensePass",
    "InterpolationError",
    "ALLOWANCE",
    "ALLOWANCE_TORUS",
    "FLOOR",
    "FLOOR_TORUS",
    "block_bounds",
    "block_bounds_rows",
    "cutter_clearance",
    "chord_heights",
    "chord_heights_rows",
    "concat_passes",
    "match_chord_height",
    "measure_blocks",
    "search_chord",
    "search_constant_error",
]
#: "pointwise": max over the block's dense poses of |l_P + l_θ| (Eq. 14 per pose);
#: "paper": per arc-shaped piece max |l_P| + max |l_θ| (paper 002 §3.2, Fig. 10), the larger
BOUNDS = ("pointwise", "paper")


#: relative allowance added to every bound for what the model does not see: the faceted mesh
#: (the planned path's own clearance varies between its poses) and the cutter between dense
#: poses; the measured excess over the bare bound was ≤ 1.2 % on the demo blade (0.1 mm
#: spacing), so 2 % keeps the bound conservative
ALLOWANCE = 0.02
#: the same for a torus (bull nose): the spine point nearest the surface slides along the
#: corner circle as the tool tilts, which the rigid corner-centre model of Eq. (11) does not
#: follow; measured excess ≤ 3 % (demo leading edge, 6/2 bull nose)
ALLOWANCE_TORUS = 0.05
#: mm added to every bound: the evaluation floor (a block inside one dense segment has a
#: model error of 0; measured against a faceted mesh it shows the clearance's variation
#: between two dense poses, up to 0.1 µm on the Rotor 37 STL)
FLOOR = 2e-4
#: the floor for a torus: its clearance is a minimum over the sampled corner circle
FLOOR_TORUS = 5e-4


class InterpolationError(BliskCamError):
    """Bad input to the interpolation (non-positive tolerance, unknown method, …)."""


# ====================================================================== dense pass
@dataclass
class DensePass:
    """A pass solved for the machine and resampled (module docstring).

    q : (m, 5) joints; tip, axis, normal : (m, 3) paths' frame (axis, normal unit);
    lever : (m, 3) mm tip → corner centre; centre : (m, 3) mm corner centres;
    gP, gT : (m, 5) error gradients (:func:`.block_error.error_gradients`);
    Jc : (m, 3, 5) corner-centre Jacobian; source : (m,) float — position in the input pass
    (fractional between its poses); rho : mm, curvature radius for the lateral remainder term.

    The budget of the planned path's own deviation from the part (issue 28: the promise is
    kept against the part, not against the planned path): ``own`` (m,) mm — the signed
    clearance of the cutter on the dense planned path from the part, minus the allowance the
    path leaves (> 0 material left, < 0 gouge; None: not budgeted, the error is taken from the
    planned path as before); ``margin`` mm — what is not known of it (without the part's
    mesh: the planned path's chord tolerance), added to every bound; ``own_step`` (m,) mm —
    how much ``own`` changes to the next or previous dense pose (the deviated pose is compared
    with the nearest pose, which may be one off where a coarse mesh's facet edge makes ``own``
    jump), added per pose; ``target`` mm — the
    clearance the path aims at (its allowance), for measuring against the part.
    """

    q: np.ndarray
    tip: np.ndarray
    axis: np.ndarray
    normal: np.ndarray
    lever: np.ndarray
    centre: np.ndarray
    gP: np.ndarray
    gT: np.ndarray
    Jc: np.ndarray
    source: np.ndarray
    rho: float
    machine: Machine | None = None
    allowance: float = ALLOWANCE
    floor: float = FLOOR
    own: np.ndarray | None = None
    own_step: np.ndarray | None = None
    margin: float = 0.0
    target: float = 0.0

    def __len__(self) -> int:
        return len(self.q)

    def joints_at(self, u) -> np.ndarray:
        """(k, 5) joints at dense positions u (k,) (linear between dense poses)."""
        u = np.clip(np.asarray(u, dtype=np.float64), 0, len(self.q) - 1)
        i = np.minimum(np.floor(u).astype(np.int64), len(self.q) - 2)
        f = (u - i)[:, None]
        return self.q[i] * (1 - f) + self.q[i + 1] * f

    def interp(self, arr, u) -> np.ndarray:
        u = np.clip(np.asarray(u, dtype=np.float64), 0, len(self.q) - 1)
        i = np.minimum(np.floor(u).astype(np.int64), len(self.q) - 2)
        f = u - i
        f = f.reshape((-1,) + (1,) * (arr.ndim - 1))
        return arr[i] * (1 - f) + arr[i + 1] * f


# ====================================================================== bounds
def concat_passes(passes) -> tuple[DensePass, np.ndarray]:
    """Several DensePass → one (arrays stacked) and the (P + 1,) offsets of the passes in it;
    the multi-pass search advances every pass by one block per step, so its numpy calls are
    shared by all passes."""
    passes = list(passes)
    offs = np.concatenate([[0], np.cumsum([len(p) for p in passes])])
    if len(passes) == 1:
        return passes[0], offs
    cat = {k: np.concatenate([getattr(p, k) for p in passes])
           for k in ("q", "tip", "axis", "normal", "lever", "centre", "gP", "gT", "Jc", "source")}
    owns = [p.own for p in passes]
    own = None if all(o is None for o in owns) else np.concatenate(
        [np.zeros(len(p)) if o is None else o for p, o in zip(passes, owns, strict=True)])
    steps = [p.own_step for p in passes]
    own_step = None if all(o is None for o in steps) else np.concatenate(
        [np.zeros(len(p)) if o is None else o for p, o in zip(passes, steps, strict=True)])
    return DensePass(**cat, rho=min(p.rho for p in passes), machine=passes[0].machine,
                     allowance=max(p.allowance for p in passes),
                     floor=max(p.floor for p in passes), own=own, own_step=own_step,
                     margin=max(p.margin for p in passes),
                     target=passes[0].target), offs


_CHUNK_ELEMS = 200_000  # rows × dense poses per vectorised evaluation (memory)


def _rows(dp, s, e):
    """Dense indices inside blocks s → e (R,): (R, Jm) indices (clipped) and mask."""
    j0 = np.floor(s).astype(np.int64) + 1
    jm = int(max(1, int(np.max(np.ceil(e) - 1 - j0 + 1)) if len(s) else 1))
    J = j0[:, None] + np.arange(jm)[None, :]
    mask = J < e[:, None]
    return np.clip(J, 0, len(dp) - 1), mask


def block_bounds_rows(dp: DensePass, s, e, *, bound: str = "pointwise",
                      pose_model: str = "exact", detail: bool = False,
                      allowance: float | None = None):
    """Machining error bound (mm) of blocks s → e, one per row (s, e (R,) dense positions).

    For each dense pose j with s < j < e: the chord parameter t_j of the joint-linear motion
    nearest pose j in the corner-centre metric (paper 002 Eq. 1, see :mod:`.block_error`),
    the trajectory deviation ``Δq_j`` (Eqs. 2–3), then ``l_P``, ``l_θ``: ``pose_model``
    "jacobian" maps Δq by the machine Jacobian (Eqs. 4–7, linear); "exact" (default) takes the
    deviated pose by forward kinematics (no linearisation of the machine: at tight leading
    edges the rotaries turn enough that Eq. 7 underestimates d_M by up to 5 %) and Eqs. 8–14
    with the finite rotation. Bound = max_j |l_P + l_θ| (``pointwise``; or, ``paper``, per
    arc-shaped piece between sign changes of d_M the sum max |l_P| + max |l_θ|, §3.2 Fig. 10)
    plus max_j of the lateral remainder ``|ΔC_⊥n|² / (2 ρ)`` (the cutter leaving the contact
    sideways, offset curvature radius ≥ ρ; paper 002 neglects it, §3.1), times
    (1 + ``allowance``) (None: :data:`ALLOWANCE`, :data:`ALLOWANCE_TORUS` for a cutter with a
    corner circle off the axis), plus :data:`FLOOR` (:data:`FLOOR_TORUS`). With the planned
    path's own deviation budgeted (``dp.own``, :class:`DensePass`) each d_M (l_P for
    ``paper``) is taken with it, ``|d_M + own_j|`` — the error against the part — and at the
    block's two ends ``|own|``; ``dp.margin`` is added.

    Returns (R,) bounds; with ``detail`` a tuple (bound, max |l_P|, max |l_θ|, largest linear
    (mm) and rotary (rad) trajectory deviation), each (R,)."""
    s = np.asarray(s, dtype=np.float64).reshape(-1)
    e = np.asarray(e, dtype=np.float64).reshape(-1)
    R = len(s)
    if allowance is None:
        allowance = dp.allowance
    if R == 0:
        z = np.zeros(0)
        return (z,) * 5 if detail else z
    jm = int(np.max(np.ceil(e) - np.floor(s)))
    step = max(1, _CHUNK_ELEMS // max(jm, 1))
    if R > step:
        parts = [block_bounds_rows(dp, s[i:i + step], e[i:i + step], bound=bound,
                                   pose_model=pose_model, detail=detail, allowance=allowance)
                 for i in range(0, R, step)]
        if detail:
            return tuple(np.concatenate([p[k] for p in parts]) for k in range(5))
        return np.concatenate(parts)
    J, mask = _rows(dp, s, e)
    Jn = J.shape[1]
    qs = dp.joints_at(s)
    dq = dp.joints_at(e) - qs  # (R, 5)
    qJ = dp.q[J]  # (R, Jn, 5)
    Jc = dp.Jc[J]  # (R, Jn, 3, 5)
    u = np.einsum("rjab,rb->rja", Jc, dq)
    w = np.einsum("rjab,rjb->rja", Jc, qs[:, None] - qJ)
    uu = np.einsum("rja,rja->rj", u, u)
    t = np.clip(-np.einsum("rja,rja->rj", u, w) / np.maximum(uu, 1e-300), 0.0, 1.0)
    dqj = (qs[:, None] - qJ) + t[..., None] * dq[:, None, :]  # (R, Jn, 5)
    if pose_model == "jacobian":  # Eq. (7), linear in Δq
        lP = np.einsum("rjb,rjb->rj", dqj, dp.gP[J])
        lT = np.einsum("rjb,rjb->rj", dqj, dp.gT[J])
        dM = lP + lT
        dC = w + t[..., None] * u
    else:  # the deviated pose by forward kinematics, Eqs. (8)–(14) with the finite rotation
        Q = (qs[:, None] + t[..., None] * dq[:, None, :]).reshape(-1, 5)
        tp, ax = forward(dp.machine, Q[:, :3], Q[:, 3:])
        f = J.reshape(-1)
        lP, lT, dM, dCf = pose_error(dp.tip[f], dp.axis[f], tp, ax, dp.normal[f], dp.lever[f],
                                     centre=True)
        lP, lT, dM = (x.reshape(R, Jn) for x in (lP, lT, dM))
        dC = dCf.reshape(R, Jn, 3)
    lat2 = np.maximum(np.einsum("rja,rja->rj", dC, dC) - dM * dM, 0.0)
    rem = np.where(mask, lat2 / (2.0 * dp.rho), 0.0).max(axis=1)
    own = None if dp.own is None else dp.own[J]
    slack = 0.0 if dp.own_step is None else dp.own_step[J]
    if bound == "pointwise":
        b = np.where(mask, np.abs(dM if own is None else dM + own) + slack, 0.0).max(axis=1)
    else:
        aP = np.where(mask, np.abs(lP if own is None else lP + own) + slack, 0.0)
        aT = np.where(mask, np.abs(lT), 0.0)
        sg = np.sign(dM)
        brk = np.zeros(mask.shape, bool)
        brk[:, 0] = True
        brk[:, 1:] = sg[:, 1:] != sg[:, :-1]
        starts = np.nonzero(brk.ravel())[0]
        mP = np.maximum.reduceat(aP.ravel(), starts)
        mT = np.maximum.reduceat(aT.ravel(), starts)
        row = starts // Jn
        b = np.zeros(R)
        np.maximum.at(b, row, mP + mT)
    if own is not None:  # the block's ends lie on the planned path: its own deviation there
        b = np.maximum(b, np.maximum(np.abs(dp.interp(dp.own, s)), np.abs(dp.interp(dp.own, e))))
    out = (b + rem) * (1.0 + allowance) + dp.floor + dp.margin
    if not detail:
        return out
    dev_lin = np.where(mask, np.linalg.norm(dqj[..., :3], axis=2), 0).max(axis=1)
    dev_rot = np.where(mask, np.abs(dqj[..., 3:]).max(axis=2), 0).max(axis=1)
    return (out, np.where(mask, np.abs(lP), 0).max(axis=1),
            np.where(mask, np.abs(lT), 0).max(axis=1), dev_lin, dev_rot)


def block_bounds(dp: DensePass, s: float, ends, **kw):
    """(K,) bounds of the blocks s → e for every candidate end e (K,)
    (:func:`block_bounds_rows`)."""
    ends = np.atleast_1d(np.asarray(ends, dtype=np.float64))
    return block_bounds_rows(dp, np.full(len(ends), float(s)), ends, **kw)


def chord_heights_rows(dp: DensePass, s, e) -> np.ndarray:
    """(R,) mm: chord height of the tip path in the part frame — the largest distance of the
    dense tips inside each block s → e (R,) from the straight segment tip(s) → tip(e) (the
    baseline of paper 002 §4.1)."""
    s = np.asarray(s, dtype=np.float64).reshape(-1)
    e = np.asarray(e, dtype=np.float64).reshape(-1)
    if len(s) == 0:
        return np.zeros(0)
    J, mask = _rows(dp, s, e)
    a = dp.interp(dp.tip, s)
    ab = dp.interp(dp.tip, e) - a
    L2 = np.maximum(np.einsum("ra,ra->r", ab, ab), 1e-300)
    p = dp.tip[J] - a[:, None]
    t = np.clip(np.einsum("rja,ra->rj", p, ab) / L2[:, None], 0, 1)
    d = np.linalg.norm(p - t[..., None] * ab[:, None], axis=2)
    return np.where(mask, d, 0.0).max(axis=1)


def chord_heights(dp: DensePass, s: float, ends) -> np.ndarray:
    """(K,) chord heights of the blocks s → e (:func:`chord_heights_rows`)."""
    ends = np.atleast_1d(np.asarray(ends, dtype=np.float64))
    return chord_heights_rows(dp, np.full(len(ends), float(s)), ends)


def _confirm_bracket(ok, gallop, fn, rows, s, lo, hi, last, min_step):
    """Check the fast estimate's bracket [lo, hi) of the blocks from s with fn, in place:
    the end is kept, moved down to 85 % of the way, or searched again with fn (lo NaN)."""
    has = ~np.isnan(lo)
    at_end = has & np.isnan(hi)
    if at_end.any():
        i = np.nonzero(at_end)[0]
        g = ok(fn, s[i], last[rows[i], None])[:, 0]
        hi[i[~g]] = last[rows[i[~g]]]
        lo[i[~g]] = np.nan
    mid = has & ~at_end
    if mid.any():
        i = np.nonzero(mid)[0]
        c = s[i] + 0.85 * (lo[i] - s[i])
        g = ok(fn, s[i], np.stack([c, lo[i]], axis=1))
        only_c = ~g[:, 1] & g[:, 0]
        neither = ~g[:, 1] & ~g[:, 0]
        hi[i[only_c]] = lo[i[only_c]]
        lo[i[only_c]] = c[only_c]
        hi[i[neither]] = c[neither]
        lo[i[neither]] = np.nan
    redo = np.isnan(lo) & ~np.isnan(hi)
    if redo.any():
        i = np.nonzero(redo)[0]
        lo[i], hi[i] = gallop(fn, rows[i], s[i],
                              np.maximum(0.5 * (hi[i] - s[i]), min_step))


def _search(dp: DensePass, offs, fn, tol: float, *, fast=None, max_rotary_step=None,
            min_step: float = 1e-3, ways: int = 8, rounds: int = 2):
    """Greedy longest blocks of every pass (offsets ``offs`` (P + 1,) into ``dp``): from s,
    the largest e with fn(s, e) ≤ tol (assumed monotone in e up to the first failure).
    All passes advance one block per step (shared vectorised evaluations). Galloping over
    geometric candidates (with ``fast``, a cheaper estimate of fn, when given; fn then checks
    the bracket), then ``rounds`` rounds of ``ways``-way bisection with fn; ``min_step`` dense
    steps is the shortest block. fn(s (R,), e (R,)) → (R,). Returns per pass the dense
    positions of its block ends (B + 1,), from the pass's first pose to its last (global
    positions minus the pass offset)."""
    P = len(offs) - 1
    last = (offs[1:] - 1).astype(np.float64)
    G = np.exp2(np.linspace(-2.0, 2.0, 9))
    fast = fast or fn

    def ok(f, s, E):
        """(n, K) candidate ends E of blocks from s (n,) → bool (n, K)."""
        n, K = E.shape
        S = np.repeat(s, K)
        good = (f(S, E.reshape(-1)) <= tol).reshape(n, K)
        if max_rotary_step is not None:
            dq = np.abs(dp.joints_at(E.reshape(-1))[:, 3:] - dp.joints_at(S)[:, 3:]).max(axis=1)
            good &= (dq <= max_rotary_step).reshape(n, K)
        return good

    def prefix(E, g):
        """per row: largest passing candidate before the first failure (nan: none) and that
        failure (nan: none)."""
        n, K = E.shape
        bad = ~g
        anyb = bad.any(axis=1)
        k = np.where(anyb, np.argmax(bad, axis=1), K)
        lo = np.where(k > 0, E[np.arange(n), np.maximum(k - 1, 0)], np.nan)
        hi = np.where(anyb, E[np.arange(n), np.minimum(k, K - 1)], np.nan)
        return lo, hi

    def gallop(f, rows, s, scale):
        """lo (passes; nan: not even s + min_step), hi (fails; nan: lo is the pass end)."""
        lo = np.full(len(rows), np.nan)
        hi = np.full(len(rows), np.nan)
        act = np.arange(len(rows))
        scale = scale.copy()
        for _ in range(80):
            if len(act) == 0:
                break
            E = np.minimum(s[act, None] + scale[act, None] * G[None], last[rows[act], None])
            la, hb = prefix(E, ok(f, s[act], E))
            end = np.isnan(hb) & (E[:, -1] >= last[rows[act]])
            grow = np.isnan(hb) & ~end
            tiny = np.isnan(la) & ~np.isnan(hb) & (E[:, 0] - s[act] <= min_step)
            shrink = np.isnan(la) & ~np.isnan(hb) & ~tiny
            done = ~(grow | shrink)
            lo[act[done]] = la[done]
            hi[act[done]] = hb[done]
            scale[act[grow]] *= 4.0
            scale[act[shrink]] /= 4.0
            act = act[~done]
        return lo, hi

    def refine(f, s, a, b):
        for _ in range(rounds):
            E = a[:, None] + (b - a)[:, None] * (np.arange(1, ways + 1) / (ways + 1))[None]
            la, hb = prefix(E, ok(f, s, E))
            a = np.where(np.isnan(la), a, la)
            b = np.where(np.isnan(hb), b, hb)
        return a

    ends = [[float(offs[p])] for p in range(P)]
    rows = np.arange(P)[last > offs[:-1]]
    s = offs[rows].astype(np.float64)
    L = np.full(len(rows), 8.0)
    while len(rows):
        lo, hi = gallop(fast, rows, s, L)
        if fast is not fn:  # the fast estimate brackets; fn decides
            _confirm_bracket(ok, gallop, fn, rows, s, lo, hi, last, min_step)
        br = ~np.isnan(lo) & ~np.isnan(hi)
        if br.any():
            i = np.nonzero(br)[0]
            lo[i] = refine(fn, s[i], lo[i], hi[i])
        lo = np.where(np.isnan(lo), np.minimum(s + min_step, last[rows]), lo)
        for r, v in zip(rows, lo, strict=True):
            ends[r].append(float(v))
        L = np.maximum(lo - s, min_step)
        s = lo
        keep = s < last[rows] - 1e-9
        rows, s, L = rows[keep], s[keep], L[keep]
    return [np.asarray(e) - offs[p] for p, e in enumerate(ends)]


def _as_list(dense):
    if isinstance(dense, DensePass):
        return [dense], True
    return list(dense), False


def search_constant_error(dense, max_error: float, *, bound: str = "pointwise",
                          max_rotary_step=None, pose_model: str = "exact",
                          min_step: float = 1e-3):
    """Block ends: the longest blocks whose error bound (:func:`block_bounds_rows`) stays
    ≤ ``max_error`` mm = [d_M] (paper 002 §3.2, Fig. 11). ``dense``: a DensePass (→ (B + 1,)
    dense positions) or a list of them (→ list; searched together). ``min_step``: the
    shortest block, dense steps (where even it exceeds the bound)."""
    _check_positive("max_error", max_error)
    if bound not in BOUNDS:
        raise InterpolationError(f"unknown bound {bound!r}; use one of {', '.join(BOUNDS)}")
    passes, single = _as_list(dense)
    dp, offs = concat_passes(passes)
    fast = None
    if pose_model == "exact":
        fast = lambda s, e: block_bounds_rows(dp, s, e, bound=bound,  # noqa: E731
                                              pose_model="jacobian")
    out = _search(dp, offs, lambda s, e: block_bounds_rows(dp, s, e, bound=bound,
                                                          pose_model=pose_model),
                  float(max_error), fast=fast, max_rotary_step=max_rotary_step,
                  min_step=min_step)
    return out[0] if single else out


def search_chord(dense, chord_height: float, *, max_rotary_step=None):
    """Block ends: the longest blocks whose tip chord height in the part frame
    (:func:`chord_heights_rows`) stays ≤ ``chord_height`` mm (the baseline of paper 002 §4.1).
    ``dense`` as in :func:`search_constant_error`."""
    _check_positive("chord_height", chord_height)
    passes, single = _as_list(dense)
    dp, offs = concat_passes(passes)
    out = _search(dp, offs, lambda s, e: chord_heights_rows(dp, s, e), float(chord_height),
                  max_rotary_step=max_rotary_step)
    return out[0] if single else out


def _check_positive(name, v):
    if v is None or not (isinstance(v, (int, float, np.floating)) and math.isfinite(v) and v > 0):
        raise InterpolationError(f"{name} must be a positive number of mm, got {v!r}")


# ====================================================================== exact evaluation
def _spine_point(cutter, tip, ax, normal):
    """(k, 3) point of the cutter's corner circle (spine) nearest the surface of unit normal
    ``normal`` (k, 3): ``tip + f a + e u`` with u the direction of −n across the axis (the
    contact side); for a ball the centre ``tip + ρ a``."""
    f, e = float(cutter.f), float(cutter.e)
    c = tip + f * ax
    if e <= 1e-12:
        return c
    u = -(normal - np.einsum("ij,ij->i", normal, ax)[:, None] * ax)
    return c + e * unit(u, keep_zero=False)


def _clearance(machine, cutter, md, q, normal=None):
    """(k,) mm signed clearance of the cutter at joints q (k, 5) from the mesh: distance of
    the corner circle (spine) to the mesh minus the corner radius (ball: centre − ρ). For a
    torus the spine is searched within ±12° of the contact side given by the surface
    ``normal`` (k, 3): 2° steps, then 0.5° around the best (≤ 0.04 µm chord sag at
    e = 4 mm)."""
    tip, ax = forward(machine, q[:, :3], q[:, 3:])
    r = float(cutter.r)
    f = float(cutter.f)
    e = float(cutter.e)
    c = tip + f * ax
    if e <= 1e-12:
        return md.query(c).signed_distance - r, c
    u = unit(-(normal - np.einsum("ij,ij->i", normal, ax)[:, None] * ax), keep_zero=False)
    v = np.cross(ax, u)

    def dist(phi):  # phi (k, p) radians → (k, p) mm
        P = c[:, None] + e * (np.cos(phi)[..., None] * u[:, None] + np.sin(phi)[..., None]
                              * v[:, None])
        return md.query(P.reshape(-1, 3)).signed_distance.reshape(phi.shape)

    k = len(q)
    coarse = np.broadcast_to(np.radians(np.linspace(-12.0, 12.0, 13)), (k, 13))
    dc = dist(coarse)
    best = coarse[np.arange(k), np.argmin(dc, axis=1)]
    fine = best[:, None] + np.radians(np.linspace(-2.0, 2.0, 9))[None]
    d = np.minimum(dc.min(axis=1), dist(fine).min(axis=1))
    return d - r, c


def cutter_clearance(machine, cutter, mesh, q, normal):
    """(k,) mm signed clearance of the cutter at joints q (k, 5) from the mesh (TriMesh or
    MeshDistance): > 0 off the surface, < 0 in it (:func:`_clearance`)."""
    md = mesh if isinstance(mesh, MeshDistance) else MeshDistance(mesh)
    return _clearance(machine, cutter, md, np.asarray(q, dtype=np.float64), normal)[0]


def _foot(dp: DensePass, c) -> np.ndarray:
    """(k,) dense positions of the foot points of corner centres c (k, 3) on the dense
    centre polyline (the nearest dense pose's two segments, perpendicular projection)."""

    m = len(dp)
    _, j = cKDTree(dp.centre).query(c)
    best_u = j.astype(np.float64)
    best_d = np.linalg.norm(c - dp.centre[j], axis=1)
    for a in (j - 1, j):
        ok = (a >= 0) & (a + 1 < m)
        a = np.clip(a, 0, m - 2)
        p0, p1 = dp.centre[a], dp.centre[a + 1]
        d = p1 - p0
        t = np.clip(np.einsum("ij,ij->i", c - p0, d) / np.maximum(np.einsum("ij,ij->i", d, d),
                                                                    1e-300), 0, 1)
        dist = np.linalg.norm(c - (p0 + t[:, None] * d), axis=1)
        better = ok & (dist < best_d)
        best_u = np.where(better, a + t, best_u)
        best_d = np.where(better, dist, best_d)
    return best_u


def measure_blocks(machine: Machine, cutter, dp: DensePass, ends, *, mesh=None,
                   samples: int = 32, ref=None, per_dense: float = 1.0):
    """Exact per-block error, not using the bound.

    Each block's joint-linear motion (ends (B + 1,) dense positions) is sampled at
    ``samples`` interior points (more for long blocks: ``per_dense`` per dense pose); ``ref``
    (m,) the planned dense poses' clearance from the mesh, when already known;
    ``machine.forward`` gives the cutter pose. With ``mesh`` (TriMesh or
    :class:`..geometry.distance.MeshDistance`): the signed clearance of the cutter from the mesh
    (:func:`_clearance`) minus that of the planned dense path (nearest dense pose) — > 0
    undercut, < 0 overcut. Without a mesh: the corner centre's offset from the nearest dense
    pose's centre along that pose's surface normal (no linearisation of the machine; the
    surface taken as its tangent plane). With the planned path's own deviation budgeted
    (``dp.own``): against the part — with ``mesh`` the cutter's clearance minus ``dp.target``
    (the path's allowance), without it the offset above plus ``dp.own`` at the foot point.

    Returns (B,) max |error|, (B,) most negative (overcut, ≤ 0), (B,) most positive (≥ 0), mm.
    """
    ends = np.asarray(ends, dtype=np.float64)
    B = len(ends) - 1
    qs = dp.joints_at(ends)
    span = np.diff(ends)
    ns = np.maximum(samples, np.ceil(per_dense * span).astype(np.int64) + 1)
    blk = np.repeat(np.arange(B), ns)
    start = np.concatenate([[0], np.cumsum(ns)])[:-1]
    k = np.arange(len(blk)) - start[blk]
    t = (k + 1) / (ns[blk] + 1)
    Q = qs[blk] + t[:, None] * (qs[blk + 1] - qs[blk])
    tip, ax = forward(machine, Q[:, :3], Q[:, 3:])
    # the spine point on the contact side of the moved tool (ball: its centre)
    n0 = unit(dp.interp(dp.normal, ends[blk] + t * span[blk]), keep_zero=False)
    c = _spine_point(cutter, tip, ax, n0)
    foot = _foot(dp, c)
    nf = unit(dp.interp(dp.normal, foot), keep_zero=False)
    c = _spine_point(cutter, tip, ax, nf)
    if mesh is not None:
        md = mesh if isinstance(mesh, MeshDistance) else MeshDistance(mesh)
        if ref is None and dp.own is None:
            ref, _ = _clearance(machine, cutter, md, dp.q, dp.normal)
        val, _ = _clearance(machine, cutter, md, Q, nf)
        err = (val - dp.target) if dp.own is not None else (val - dp.interp(ref, foot))
    else:
        cf = dp.interp(dp.centre, foot)
        err = np.einsum("ij,ij->i", c - cf, nf)
        if dp.own is not None:
            err = err + dp.interp(dp.own, foot)
    mx = np.zeros(B)
    lo = np.zeros(B)
    hi = np.zeros(B)
    np.maximum.at(mx, blk, np.abs(err))
    np.minimum.at(lo, blk, err)
    np.maximum.at(hi, blk, err)
    return mx, lo, hi


def match_chord_height(dp_list, machine, cutter, target: float, *, mesh=None,
                       lo: float = 1e-5, hi: float = 1.0, iters: int = 16, mesh_iters: int = 0,
                       samples: int = 32):
    """The chord height whose measured maximum error matches ``target`` mm from below: the
    largest h (bisection on log h) whose blocks over all passes ``dp_list`` have a measured
    maximum (:func:`measure_blocks`) ≤ target. The bisection runs against the path (fast; on
    the demo blade it agrees with the mesh to 0.02 µm), with ``mesh_iters`` > 0 then that many
    more steps against ``mesh`` within a factor 2; the chosen blocks are measured against
    ``mesh`` when given. The chord method's maximum jumps with h (one block growing over a
    fast rotary turn), so "equal" is the largest h whose maximum does not exceed the target.
    Returns (h, ends per pass, measured (B,) per pass)."""
    dp_list = list(dp_list)
    md = None if mesh is None else (mesh if isinstance(mesh, MeshDistance) else MeshDistance(mesh))
    refs = [None] * len(dp_list)
    if md is not None:
        refs = [_clearance(machine, cutter, md, dp.q, dp.normal)[0] for dp in dp_list]

    def run(h, m=None):
        E = search_chord(dp_list, h)
        M = [measure_blocks(machine, cutter, dp, e, mesh=m, samples=samples, ref=rf)[0]
             for dp, e, rf in zip(dp_list, E, refs, strict=True)]
        return max(float(x.max()) for x in M), E, M

    def bisect(a, b, n, m):
        best = None
        for _ in range(n):
            mid = 0.5 * (a + b)
            worst, E, M = run(math.exp(mid), m)
            if worst <= target:
                best = (math.exp(mid), E, M)
                a = mid
            else:
                b = mid
        return best, a

    best, a = bisect(math.log(lo), math.log(hi), iters, None)
    if md is not None and mesh_iters > 0:
        h0 = best[0] if best else math.exp(a)
        best2, a2 = bisect(math.log(h0 / 2), math.log(h0 * 2), mesh_iters, md)
        if best2 is not None:
            return best2
        _, E, M = run(h0 / 2, md)
        return h0 / 2, E, M
    h = best[0] if best else math.exp(a)
    if best is None or md is not None:
        _, E, M = run(h, md)
        return h, E, M
    return best
