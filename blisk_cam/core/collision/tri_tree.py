"""A tree of obstacle triangles (Morton order) and the refine step of
detection: the clearance of a posed tool from the triangles near it,
by beam search and golden-section steps along edges. mm.
"""

from __future__ import annotations

import math
import threading

import numpy as np

from ..kernels import collision as compiled_refine
from ..kernels.swept_cutter import cutter_profile
from ..runtime import workers
from .posed_tool import _box_bound, _Flute, _Frustum, _posed_sd, _posed_sd_grad, _posed_support

_LEAF = 8
#: children per node of the triangle tree
_BRANCH = 4
_GOLDEN_STEPS = 40
#: an edge's search stops once its convexity bound is this close to its best value, mm
_EDGE_TOL = 1e-9
_CHUNK = 1024
#: triangles refined per pose once the pose is known to penetrate (depth estimate)
_PENETRATION_PAIRS = 16
#: poses whose lower bound is this far above ds (mm) refine only _FAR_PAIRS triangles
_FAR_MARGIN = 1.0
_FAR_PAIRS = 8
_FAR_BEAM = 8
#: nodes kept per level for a pose known to penetrate (its depth is an estimate)
_DEEP_BEAM = 8
_REP_FACTOR = 4.0
_GRAD_RADIUS = 2.0
#: a compiled-built tree's numpy arrays, made when first used
_LAZY = frozenset(("A", "B", "C", "cen", "rad", "nrm", "ok", "levels", "counts"))


# ====================================================================== triangle tree
def _morton(P):
    lo, hi = P.min(0), P.max(0)
    q = ((P - lo) / np.maximum(hi - lo, 1e-12).max() * 1023).astype(np.uint64)

    def spread(x):
        x = x & np.uint64(0x3FF)
        x = (x | (x << np.uint64(16))) & np.uint64(0x30000FF)
        x = (x | (x << np.uint64(8))) & np.uint64(0x300F00F)
        x = (x | (x << np.uint64(4))) & np.uint64(0x30C30C3)
        x = (x | (x << np.uint64(2))) & np.uint64(0x9249249)
        return x

    return spread(q[:, 0]) | (spread(q[:, 1]) << np.uint64(1)) | (spread(q[:, 2]) << np.uint64(2))


