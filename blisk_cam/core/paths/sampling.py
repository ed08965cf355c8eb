"""Forward step: CC points along an exact intersection polyline within a chord tolerance
(paper 001 §3.1.3, Eq. 10), with the tolerance holding for the tool path too.

The paper fits a spline through the intersection points and steps by the chord error of the
CC curve. On a mesh the exact CC curve *is* the intersection polyline (the mesh is piecewise
linear), so we sample it directly: from each CC point we take the farthest polyline point such
that every skipped point lies within ``chord`` of the straight CC move **and** every skipped
ball centre lies within ``chord`` of the straight centre move (ARCHITECTURE.md, math notes:
around a 0.3 mm leading edge the normal turns by ~180° in a millimetre, and a straight move
between poses on either side would cut into the blade). To see the centre path between
polyline points we first insert points where the smooth normal turns by more than
``2 acos(1 − chord / (4 ρ))`` (normals slerped along the segment, which lies in one face, so
the inserted points are on the mesh and on the cone).
"""

from __future__ import annotations

import numpy as np

from ..errors import ToleranceError
from ..geometry.vectors import slerp, unit
from ..kernels import densify as compiled_densify
from ..kernels import step as compiled_step
from ..kernels.backend import extension

__all__ = ["densify_by_normal_turn", "forward_step_indices", "sample_polyline"]

#: share of the chord tolerance the ball-centre path may use between poses
CENTRE_CHORD_SHARE = 0.6


def densify_by_normal_turn(points, normals, closed: bool, max_turn: float):
    """Insert points on polyline segments where the normal turns by more than ``max_turn``.

    Parameters
    ----------
    points : (k, 3) float, mm
    normals : (k, 3) float, unit
    closed : bool — if True the closing segment (last → first) is included and the returned
        arrays end with a copy of the first point.
    max_turn : float, radians

    Returns
    -------
    points (k', 3), normals (k', 3), segment (k',) int — the input segment each output point
    lies on (segment i joins input points i and i+1, the closing one wraps to 0)

    The compiled kernels give the same bits (:mod:`..kernels.densify`); this numpy code is
    their reference and runs where they do not (numpy backend, anti-parallel normals).
    """
    got = compiled_densify.densify_by_normal_turn(points, normals, closed, max_turn)
    if got is not None:
        return got
    P = np.asarray(points, dtype=np.float64)
    N = unit(np.asarray(normals, dtype=np.float64))
    if closed:
        P = np.vstack([P, P[:1]])
        N = np.vstack([N, N[:1]])
    if len(P) < 2:
        return P, N, np.zeros(len(P), dtype=np.int64)
    n0, n1 = N[:-1], N[1:]
    cosang = np.clip(np.einsum("ij,ij->i", n0, n1), -1.0, 1.0)
    ang = np.arccos(cosang)
    nsub = np.maximum(1, np.ceil(ang / max_turn).astype(np.int64))
    nsub = np.minimum(nsub, 10_000)
    if np.all(nsub == 1):
        return P, N, np.minimum(np.arange(len(P)), len(n0) - 1)
    seg = np.repeat(np.arange(len(n0)), nsub)
    start = np.repeat(np.cumsum(nsub) - nsub, nsub)
    u = (np.arange(len(seg)) - start) / nsub[seg]
    p = P[seg] + u[:, None] * (P[seg + 1] - P[seg])
    n = slerp(n0[seg], n1[seg], u, weights_first=True)
    return np.vstack([p, P[-1:]]), np.vstack([n, N[-1:]]), np.append(seg, len(n0) - 1)


#: largest (candidate ends × points between) evaluated at once by the forward step: a search
#: whose remaining tests lie within this many point–segment distances gets them all from one
#: batch, else the batch holds the tests of its next few bisection levels (one batch costs
#: about as much as one test per ~600 distances; the first batch up to here holds the whole
#: search for steps up to ~27 points)
BATCH_PAIRS = 3000
#: a search first evaluates the tests it makes if its step is within this many points of the
#: last step (on the 1M-triangle demo blade 60 % of the steps repeat the last exactly, 79 %
#: within 2 points)
LIKELY_SPREAD = 2


