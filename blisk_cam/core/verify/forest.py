"""Several swept volumes of one tool queried together (one member per pass
level): point i against member ``which[i]``, in full chunks over all
members. mm.
"""

from __future__ import annotations

import numpy as np

from ..kernels import swept_ball as compiled_ball
from ..kernels import swept_cutter as compiled_cutter
from ..runtime import check_cancel, map_chunks, map_tasks, workers
from .sweep import BOX_PIECES, SweptCutter, _fast_search, _sphere_trace, searched_once
from .sweep_ball import SweptBall

__all__ = ["SweptForest", "regula_falsi"]

#: points per chunk of :class:`SweptForest`'s joint pass (its members are small: one level's
#: passes, ~30 candidate clusters per point, so bigger chunks than a whole path's pay off)
_FOREST_CHUNK = 4096


class SweptForest:
    """Swept volumes of one tool along several sets of passes (e.g. one per pass level, for
    the scallops between neighbouring levels), queried together: point i against member
    ``which[i]``.

    When every member is a "fast" :class:`SweptCutter` of the same cutter, the queries of
    all members run as one chunked pass: the points sorted by member, cut into chunks of
    ``chunk`` points regardless of the members' boundaries; per chunk, step 0 (upper bound,
    candidate clusters) by each member it holds on its own trees, then steps 1–4 over all the
    chunk's (point, segment) pairs at once, on tables that hold every member's segments and
    clusters (:func:`_fast_search`). The verify of a bull-nose path asks ~50 per-level
    volumes for one to ten thousand points each, several times over (ridge ends, the regula
    falsi steps, the sphere tracing of the scallop heights): one pass over full chunks
    replaces hundreds of small ones and chunk tails, whose cost was Python/numpy overhead
    per call. Each point's figures are its member's, bit for bit: they depend on the point's
    own bound and candidates only. (How many points share a chunk decides how a member's
    tree is walked — every leaf tested at once for a few points, a descent otherwise — and
    the flat test can return a few more clusters, whose ancestors' bounds miss the radius:
    their segments cannot come within it, so they never change a value; the per-level
    queries' chunk tails took the flat test before too.)

    :class:`SweptBall` members of one radius with compiled trees (``balls``) are asked in one
    compiled call: the points sorted by member, runs of each member's points sharing the
    threads (one call per level, five times over: ~260 calls on Rotor 37, each with its
    Python and thread-pool overhead and a thread idle at its end); each point's figures are
    its member's own. Other members (numpy balls, the "exact" method) are asked member by
    member, one task each (:func:`..runtime.map_tasks`), each with its points in the order
    given.

    Parameters
    ----------
    members : list of SweptCutter or SweptBall
    chunk : int — points per chunk of the joint pass
    """

    def __init__(self, members, *, chunk: int = _FOREST_CHUNK):
        self.members = list(members)
        self.chunk = max(int(chunk), 1)
        ms = self.members
        live = [m for m in ms if isinstance(m, SweptCutter) and m.has_tree]
        self.fast = (bool(live) and all(isinstance(m, SweptCutter) and m.method == "fast"
                                        for m in ms)
                     and len({(repr(m.cutter.as_dict()), m.xtol) for m in live}) == 1)
        # swept balls of one radius with compiled trees: every member's queries in one call
        self.balls = (bool(ms) and all(isinstance(m, SweptBall) for m in ms)
                      and len({m.radius for m in ms}) == 1 and compiled_ball.forest_available()
                      and all(m._ctree is not None or len(m.a) == 0 for m in ms))
        if not self.fast:
            return
        self.cutter, self.xtol = live[0].cutter, live[0].xtol
        has = np.array([m.has_tree for m in ms])
        nseg = np.array([len(m.ta) for m in ms], dtype=np.int64)
        ncl = np.array([len(m._ls) if m.has_tree else 0 for m in ms], dtype=np.int64)
        self._has = has
        self._ncl = ncl
        self._cboxes = None
        self._so = np.cumsum(nseg) - nseg  # first segment of each member in the tables
        self._co = np.cumsum(ncl) - ncl  # first cluster of each member
        self._slk = np.array([m._slack if m.has_tree else 0.0 for m in ms])

        def cat(name):
            return np.concatenate([getattr(m, name) for m in live])

        self.ta, self.tb, self._k, self._b, self._chord_ok = (
            cat(n) for n in ("ta", "tb", "_k", "_b", "_chord_ok"))
        self._lt, self._la, self._lphi, self._ldt = (
            cat(n) for n in ("_lt", "_la", "_lphi", "_ldt"))
        self._ls = np.concatenate([np.where(m._ls >= 0, m._ls + so, -1)
                                   for m, so in zip(ms, self._so, strict=True)
                                   if m.has_tree])

    def __len__(self):
        return len(self.members)

    def __getitem__(self, j):
        """Member ``j`` (a per-level query of its own, e.g. a ball's listed segments)."""
        return self.members[j]

    def _which(self, which, k):
        w = np.asarray(which, dtype=np.int64).reshape(-1)
        if len(w) != k:
            raise ValueError(f"which must give one member per point: {len(w)} for {k} points")
        if len(w) and (w.min() < 0 or w.max() >= len(self.members)):
            raise ValueError(f"which must name members 0..{len(self.members) - 1}, got "
                             f"{int(w.min())}..{int(w.max())}")
        return w

    def per_member(self, w, ask):
        """``ask(member, rows)`` for every member holding queries, one task each (the
        fallback of the joint pass, and a member's own queries such as a ball's
        :meth:`SweptBall.near`): ``w`` (k,) the member of each query; each member's rows
        ascending, from one stable sort of ``w``; [(rows, result or None)] in member
        order."""
        order = np.argsort(w, kind="stable")
        start = np.searchsorted(w[order], np.arange(len(self.members) + 1))

        def one(j):
            rows = order[start[j] : start[j + 1]]
            return (rows, ask(self.members[j], rows)) if len(rows) else (rows, None)

        return map_tasks(one, range(len(self.members)))

    def nearest(self, points, which, near=None):
        """Signed distance (k,) from points (k, 3) to the swept volume of member ``which``
        (k,) each, and the nearest segment (k,) (numbered in the member, −1 where none).

        ``near`` (k, 3), optional, for :class:`SweptBall` members only: where each point's
        nearest centres are likely (:meth:`SweptBall.nearest`; the same result)."""
        P = np.ascontiguousarray(np.asarray(points, dtype=np.float64).reshape(-1, 3))
        k = len(P)
        w = self._which(which, k)
        if self.balls:  # compiled balls: the guesses are not needed (the same result)
            out = np.full(k, np.inf)
            arg = np.full(k, -1, dtype=np.int64)
            rows, trees, start = self._ball_rows(w)
            if len(rows):
                # (rows gathered by take: ~3x faster than fancy indexing)
                d2, seg = compiled_ball.forest_nearest(trees, P.take(rows, axis=0), start,
                                                       workers())
                out[rows], arg[rows] = np.sqrt(d2) - self.members[0].radius, seg
            return out, arg
        if not self.fast:
            out = np.full(k, np.inf)
            arg = np.full(k, -1, dtype=np.int64)
            if near is None:
                def ask(m, rows):
                    return m.nearest(P[rows])
            else:
                G = np.asarray(near, dtype=np.float64).reshape(-1, 3)

                def ask(m, rows):
                    return m.nearest(P[rows], near=G[rows])
            for rows, res in self.per_member(w, ask):
                if res is not None:
                    out[rows], arg[rows] = res
            return out, arg
        if near is not None:
            raise ValueError("near is for swept balls: a swept cutter finds its own "
                             "candidates")
        # a (point, member) asked more than once is searched once: a point's figures are a
        # function of its coordinates and member alone (class docstring), and the scallops'
        # callers repeat ~1 query in 5 (grid samples shared by rows, the ridges' ends and
        # regula falsi iterates met again)
        return searched_once(P, w, self._nearest_fast)

    def ridge_steps(self, xa, xb, ga, gb, lo, steps):
        """Compiled balls (``balls``): the regula falsi of :func:`.measure._ridge_points`,
        ``steps`` steps of every edge from ``xa`` to ``xb`` (k, 3) (g = d_lo − d_hi ``ga``,
        ``gb`` at the ends, levels ``lo`` and ``lo`` + 1 (k,)) in one compiled call, with its
        arithmetic: (last iterates (k, 3), their distances to the two levels (k,), (k,)).
        None otherwise (the caller steps in numpy)."""
        if not self.balls:
            return None
        check_cancel()
        return compiled_ball.ridge_steps([m._ctree for m in self.members], xa, xb, ga, gb, lo,
                                         self.members[0].radius, max(int(steps), 1),
                                         workers())

    def _ball_rows(self, w):
        """The compiled balls' joint query of points of members ``w`` (k,): (the rows whose
        member has segments, sorted by member (stable), the members' trees, the offsets of
        each tree's rows in that order (trees + 1,))."""
        check_cancel()  # one call for every member: checked before it
        has = np.array([m._ctree is not None for m in self.members])
        # the same stable order; small ints sort by radix (~4x faster than int64's merge)
        order = np.argsort(w.astype(np.int16) if len(has) < 2**15 else w, kind="stable")
        rows = order[has[w[order]]]
        trees = [m._ctree for m in self.members if m._ctree is not None]
        tid = np.cumsum(has) - 1  # the tree of each member that has one
        start = np.zeros(len(trees) + 1, dtype=np.int64)
        np.cumsum(np.bincount(tid[w[rows]], minlength=len(trees)), out=start[1:])
        return rows, trees, start

    def _nearest_fast(self, P, w):
        """:meth:`nearest` of distinct (point, member) rows by the fast joint pass."""
        k = len(P)
        out = np.full(k, np.inf)
        arg = np.full(k, -1, dtype=np.int64)
        # the same stable order as :meth:`_ball_rows` (int16 members sort by radix)
        order = np.argsort(w.astype(np.int16) if len(self.members) < 2**15 else w,
                           kind="stable")
        sel = order[self._has[w[order]]]  # members without segments: inf, −1
        Ps, ws = P[sel], w[sel]
        ds = np.empty(len(sel))
        gs = np.empty(len(sel), dtype=np.int64)
        ch = self.chunk

        def one(s0):
            ds[s0 : s0 + ch], gs[s0 : s0 + ch] = self._chunk(Ps[s0 : s0 + ch], ws[s0 : s0 + ch])

        map_chunks(one, len(sel), ch)
        out[sel] = ds
        arg[sel] = np.where(gs >= 0, gs - self._so[ws], -1)
        return out, arg

    def _chunk(self, Pc, wc, delta: float = 1e-6):
        """Points ``Pc`` (k, 3) of members ``wc`` (k,, sorted): step 0 member by member,
        steps 1–4 at once. (distance (k,), segment in the joint tables (k,))."""
        kc = len(Pc)
        starts = np.flatnonzero(np.concatenate([[True], wc[1:] != wc[:-1]]))
        ends = np.append(starts[1:], kc)
        u = np.empty(kc)
        arg = np.empty(kc, dtype=np.int64)
        qs, ls = [], []
        boxes = compiled_cutter.boxes_available()
        for s, e in zip(starts, ends, strict=True):
            j = int(wc[s])
            m = self.members[j]
            uj, aj = m._upper_bound(Pc[s:e])
            u[s:e] = uj
            arg[s:e] = np.where(aj >= 0, aj + self._so[j], -1)
            if not boxes:
                qj, lj = m._candidate_clusters(Pc[s:e], uj)
                qs.append(qj + s)
                ls.append(lj + self._co[j])
        if boxes:  # the candidates and steps 1–4 compiled
            if self._cboxes is None:
                lo, hi = zip(*(m._leaf_box_arrays() for m in self.members
                               if m.has_tree), strict=True)
                self._cboxes = compiled_cutter.leaf_boxes(np.concatenate(lo),
                                                          np.concatenate(hi),
                                                          self._co[self._has], BOX_PIECES)
            return compiled_cutter.fast_search_boxes(
                self.cutter, self, self._cboxes, Pc, u, arg, self._slk[wc], self._co[wc],
                self._co[wc] + self._ncl[wc], self.xtol, delta, workers())
        return _fast_search(self, Pc, u, arg, np.concatenate(qs), np.concatenate(ls),
                            self._slk[wc], self.xtol, delta)

    def distance(self, points, which, near=None):
        """(k,) signed distance (mm) from points to their members' swept volumes (``near``:
        see :meth:`nearest`)."""
        return self.nearest(points, which, near)[0]

    def height_along(self, points, directions, max_height, which, steps: int = 60):
        """:meth:`SweptCutter.height_along` (or the member's own) of every point against its
        member ``which`` (k,): (k,) mm, ``inf`` where there is no hit within ``max_height``.
        The sphere tracing of all members advances together, one joint query per step."""
        P = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        N = np.asarray(directions, dtype=np.float64).reshape(-1, 3)
        w = self._which(which, len(P))
        hmax = np.broadcast_to(np.asarray(max_height, float), (len(P),)).copy()
        if self.balls:
            t = np.full(len(P), np.inf)
            rows, trees, start = self._ball_rows(w)
            if len(rows):
                t[rows] = compiled_ball.forest_first_hits(
                    trees, P.take(rows, axis=0), N.take(rows, axis=0),
                    self.members[0].radius, hmax[rows], start,
                    workers())
            return t
        if not self.fast:
            t = np.full(len(P), np.inf)
            for rows, h in self.per_member(
                    w, lambda m, rows: m.height_along(P[rows], N[rows], hmax[rows])):
                if h is not None:
                    t[rows] = h
            return t
        return _sphere_trace(lambda X, idx: self.distance(X, w[idx]), P, N, hmax, steps)