class _TriTree:
    """Triangles in Morton order with an implicit binary tree of bounding spheres (see the
    module docstring)."""

    def __init__(self, V, F, owner, compiled: bool | None = None):
        """V (n, 3) float mm, F (m, 3) int triangles, owner (m,) int obstacle per
        triangle. ``compiled``: build with the compiled kernels (None: when they run) — the
        compiled detection's tree, the same as the numpy build's arrays bit for bit; the
        numpy arrays are then made (from the same order) only when first used —, False: the
        numpy build (the reference)."""
        V = np.ascontiguousarray(V, dtype=np.float64)
        if compiled is None:
            compiled = compiled_refine.build_tree_available()
        if compiled:
            self._compiled, order = compiled_refine.build_tree(V, F, workers())
            self.owner = np.asarray(owner)[order]
            self.n = len(order)
            self._lazy, self._lock = (V, F, order), threading.Lock()
            return
        cen = (V[F[:, 0]] + V[F[:, 1]] + V[F[:, 2]]) / 3.0
        order = np.argsort(_morton(cen), kind="stable")
        self._arrays(V, F, order, cen)
        self.owner = owner[order]

    def __getattr__(self, name):
        """A compiled-built tree's numpy arrays (``_LAZY``), made from its order when first
        asked for (once, whichever thread asks)."""
        if name not in _LAZY or "_lazy" not in self.__dict__:
            raise AttributeError(name)
        with self._lock:
            if self._lazy is not None:
                V, F, order = self._lazy
                self._arrays(V, F, order, (V[F[:, 0]] + V[F[:, 1]] + V[F[:, 2]]) / 3.0)
                self._lazy = None
        return self.__dict__[name]

    def normals(self, T):
        """(k, 3) unit normals of triangles T (k,)."""
        if self.__dict__.get("_lazy") is not None:
            return compiled_refine.tree_normals(self._compiled, T)
        return self.nrm[T]

    def _arrays(self, V, F, order, cen):
        """The tree's arrays from the triangles' Morton ``order`` and centroids ``cen`` (m, 3)
        (in F's order)."""
        Fo = F[order]
        self.A, self.B, self.C = V[Fo[:, 0]], V[Fo[:, 1]], V[Fo[:, 2]]
        self.cen = cen[order]
        r2 = None
        for x in (self.A, self.B, self.C):
            e = x - self.cen
            q = np.einsum("ij,ij->i", e, e)
            r2 = q if r2 is None else np.maximum(r2, q)
        self.rad = np.sqrt(r2)
        n = len(self.A)
        self.n = n
        lo = np.minimum(np.minimum(self.A, self.B), self.C)
        hi = np.maximum(np.maximum(self.A, self.B), self.C)
        starts = np.arange(0, n, _LEAF)
        llo = np.minimum.reduceat(lo, starts, axis=0)
        lhi = np.maximum.reduceat(hi, starts, axis=0)
        rep = self.cen[starts]
        levels = [(llo, lhi, rep)]
        while len(levels[-1][0]) > 1:
            lo_, hi_, rp = levels[-1]
            s = np.arange(0, len(lo_), _BRANCH)  # a node's children: _BRANCH consecutive
            levels.append((np.minimum.reduceat(lo_, s, axis=0),
                           np.maximum.reduceat(hi_, s, axis=0), rp[s]))
        levels = levels[::-1]  # root first
        self.levels = [(0.5 * (lo_ + hi_), 0.5 * np.linalg.norm(hi_ - lo_, axis=1), rp,
                        0.5 * (hi_ - lo_)) for lo_, hi_, rp in levels]
        self.counts = [len(x[0]) for x in self.levels]
        u, v = self.B - self.A, self.C - self.A
        nrm = np.empty_like(u)  # u × v (np.cross is several times slower)
        nrm[:, 0] = u[:, 1] * v[:, 2] - u[:, 2] * v[:, 1]
        nrm[:, 1] = u[:, 2] * v[:, 0] - u[:, 0] * v[:, 2]
        nrm[:, 2] = u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]
        ln = np.sqrt(np.einsum("ij,ij->i", nrm, nrm))
        self.ok = ln > 1e-14 * np.maximum(self.rad, 1e-300) ** 2
        self.nrm = nrm / np.where(ln > 0, ln, 1.0)[:, None]

    def candidates(self, part, tips, axes, ub, pid=None, far=np.inf):
        """(query index, triangle index, centroid distance) of the pairs that may hold the
        part's minimum over the tree's triangles.

        ``tips``, ``axes`` (v, 3): the queries — poses expressed in the tree's frame (a
        neighbour blade is queried with the pose turned back onto the blade, see
        :class:`CollisionScene`); ``pid`` (v,) the pose of each query (default: the query
        itself), indexing ``ub`` (m,), which is lowered in place to upper bounds of the poses'
        clearances (shared by all queries of a pose). Returns (P (k,) query index, T (k,)
        triangle index, sdc (k,) the part's signed distance at T's centroid).

        Two beams (best-first by a bound, then cut to a fixed width per query and level):

        * a pose whose nodes all have lower bounds ≥ ``far`` (mm; certainly clear) keeps its
          ``_FAR_BEAM`` nodes with the smallest lower bound (its figure is then bounded,
          not exact);
        * a pose known to penetrate (bound < 0) keeps its ``_DEEP_BEAM`` nodes with the
          deepest representative point (a node's representative is its first child's, so
          the node that gave the bound stays, down to the triangle whose centroid it is:
          the pose's reported clearance stays at most that bound)."""
        m = len(tips)
        if pid is None:
            pid = np.arange(m)
        P = np.arange(m)
        N = np.zeros(m, dtype=np.int64)
        beam = np.isfinite(far)
        grad = hasattr(part, "sd_grad_rz")
        for li, (c, r, rep, h) in enumerate(self.levels):
            t, a = tips[P], axes[P]
            if grad and r[0] < _GRAD_RADIUS:
                lb = _box_bound(part, c[N], t, a, r[N], h[N])
            else:
                lb = _posed_sd(part, c[N], t, a) - r[N]
            keep = lb <= ub[pid[P]]
            P, N, t, a = P[keep], N[keep], t[keep], a[keep]
            if len(P) == 0:
                return P, N, np.zeros(0), np.zeros(0)
            lb = lb[keep]
            depth = None
            if r[0] < _REP_FACTOR * part.rmax + 8.0:  # nodes small enough for their points to help
                srep = _posed_sd(part, rep[N], t, a)
                np.minimum.at(ub, pid[P], srep)
                keep = lb <= ub[pid[P]]
                P, N, lb, srep = P[keep], N[keep], lb[keep], srep[keep]
                depth = srep
            if beam and len(P) > _DEEP_BEAM * 4:
                starts, sizes = _groups(P)  # P stays grouped by query (sorted)
                deep = ub[pid[P[starts]]] < 0
                width = np.where(deep, _DEEP_BEAM,
                                 np.where(np.minimum.reduceat(lb, starts) >= far, _FAR_BEAM, 0))
                cut = (width > 0) & (sizes > width)
                if np.any(cut):
                    P, N = _beam(P, N, lb, depth, ub[pid[P]], sizes, cut, deep, width)
            if li + 1 < len(self.levels):
                nxt = self.counts[li + 1]
                P = np.repeat(P, _BRANCH)
                N = (_BRANCH * N[:, None] + np.arange(_BRANCH)).ravel()
                ok = N < nxt
                P, N = P[ok], N[ok]
        # leaves → triangles
        P = np.repeat(P, _LEAF)
        T = (_LEAF * N[:, None] + np.arange(_LEAF)).ravel()
        ok = T < self.n
        P, T = P[ok], T[ok]
        cen = self.cen[T]
        sdc, g, valid = _posed_sd_grad(part, cen, tips[P], axes[P])
        np.minimum.at(ub, pid[P], sdc)
        lb = sdc - self.rad[T]
        if g is not None:  # the tangent plane of the convex sd at the centroid, over T
            lin = np.minimum(np.minimum(np.einsum("ij,ij->i", g, self.A[T] - cen),
                                        np.einsum("ij,ij->i", g, self.B[T] - cen)),
                             np.einsum("ij,ij->i", g, self.C[T] - cen))
            lb = np.where(valid, np.maximum(lb, sdc + lin), lb)
        keep = lb <= ub[pid[P]]
        return P[keep], T[keep], sdc[keep], lb[keep]