def _span_deviations(XT, i, js, cols):
    """Largest distance of the points ``i+1 .. j-1`` to the segment from point ``i`` to point
    ``j``, for every end ``j`` of ``js`` and each of the p stacked polylines at once.

    Every sum of three products is taken as ``(x₀y₀ + x₂y₂) + x₁y₁``, the order in which
    ``np.einsum`` sums three terms (its two-lane SIMD loop puts terms 0 and 2 in one lane;
    numpy 1.26 and 2.5 alike): the one-span-at-a-time einsum version chose the same samples
    to the last bit. The arrays are laid out (coordinate, polyline, end, point) so that
    every operation runs along the points (numpy is slow along short trailing axes).

    Parameters
    ----------
    XT : (3, p, k) float, mm — the coordinates of p stacked polylines (p = 2: the CC and
        the centre polylines)
    i : int — the start
    js : (n,) int, ascending, all > i — the candidate ends
    cols : (≥ k,) int — ``np.arange``, kept by the caller

    Returns
    -------
    (n, p) float, mm (0 where j = i + 1: no point between)
    """
    W = int(js[-1]) - i - 1  # the points between i and the farthest end
    if W <= 0:
        return np.zeros((len(js), XT.shape[1]))
    a = XT[:, :, i : i + 1]  # (3, p, 1)
    Q = (XT[:, :, i + 1 : i + 1 + W] - a)[:, :, None, :]  # (3, p, 1, W)
    if js[-1] - js[0] + 1 == len(js):  # consecutive ends: a view, no gather
        B = XT[:, :, js[0] : js[-1] + 1] - a  # (3, p, n)
    else:
        B = XT[:, :, js] - a
    sq = B * B
    L2 = sq[0] + sq[2]
    L2 += sq[1]
    L2 += L2 == 0  # a zero-length chord: t = 0 (projection onto its one point)
    B = B[..., None]  # (3, p, n, 1)
    pr = Q * B  # (3, p, n, W)
    t = pr[0] + pr[2]
    t += pr[1]
    t /= L2[..., None]
    np.maximum(t, 0.0, out=t)
    np.minimum(t, 1.0, out=t)
    d = np.multiply(B, t, out=pr)
    np.subtract(Q, d, out=d)
    d *= d
    d2 = d[0] + d[2]  # (p, n, W) squared distances
    d2 += d[1]
    np.copyto(d2, 0.0, where=cols[:W] >= (js - (i + 1))[:, None])  # at or past j: not between
    return np.sqrt(d2.max(axis=2)).T


def _bisection_tests(lo, hi, levels):
    """The points the bisection of the bracket (lo, hi) may test in its next ``levels`` steps
    (list of int; all ``hi − lo − 1`` points between when ``levels`` covers the bracket)."""
    out, brackets = [], [(lo, hi)]
    for _ in range(levels):
        nxt = []
        for a, b in brackets:
            if b - a > 1:
                m = (a + b) // 2
                out.append(m)
                nxt += ((a, m), (m, b))
        if not nxt:
            break
        brackets = nxt
    return out


def _levels_in_budget(span):
    """Bisection levels whose 2^levels − 1 tests, each over up to ``span`` points, fit in
    ``BATCH_PAIRS`` (at least 1)."""
    levels = 1
    while (2 ** (levels + 1) - 1) * span <= BATCH_PAIRS:
        levels += 1
    return levels


def _paths_to(lo, hi, g1, g2, out):
    """Append the points the bisection of (lo, hi) tests on its way to any outcome in
    [g1, g2] (the outcome g is the final lo: every test ≤ g passes, every test > g fails)."""
    while hi - lo > 1:
        m = (lo + hi) // 2
        out.append(m)
        if g1 < m <= g2:  # outcomes on both sides: the left ones take the other way
            _paths_to(lo, m, g1, g2, out)
            lo = m
        elif g2 < m:
            hi = m
        else:
            lo = m


def _likely_tests(i, step, last, g1, g2):
    """The ends the search from ``i`` with first step ``step`` tests when its outcome is any
    point of [g1, g2] and the tolerance holds up to the outcome and fails past it (list of
    int)."""
    out, good = [], i + 1
    while True:
        j = min(i + step, last)
        out.append(j)
        if g1 < j:  # outcomes below j end in the bracket (good, j)
            _paths_to(good, j, max(g1, good), min(g2, j - 1), out)
        if j > g2 or j == last:
            return out
        good, step = j, 2 * step


