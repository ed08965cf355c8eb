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

from .errors import ToleranceError

__all__ = ["densify_by_normal_turn", "forward_step_indices", "sample_polyline"]

#: share of the chord tolerance the ball-centre path may use between poses
CENTRE_CHORD_SHARE = 0.6


def _unit(v):
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(n > 0, n, 1.0)


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
    """
    P = np.asarray(points, dtype=np.float64)
    N = _unit(np.asarray(normals, dtype=np.float64))
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
    th = ang[seg]
    sin_th = np.sin(th)
    small = sin_th < 1e-9
    with np.errstate(divide="ignore", invalid="ignore"):
        wa = np.where(small, 1.0 - u, np.sin((1.0 - u) * th) / sin_th)
        wb = np.where(small, u, np.sin(u * th) / sin_th)
    n = _unit(wa[:, None] * n0[seg] + wb[:, None] * n1[seg])
    return np.vstack([p, P[-1:]]), np.vstack([n, N[-1:]]), np.append(seg, len(n0) - 1)


_einsum = np.einsum
_max_reduce = np.maximum.reduce


def _max_dev(X, i, j):
    """Largest distance of points i+1..j-1 of X to the segment X[i] X[j], for the stacked
    point sets of X (k, p, 3) at once (p = 2: the CC and the centre polylines). (p,) float."""
    if j - i < 2:
        return np.zeros(X.shape[1])
    a = X[i]
    q = X[i + 1 : j] - a  # (w, p, 3)
    ab = X[j] - a  # (p, 3)
    # einsum dot products (the same sums, one call each): this runs ~10 times per pose
    L2 = _einsum("pj,pj->p", ab, ab)
    t = _einsum("wpj,pj->wp", q, ab) / np.where(L2 > 0, L2, 1.0)
    np.maximum(t, 0.0, out=t)
    np.minimum(t, 1.0, out=t)
    d = q - t[:, :, None] * ab
    return np.sqrt(_max_reduce(_einsum("wpj,wpj->wp", d, d), axis=0))


def forward_step_indices(P, C, chord: float, max_step: float | None = None,
                         centre_chord: float | None = None, *, memo: dict | None = None):
    """Greedy forward step: indices of P to keep so that every skipped point lies within
    ``chord`` of its straight move, for the CC points ``P`` and the centres ``C`` alike.

    The first and last index are always kept. From each kept point an exponential search
    (starting at the previous step, which is usually close) then a bisection find the
    farthest admissible point (the tolerance is checked at the chosen point, so the result
    always satisfies it).

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
    X = np.stack([np.asarray(P, dtype=np.float64), np.asarray(C, dtype=np.float64)], axis=1)
    k = len(X)
    last = k - 1
    keep = [0]
    i = 0
    old, unchanged_to = {}, None
    key = (tol_p, tol_c, max_step)
    if memo is not None and memo.get("key") == key and memo.get("X", X[:0]).shape == X.shape:
        old = memo["trace"]
        # unchanged_to[j]: number of changed points before j
        changed = np.any(X != memo["X"], axis=(1, 2))
        unchanged_to = np.concatenate([[0], np.cumsum(changed)])
    trace = {}
    reach = [0]  # the largest end tested from the current start

    def ok(i, j):
        reach[0] = max(reach[0], j)
        if max_step is not None and np.linalg.norm(X[j, 0] - X[i, 0]) > max_step:
            return False
        dev = _max_dev(X, i, j)
        return bool(dev[0] <= tol_p) and bool(dev[1] <= tol_c)

    prev = 2
    while i < last:
        good = i + 1
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
        reach[0] = i
        bad = None
        while True:
            j = i + step
            if j >= last:
                if ok(i, last):
                    good = last
                else:
                    bad = last
                break
            if ok(i, j):
                good = j
                step *= 2
            else:
                bad = j
                break
        if bad is not None:
            lo, hi = good, bad
            while hi - lo > 1:
                mid = (lo + hi) // 2
                if ok(i, mid):
                    lo = mid
                else:
                    hi = mid
            good = lo
        trace[i] = (max(prev, 2), good, reach[0])
        keep.append(good)
        prev = good - i
        i = good
    if memo is not None:
        memo.update(key=key, X=X, trace=trace)
    return np.asarray(keep, dtype=np.int64)


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