def _beam(P, N, lb, depth, ubp, sizes, cut, deep, width):
    """Keep the ``width`` best nodes of every query group that is ``cut`` (P sorted, so the
    groups are runs; the other groups stay whole, and P stays sorted). Best: the node whose
    representative gave the pose's bound ``ubp`` first (for a deep query, the deepest
    representatives first), then the smallest lower bound ``lb``."""
    inc = np.repeat(cut, sizes)
    ci = np.nonzero(inc)[0]
    key = lb[ci]
    if depth is not None:
        dq = depth[ci]
        key = np.where(np.repeat(deep, sizes)[ci], np.where(dq < 0, dq - 1e3, key),
                       np.where(dq <= ubp[ci] + 1e-12, -2e3, key))
    kmin = key.min()
    span = float(key.max() - kmin) + 1.0
    ci = ci[np.argsort(P[ci] * span + (key - kmin))]  # one float key: group, then key
    cs, csz = _groups(P[ci])
    rank = np.arange(len(ci)) - np.repeat(cs, csz)
    keep = ~inc
    keep[ci[rank < np.repeat(width[cut], csz)]] = True
    return P[keep], N[keep]


def _groups(P):
    """(starts, sizes) of the runs of equal values in the non-empty sorted array P."""
    starts = np.concatenate([[0], np.flatnonzero(P[1:] != P[:-1]) + 1])
    return starts, np.diff(np.append(starts, len(P)))


def _inside_tri(q, A, B, C, n):
    def side(p0, p1):
        return np.einsum("ij,ij->i", np.cross(p1 - p0, q - p0), n)

    return (side(A, B) >= 0) & (side(B, C) >= 0) & (side(C, A) >= 0)