# long on purpose: one hot sequential search loop (memo, batches, exponential search, bisection
# on shared state); next for a compiled kernel, and split it would thread that state per step
def forward_step_indices(P, C, chord: float, max_step: float | None = None,
                         centre_chord: float | None = None, *, memo: dict | None = None):
    """Greedy forward step: indices of P to keep so that every skipped point lies within
    ``chord`` of its straight move, for the CC points ``P`` and the centres ``C`` alike.

    The first and last index are always kept. From each kept point an exponential search
    (starting at the previous step, which is usually close) then a bisection find the
    farthest admissible point (the tolerance is checked at the chosen point, so the result
    always satisfies it).

    The tests are evaluated in batches (:func:`_span_deviations`), a few numpy calls for
    many candidate ends instead of a dozen per end: a search first gets the answers of every
    test it makes if its outcome lies within ``LIKELY_SPREAD`` points of the last step (four
    searches in five on the demo blade need nothing else), then runs on the known answers,
    asking a batch only for a test not yet known. The searches, their outcomes and the
    chosen points are exactly those of one test at a time.

    Parameters
    ----------
    P, C : (k, 3) float, mm
    chord : float, mm
    max_step : float, mm, optional — also limit the CC move length
    centre_chord : float, mm, optional — tolerance for the centres (default ``chord``)
    memo : dict, optional — carried from one call to the next on the same polyline whose
        points changed in places only (the generator lifts a few ball centres and samples
        again): a search from point i with the same first step whose tested points
        i..max j are all unchanged has the same outcome, so it is taken from the last call
        instead of being run again. The result is the same as without ``memo``.

    Returns
    -------
    (q,) int indices
    """
    tol_p = float(chord)
    tol_c = float(chord if centre_chord is None else centre_chord)
    if max_step is None and extension() is not None:
        return _compiled_forward_step(P, C, tol_p, tol_c, memo)
    # (3, 2, k): coordinate, polyline (CC, centre), point
    k = len(P)
    XT = np.empty((3, 2, k))
    XT[:, 0] = np.asarray(P, dtype=np.float64).T
    XT[:, 1] = np.asarray(C, dtype=np.float64).T
    last = k - 1
    keep = [0]
    i = 0
    old, unchanged_to = {}, None
    key = (tol_p, tol_c, max_step)
    if memo is not None and memo.get("key") == key and memo.get("XT", XT).shape == XT.shape:
        old = memo["trace"]
        # unchanged_to[j]: number of changed points before j
        changed = np.any(XT != memo["XT"], axis=(0, 1))
        unchanged_to = np.concatenate([[0], np.cumsum(changed)])
    trace = {}
    cols = np.arange(k)
    known = {}  # end j → admissible from the current start i

    def evaluate(ends):
        ends = sorted(set(ends))
        js = np.array(ends)
        dev = _span_deviations(XT, i, js, cols)
        good = (dev[:, 0] <= tol_p) & (dev[:, 1] <= tol_c)
        if max_step is not None:
            good &= [not np.linalg.norm(XT[:, 0, j] - XT[:, 0, i]) > max_step for j in ends]
        known.update(zip(ends, good.tolist(), strict=True))

    prev = 2
    while i < last:
        step = max(prev, 2)
        was = old.get(i)
        if (was is not None and was[0] == step
                and unchanged_to[was[2] + 1] == unchanged_to[i]):
            good = was[1]
            trace[i] = was
            keep.append(good)
            prev = good - i
            i = good
            continue
        known.clear()
        # first the tests of the outcomes within LIKELY_SPREAD of the last step (~80 %)
        evaluate(_likely_tests(i, step, last, max(i + 1, i + step - LIKELY_SPREAD),
                               i + step + LIKELY_SPREAD))
        good = i + 1
        bad = None
        while True:  # exponential search
            j = min(i + step, last)
            if j not in known:  # (j > good: the first j is among the likely tests)
                nxt = min(i + 2 * step, last)  # the next test if j passes
                if (nxt - good) * (nxt - i) <= BATCH_PAIRS:
                    evaluate(range(good + 1, nxt + 1))  # every test up to nxt's bracket
                else:
                    lv = _levels_in_budget(nxt - i)
                    evaluate([j, nxt, *_bisection_tests(good, j, lv),
                              *_bisection_tests(j, nxt, lv - 1)])
            if not known[j]:
                bad = j
                break
            good = j
            if j == last:
                break
            step *= 2
        if bad is not None:
            lo, hi = good, bad
            while hi - lo > 1:
                mid = (lo + hi) // 2
                if mid not in known:
                    if (hi - lo - 1) * (hi - i) <= BATCH_PAIRS:
                        evaluate(range(lo + 1, hi))
                    else:
                        evaluate(_bisection_tests(lo, hi, _levels_in_budget(hi - i)))
                if known[mid]:
                    lo = mid
                else:
                    hi = mid
            good = lo
        # the outcome depends on the points i .. the farthest end tested
        trace[i] = (max(prev, 2), good, last if bad is None else bad)
        keep.append(good)
        prev = good - i
        i = good
    if memo is not None:
        memo.update(key=key, XT=XT, trace=trace)
    return np.asarray(keep, dtype=np.int64)