def regula_falsi(xa, xb, ga, gb, steps, distances):
    """The regula falsi (Illinois) of verify's scallop ridges (``measure._ridge_points``) in
    numpy — the reference of the compiled balls' :meth:`SweptForest.ridge_steps`, operation
    for operation: edge i from ``xa`` to ``xb`` (k, 3) mm with g = d_lo − d_hi ``ga``, ``gb``
    (k,) at its ends; each of ``steps`` steps takes t = (ta gb − tb ga) / (gb − ga), the
    point x = xa + t (xb − xa) and ``distances(x, step)`` → (d_lo, d_hi) (k,) mm, its
    distances to the edge's two levels, then keeps the end whose g has the other sign,
    halving the kept end's g when the same end is replaced twice running. Returns the last
    iterates and their distances (x (k, 3), d_lo (k,), d_hi (k,))."""
    ta, tb = np.zeros(len(xa)), np.ones(len(xa))
    last = np.zeros(len(xa), dtype=np.int8)  # which end was replaced last
    for i in range(max(int(steps), 1)):
        t = (ta * gb - tb * ga) / (gb - ga)
        x = xa + t[:, None] * (xb - xa)
        la, lb = distances(x, i)
        gx = la - lb
        repl_a = np.sign(gx) == np.sign(ga)
        ga = np.where(~repl_a & (last == 2), 0.5 * ga, ga)
        gb = np.where(repl_a & (last == 1), 0.5 * gb, gb)
        ta, ga = np.where(repl_a, t, ta), np.where(repl_a, gx, ga)
        tb, gb = np.where(repl_a, tb, t), np.where(repl_a, gb, gx)
        last = np.where(repl_a, 1, 2).astype(np.int8)
    return x, la, lb