def _edge_minima(part, E0, D, t, a, f0, f1, P, ub, tol=_EDGE_TOL):
    """Minimum of the posed part's signed distance along each edge E0 + x D, x ∈ [0, 1]
    (arrays per edge, (k, 3); f0, f1 (k,) the values at the ends), by golden section on
    the convex function, with the convexity bound of the bracket: the secant through the
    two probes, extended, bounds f below outside them, and the secants through each probe
    and its bracket end bound it between them. An edge stops once that lower bound is
    above its pose's upper bound ``ub[P]`` (it cannot hold the pose's minimum; ``ub`` (m,)
    is lowered in place by the values found) or within ``tol`` (mm) of its best value,
    at most ``_GOLDEN_STEPS`` steps (0.618⁴⁰ ≈ 4·10⁻⁹ of the edge).

    Returns (value (k,), x (k,)) — the best value found and where; an edge stopped by the
    bound returns a value ≥ its minimum that is above its pose's final minimum."""
    k = len(E0)
    val = np.minimum(f0, f1)
    xv = np.where(f0 <= f1, 0.0, 1.0)
    g = _GOLDEN
    lo, hi = np.zeros(k), np.ones(k)
    flo, fhi = f0.copy(), f1.copy()
    x1, x2 = np.full(k, 1.0 - g), np.full(k, g)
    v1 = _posed_sd(part, E0 + x1[:, None] * D, t, a)
    v2 = _posed_sd(part, E0 + x2[:, None] * D, t, a)
    idx = np.arange(k)
    for step in range(_GOLDEN_STEPS + 1):
        left = v1 <= v2
        up = np.where(left, v1, v2)
        xu = np.where(left, x1, x2)
        better = up < val[idx]
        val[idx[better]] = up[better]
        xv[idx[better]] = xu[better]
        np.minimum.at(ub, P[idx], up)
        # convexity lower bound of f over [lo, hi]
        s12 = (v2 - v1) / (x2 - x1)
        b_left = np.minimum(v1, v1 - s12 * (x1 - lo))
        b_right = np.minimum(v2, v2 + s12 * (hi - x2))
        sa = (v1 - flo) / (x1 - lo)
        sb = (fhi - v2) / (hi - x2)
        den = sa - sb
        xi = np.clip((v2 - sb * x2 - v1 + sa * x1) / np.where(den != 0, den, 1.0), x1, x2)
        mid = np.minimum(np.minimum(np.maximum(v1, v2 + sb * (x1 - x2)),
                                    np.maximum(v1 + sa * (x2 - x1), v2)),
                         np.where(den != 0, np.maximum(v1 + sa * (xi - x1), v2 + sb * (xi - x2)),
                                  np.inf))
        bound = np.minimum(np.minimum(b_left, b_right), mid)
        go = (bound <= ub[P[idx]]) & (val[idx] - bound > tol)
        if step == _GOLDEN_STEPS or not np.any(go):
            break
        if not np.all(go):
            idx, lo, hi, flo, fhi, x1, x2, v1, v2, left = (
                z[go] for z in (idx, lo, hi, flo, fhi, x1, x2, v1, v2, left))
        # left: [lo, x2] keeps x1 as its upper probe; right: [x1, hi] keeps x2 as its lower
        hi, fhi = np.where(left, x2, hi), np.where(left, v2, fhi)
        lo, flo = np.where(left, lo, x1), np.where(left, flo, v1)
        nx1 = hi - g * (hi - lo)
        nx2 = lo + g * (hi - lo)
        xn = np.where(left, nx1, nx2)
        fn = _posed_sd(part, E0[idx] + xn[:, None] * D[idx], t[idx], a[idx])
        x1, v1, x2, v2 = (np.where(left, nx1, x2), np.where(left, fn, v2),
                          np.where(left, x1, nx2), np.where(left, v1, fn))
    return val, xv


_GOLDEN = 0.5 * (math.sqrt(5.0) - 1.0)


def _part_spec(part):
    """The floats describing ``part`` to the compiled refine (a flute: its cutter's profile,
    support constants and length; a frustum: z0, r0, z1, r1), None for another part."""
    if isinstance(part, _Frustum):
        return (1.0, part.z0, part.r0, part.z1, part.r1)
    if isinstance(part, _Flute):
        cu, g = part.cutter, part._g
        return (0.0, *cutter_profile(cu), cu.e, cu.r, cu.f, g["th_lo"], g["th_hi"], *g["T"], cu.h)
    return None