def _compiled_forward_step(P, C, tol_p, tol_c, memo):
    """:func:`forward_step_indices` by the compiled kernel (the same searches, tests and
    arithmetic, so the same indices to the last bit); ``memo`` holds its own key, so a memo
    of one backend is never read by the other."""
    X = np.empty((2, len(P), 3))
    X[0] = P
    X[1] = C
    key = (tol_p, tol_c, "compiled")
    old = unchanged_to = None
    if memo is not None and memo.get("key") == key and memo["X"].shape == X.shape:
        changed = np.any(X != memo["X"], axis=(0, 2))
        unchanged_to = np.concatenate([[0], np.cumsum(changed)])
        old = memo["trace"]
    keep, trace = compiled_step.forward_step(X[0], X[1], tol_p, tol_c, old, unchanged_to)
    if memo is not None:
        memo.update(key=key, X=X, trace=trace)
    return keep


def sample_polyline(points, normals, closed: bool, *, chord: float, radius: float, start=None,
                    lift=None, return_index: bool = False, centre_chord: float | None = None,
                    memo: dict | None = None):
    """CC points and normals on an exact intersection polyline for a ball of ``radius``.

    Parameters
    ----------
    points : (k, 3) float, mm — the exact mesh ∩ cone polyline
    normals : (k, 3) float — smooth unit normals there
    closed : bool
    chord : float, mm — tolerance for the CC polyline and for the ball-centre polyline
    radius : float, mm — ball radius ρ (centres are ``p + ρ n``)
    start : int, optional — for closed loops, the polyline index to start at (default: the
        point farthest along +z, so the seams of successive passes line up)
    centre_chord : float, mm, optional — tolerance of the ball-centre polyline (default
        ``CENTRE_CHORD_SHARE × chord``); the generator also caps it by a share of the cusp
        height, since the centre path's sag between poses adds to the scallop
    lift : callable (points (q, 3), normals (q, 3), segment (q,) of the input polyline, after
        the ``start`` roll) → (q,) mm, optional — how far each ball centre must be lifted along
        its normal beyond ``radius`` to clear the facets around the point (centres are then
        ``p + (ρ + λ) n``; the chord check uses these lifted centres)
    memo : dict, optional — the same dict on every call for the same polyline: the forward
        step reuses the searches of the last call where the centres did not change (see
        :func:`forward_step_indices`); the result is the same

    Returns
    -------
    cc : (q, 3) float, mm
    normal : (q, 3) float
    lifted : (q,) float, mm — λ of each pose (0 without ``lift``)
    index : (q,) int — with ``return_index``: the index of each pose among the points passed to
        ``lift`` (the input polyline after the ``start`` roll, densified where the normal turns)
    (for a closed loop the first point is not repeated at the end)
    """
    if not (np.isfinite(chord) and chord > 0):
        raise ToleranceError(f"chord tolerance must be > 0 mm, got {chord}")
    P = np.asarray(points, dtype=np.float64)
    N = np.asarray(normals, dtype=np.float64)
    if closed:
        if start is None:
            start = int(np.argmax(P[:, 2]))
        P = np.roll(P, -start, axis=0)
        N = np.roll(N, -start, axis=0)
    cchord = CENTRE_CHORD_SHARE * chord if centre_chord is None else float(centre_chord)
    tight = min(chord, cchord)
    max_turn = 2.0 * np.arccos(max(1.0 - tight / (4.0 * radius), -1.0)) if radius > 0 else np.pi
    D, DN, seg = densify_by_normal_turn(P, N, closed, max_turn)
    lam = np.zeros(len(D)) if lift is None else np.asarray(lift(D, DN, seg), dtype=np.float64)
    C = D + (radius + lam)[:, None] * DN
    # the exact offset of a faceted mesh lies up to ρ(1 − cos δ) outside the smooth one
    # (δ: smooth vs facet normal) and the straight move between densified centres cuts the
    # curved offset by up to a quarter of the tolerance: the centre path keeps 40 % spare
    # (0.75 let Rotor 37's tip boundary loop overcut by 1 % at e = 0.01)
    idx = forward_step_indices(D, C, chord, centre_chord=cchord, memo=memo)
    if closed:
        idx = idx[:-1]
    if return_index:
        return D[idx], DN[idx], lam[idx], idx
    return D[idx], DN[idx], lam[idx]