# long on purpose: the bounded-error distance refinement of candidate pairs in one vectorised loop
def _refine(part, A, B, C, nrm, ok, tip, axis, P=None, ub=None):
    """Exact minimum (k,) of the posed part's signed distance over triangles (A, B, C), and
    the (k, 3) triangle point where it is taken (module docstring).

    With ``P`` (k,) pose index per pair and ``ub`` (m,) upper bounds of the poses'
    clearances (lowered in place), work that cannot beat a pose's bound is skipped: cheap
    candidates first (vertices, the interior), then only the edges whose Lipschitz lower
    bound (f0 + f1 − L) / 2 reaches the bound are searched, and after 12 golden steps only
    those whose bracket bound max(f1, f2) − (hi − lo) L still does. A pair so skipped
    returns a value ≥ its true minimum that is above the pose's final minimum."""
    k = len(A)
    if P is None:
        P = np.arange(k)
        ub = np.full(k, np.inf)
    spec = _part_spec(part) if compiled_refine.available() else None
    if spec is not None and k:
        best, where, ub[:] = compiled_refine.refine_pairs(spec, A, B, C, nrm, ok, tip, axis, P,
                                                          ub, workers())
        return best, where
    best = np.full(k, np.inf)
    where = np.zeros((k, 3))

    def offer(val, pts, sel=None):
        nonlocal best, where
        if sel is None:
            better = val < best
            best = np.where(better, val, best)
            where = np.where(better[:, None], pts, where)
        else:  # sel may repeat a pair (its three edges): the smallest value per pair
            order = np.lexsort((val, sel))
            first = np.ones(len(order), bool)
            first[1:] = sel[order][1:] != sel[order][:-1]
            o = order[first]
            better = val[o] < best[sel[o]]
            best[sel[o][better]] = val[o][better]
            where[sel[o][better]] = pts[o][better]

    fv = [_posed_sd(part, X, tip, axis) for X in (A, B, C)]
    for X, f in zip((A, B, C), fv, strict=True):
        offer(f, X)
    # interior: support points along ±n
    n = nrm
    ym = _posed_support(part, -n, tip, axis)
    yp = _posed_support(part, n, tip, axis)
    hm = np.einsum("ij,ij->i", ym - A, n)
    hp = np.einsum("ij,ij->i", yp - A, n)
    above = ok & (hm > 0)
    q = ym - hm[:, None] * n
    hit = above & _inside_tri(q, A, B, C, n)
    offer(np.where(hit, hm, np.inf), q)
    below = ok & (hp < 0)
    q = yp - hp[:, None] * n
    hit_b = below & _inside_tri(q, A, B, C, n)
    offer(np.where(hit_b, -hp, np.inf), q)
    # the part on one side of T's plane: its distance to the plane bounds sd over all of T
    # (edges included); with the foot inside T that bound is T's minimum itself
    plane_lb = np.where(above, hm, np.where(below, -hp, -np.inf))
    solved = hit | hit_b
    cuts = np.nonzero(ok & ~above & ~below)[0]
    if len(cuts):
        c_ = cuts
        Ac, Bc, Cc, nc, tc, ac = A[c_], B[c_], C[c_], n[c_], tip[c_], axis[c_]
        w = -hm[c_] / np.where(hp[c_] - hm[c_] > 0, hp[c_] - hm[c_], 1.0)
        q = ym[c_] + w[:, None] * (yp[c_] - ym[c_])
        hit = _inside_tri(q, Ac, Bc, Cc, nc)
        offer(np.where(hit, _posed_sd(part, q, tc, ac), np.inf), q, c_)
        # penetration candidates: where the axis line crosses the plane, and the feet on the
        # plane of the axis points at the part's bottom, middle and top, inside T
        na = np.einsum("ij,ij->i", nc, ac)
        good = np.abs(na) > 1e-9
        tl = np.einsum("ij,ij->i", Ac - tc, nc) / np.where(good, na, 1.0)
        q = tc + tl[:, None] * ac
        hit = good & _inside_tri(q, Ac, Bc, Cc, nc)
        offer(np.where(hit, _posed_sd(part, q, tc, ac), np.inf), q, c_)
        for zz in (part.z0, 0.5 * (part.z0 + part.z1), part.z1):
            M = tc + zz * ac
            q = M - np.einsum("ij,ij->i", M - Ac, nc)[:, None] * nc
            hit = _inside_tri(q, Ac, Bc, Cc, nc)
            offer(np.where(hit, _posed_sd(part, q, tc, ac), np.inf), q, c_)
    np.minimum.at(ub, P, best)
    # edges: golden section on the convex sd along each edge, pruned by the bounds
    E0 = np.vstack([A, B, C])
    D = np.vstack([B, C, A]) - E0
    F0 = np.concatenate(fv)
    F1 = np.concatenate([fv[1], fv[2], fv[0]])
    L = np.linalg.norm(D, axis=1)
    PP = np.tile(P, 3)
    lb3 = np.maximum(0.5 * (F0 + F1 - L), np.tile(plane_lb, 3))
    act = np.nonzero((lb3 <= ub[PP]) & ~np.tile(solved, 3))[0]
    if len(act):
        val, x = _edge_minima(part, E0[act], D[act], np.tile(tip, (3, 1))[act],
                              np.tile(axis, (3, 1))[act], F0[act], F1[act], PP[act], ub)
        pair = np.tile(np.arange(k), 3)[act]
        offer(val, E0[act] + x[:, None] * D[act], pair)
    np.minimum.at(ub, P, best)
    return best, where
