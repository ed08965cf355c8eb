"""A bounding-volume tree over clusters of primitives (median splits, sphere
and oriented-box bounds) with chunked nearest and within-range queries
in packets; the distance classes of :mod:`.distance` and the swept
volumes of ``verify`` build on it. Lengths in mm.
"""

from __future__ import annotations

import numpy as np

from ..runtime import map_chunks

CHUNK = 2048  # queries per chunk in tree traversals (the frontier stays in cache: 16384
#                 ran 1.5–2× slower on Rotor 37's verify, bench/bench_verify.py)

_FLAT_PAIRS = 8192  # (query, leaf) pairs below which a tree query tests all leaves at once

# packet traversal (:meth:`ClusterTree.leaf_pairs`): queries per group, levels walked per query at
# the bottom of the tree, fewest queries for which groups are formed
_GROUP, _GROUP_TAIL, GROUP_MIN = 8, 0, 256


# ================================================================== bounding-volume tree
def _median_slots(cen, size):
    """Recursive median splits of points along the longest extent (vectorised, level by
    level) into 2^L groups of ``size`` slots. Returns (slots (2^L, size) ids, −1 padded; L)."""
    m = len(cen)
    nleaf = max(1, -(-m // size))
    L = int(np.ceil(np.log2(nleaf))) if nleaf > 1 else 0
    NS = (1 << L) * size
    # one contiguous array per coordinate: the per-segment extents are then reductions along
    # contiguous rows (3-4x faster than over (nseg, seglen, 3) blocks; the same values)
    keys = []
    for j in range(3):
        k = np.full(NS, np.inf)
        k[:m] = cen[:, j]
        keys.append(k)
    order = np.arange(NS)
    for level in range(L):
        nseg = 1 << level
        seglen = NS >> level
        cs = [k[order].reshape(nseg, seglen) for k in keys]
        fin = np.isfinite(cs[0])
        lo = np.stack([np.min(x, axis=1, where=fin, initial=np.inf) for x in cs], axis=1)
        hi = np.stack([np.max(x, axis=1, where=fin, initial=-np.inf) for x in cs], axis=1)
        ext = np.where(np.isfinite(hi - lo), hi - lo, -1.0)
        ax = np.argmax(ext, axis=1)[:, None]
        key = np.where(ax == 0, cs[0], np.where(ax == 1, cs[1], cs[2]))
        part = np.argpartition(key, seglen // 2 - 1, axis=1)
        order = np.take_along_axis(order.reshape(nseg, seglen), part, axis=1).reshape(-1)
    return np.where(order < m, order, -1).reshape(-1, size), L


def run_clusters(breaks, m, size):
    """Clusters of up to ``size`` consecutive primitives, never across ``breaks`` (sorted
    start indices of runs, e.g. the first segment of each curve). (n, size) ids, −1 padded."""
    starts = np.unique(np.concatenate([[0], np.asarray(breaks, dtype=np.int64)]))
    starts = starts[starts < m]
    ends = np.append(starts[1:], m)
    nper = -(-(ends - starts) // size)
    rank = np.arange(nper.sum()) - np.repeat(np.cumsum(nper) - nper, nper)
    first = np.repeat(starts, nper) + size * rank
    last = np.repeat(ends, nper)
    ids = first[:, None] + np.arange(size)
    return np.where(ids < last[:, None], ids, -1)


class ClusterTree:
    """A complete binary bounding-volume tree over clusters of primitives.

    The clusters (leaves) are split at the median of their centroids along the longest
    extent, level by level (vectorised). Every node stores an axis-aligned box and an
    oriented cylinder (axis = the smallest principal direction of the node's points for
    surfaces, the largest for curves) containing the node's points; a node is visited only
    if both bounds come within the search radius. Queries are breadth-first, vectorised over
    (query, node) pairs. A k-d tree of the primitives' centroids gives nearest queries a
    first upper bound.

    Parameters
    ----------
    corners : (m, c, 3) float — the corner points of each (convex) primitive
    flat : bool — True for surface patches (cylinder along the normal), False for curves
    clusters : (n, B) int — primitive ids of each leaf, −1 padded; default median splits
    leaf_size : int — B when ``clusters`` is not given
    discs : (axes (m, 2, 3), phi (m,), radius) or None — widen the bounds for a disc of
        ``radius`` ⟂ the axis at every point of each primitive, the axis turning on the great
        arc from axes[:, 0] to axes[:, 1] (angle phi): along a unit direction w such a disc
        reaches radius · sin∠(w, axis), and sin∠(w, axis(t)) ≤ (sin∠(w, a₀) + sin∠(w, a₁) +
        φ)/2 on the arc (the angle is 1-Lipschitz in t φ); across w it reaches ≤ radius. The
        node boxes and cylinders grow by these amounts (used by :class:`SweptCutter`: a posed
        cutter lies in the cylinder of radius ``max_radius`` about its axis segment, so the
        bound below the tips is tight instead of ``max_radius``).
    disc_axis : bool — with ``discs``: every node's cylinder takes the mean disc axis of its
        primitives as its axis (instead of a principal direction) and the axis-aligned box
        is replaced by an oriented box (the mean axis, the points' principal direction across
        it, their cross product), so a node of nearly parallel discs is bounded by a flat
        puck and box — tight above and below the discs, where a principal-direction
        cylinder around a run of discs would be ``radius`` thick.
    group_tail : int — levels above the leaves where the packet traversal of many queries
        (:meth:`_group_descent`) hands over to per-query tests (speed only: the pairs are
        the same)
    leaf_obb : bool — :meth:`pairs` also tests each leaf's oriented box (its points'
        principal axes): fewer leaves, the same order
    """

    def __init__(self, corners, *, flat: bool, clusters=None, leaf_size: int = 8, discs=None,
                 disc_axis: bool = False, group_tail: int = _GROUP_TAIL, leaf_obb: bool = False):
        corners = np.asarray(corners, dtype=np.float64)
        self.group_tail = int(group_tail)
        m, nc, _ = corners.shape
        self.m = m
        pcen = corners.mean(axis=1)
        if clusters is None:
            clusters, _ = _median_slots(pcen, leaf_size)
            clusters = clusters[np.any(clusters >= 0, axis=1)]
        clusters = np.asarray(clusters, dtype=np.int64)
        B = clusters.shape[1]
        cnt = np.maximum((clusters >= 0).sum(axis=1), 1)
        ccen = np.where((clusters >= 0)[:, :, None], pcen[np.maximum(clusters, 0)], 0.0)
        ccen = ccen.sum(axis=1) / cnt[:, None]
        slots, L = _median_slots(ccen, 1)
        slot = slots[:, 0]
        NL = 1 << L
        self.L, self.NL = L, NL
        self.prims = np.where((slot >= 0)[:, None], clusters[np.maximum(slot, 0)], -1)

        # the points of each leaf; padding (absent primitives, empty leaves) repeats points of
        # the same leaf or of the previous leaf, which leaves every bound valid and tight.
        # Padding may sit in any slot (median splits leave −1 anywhere in a cluster): repeat
        # the row's first present primitive, not slot 0 — a leaf whose slot 0 was padding
        # used to be bounded by the previous leaf's points and lost its own primitives
        present = self.prims >= 0
        first = self.prims[np.arange(NL), np.argmax(present, axis=1)]  # −1 for an empty leaf
        fill = np.where(present, self.prims, first[:, None])
        empty = first < 0
        if np.any(empty):
            src = np.maximum.accumulate(np.where(~empty, np.arange(NL), -1))
            src = np.where(src >= 0, src, np.argmax(~empty))
            fill = fill[src]
        pts = corners[fill].reshape(NL, B * nc, 3)
        nn = 2 * NL
        self.lo = np.empty((nn, 3))
        self.hi = np.empty((nn, 3))
        self.c = np.zeros((nn, 3))
        self.w = np.tile([0.0, 0.0, 1.0], (nn, 1))
        self.H = np.zeros(nn)
        self.R = np.zeros(nn)
        self.lo[NL:] = pts.min(axis=1)
        self.hi[NL:] = pts.max(axis=1)
        if discs is not None:
            d_ax = np.asarray(discs[0], dtype=np.float64)[fill]  # (NL, B, 2, 3)
            d_phi = np.asarray(discs[1], dtype=np.float64)[fill]  # (NL, B)
            d_rad = float(discs[2])

            def reach(sin_a, sin_b, ph):
                return d_rad * np.minimum(1.0, 0.5 * (sin_a + sin_b + ph))

            sx = np.sqrt(np.maximum(1.0 - d_ax * d_ax, 0.0))  # sine to each coordinate axis
            ext = reach(sx[:, :, 0], sx[:, :, 1], d_phi[:, :, None]).max(axis=1)
            self.lo[NL:] -= ext
            self.hi[NL:] += ext
        for level in range(L - 1, -1, -1):
            nodes = np.arange(1 << level, 2 << level)
            self.lo[nodes] = np.minimum(self.lo[2 * nodes], self.lo[2 * nodes + 1])
            self.hi[nodes] = np.maximum(self.hi[2 * nodes], self.hi[2 * nodes + 1])
        for level in range(L + 1):
            nodes = np.arange(1 << level, 2 << level)
            X = pts.reshape(1 << level, -1, 3)
            mean = X.mean(axis=1)
            D = X - mean[:, None, :]
            _, vec = np.linalg.eigh(np.einsum("npi,npj->nij", D, D))
            wv = vec[:, :, 0] if flat else vec[:, :, 2]
            if discs is not None and disc_axis:
                ma = d_ax.reshape(1 << level, -1, 3).sum(axis=1)
                mn = np.linalg.norm(ma, axis=1)
                wv = np.where((mn > 1e-12)[:, None], ma / np.maximum(mn, 1e-300)[:, None], wv)
                self._obb_level(nodes, D, mean, wv, d_ax, d_phi, reach)
            z = np.einsum("npi,ni->np", D, wv)
            rad2 = np.einsum("npi,npi->np", D, D) - z * z
            self.c[nodes] = mean
            self.w[nodes] = wv
            self.H[nodes] = np.abs(z).max(axis=1)
            self.R[nodes] = np.sqrt(np.maximum(rad2.max(axis=1), 0.0))
            if discs is not None:
                cw = np.einsum("npki,ni->npk", d_ax.reshape(1 << level, -1, 2, 3), wv)
                sw_ = np.sqrt(np.maximum(1.0 - cw * cw, 0.0))
                ph = d_phi.reshape(1 << level, -1)
                self.H[nodes] += reach(sw_[:, :, 0], sw_[:, :, 1], ph).max(axis=1)
                self.R[nodes] += d_rad
        self.leaf_box = self._leaf_boxes(pts) if leaf_obb else None
        # bounds are computed from rounded numbers: widen them a little
        self.H += 1e-12 * (1.0 + np.abs(self.H))
        self.obb = None
        if discs is not None and disc_axis:
            half = self._obb[:, 12:15]
            self._obb[:, 12:15] = half + 1e-12 * (1.0 + np.abs(half))
            self.obb = self._obb
        self.R += 1e-12 * (1.0 + np.abs(self.R))
        self._pack()
        # upper bounds for nearest queries: the primitives with the nearest centroids
        from scipy.spatial import cKDTree  # optional: on first use (~60 ms)

        self.kd = cKDTree(pcen) if m else None
        self.kd_k = int(min(2, m))
        # a small slack for rounding in the bounds (never prunes a true candidate)
        scale = float(np.max(np.abs(corners))) if m else 1.0
        self.slack = 1e-9 * max(scale, 1.0)

    @staticmethod
    def _leaf_boxes(pts):
        """(NL, 18) per leaf [mean (3), principal axes as columns (9), low (3), high (3)
        corner of its points' box in that frame, widened for rounding]. A patch of a
        surface cut by median splits is long and narrow: the box bounds it where the
        cylinder (radius the patch's half-length) does not — Rotor 37's ball centres 6 mm off
        the surface reach 12 leaves per point through the node bounds, 6.6 through the box."""
        mean = pts.mean(axis=1)
        D = pts - mean[:, None, :]
        _, vec = np.linalg.eigh(np.einsum("npi,npj->nij", D, D))
        x = np.einsum("npi,nij->npj", D, vec)
        lo, hi = x.min(axis=1), x.max(axis=1)
        pad = 1e-9 * (1.0 + np.abs(lo) + np.abs(hi))
        return np.ascontiguousarray(np.hstack([mean, vec.reshape(-1, 9), lo - pad, hi + pad]))

    def _obb_level(self, nodes, D, mean, w2, d_ax, d_phi, reach):
        """Oriented boxes of one level's nodes (``disc_axis`` trees): axis w2 = the mean
        disc axis, w1 the principal direction of the node's points across it, w3 = w2 × w1;
        half extents = the points' extents plus the discs' reach along each direction."""
        if not hasattr(self, "_obb"):
            self._obb = np.zeros((len(self.H), 15))
        n = len(nodes)
        Dp = D - np.einsum("npi,ni->np", D, w2)[:, :, None] * w2[:, None, :]
        _, vec = np.linalg.eigh(np.einsum("npi,npj->nij", Dp, Dp))
        w1 = vec[:, :, 2]
        w1 = w1 - np.einsum("ni,ni->n", w1, w2)[:, None] * w2
        w1n = np.linalg.norm(w1, axis=1)
        alt = np.cross(w2, np.where((np.abs(w2[:, 0]) < 0.9)[:, None], [1.0, 0.0, 0.0],
                                    [0.0, 1.0, 0.0]))
        w1 = np.where((w1n > 1e-6)[:, None], w1 / np.maximum(w1n, 1e-300)[:, None],
                      alt / np.linalg.norm(alt, axis=1)[:, None])
        w3 = np.cross(w2, w1)
        ax = d_ax.reshape(n, -1, 2, 3)
        ph = d_phi.reshape(n, -1)
        half = np.empty((n, 3))
        for j, w in enumerate((w1, w2, w3)):
            cw = np.einsum("npki,ni->npk", ax, w)
            sw_ = np.sqrt(np.maximum(1.0 - cw * cw, 0.0))
            half[:, j] = (np.abs(np.einsum("npi,ni->np", D, w)).max(axis=1)
                          + reach(sw_[:, :, 0], sw_[:, :, 1], ph).max(axis=1))
        self._obb[nodes] = np.hstack([mean, w1, w2, w3, half])

    def _pack(self):
        """One (nodes, 14) array [lo, hi, c, w, H, R] so a level needs a single gather
        (with oriented boxes: [c, w1, w2, w3, half (3), H, R], (nodes, 17))."""
        if getattr(self, "obb", None) is not None:
            self.nd = np.ascontiguousarray(
                np.hstack([self.obb, self.H[:, None], self.R[:, None]]))
            return
        self.nd = np.ascontiguousarray(
            np.hstack([self.lo, self.hi, self.c, self.w, self.H[:, None], self.R[:, None]]))

    def _within_bound(self, P, node, r2):
        """Whether the lower bound of the distance from points P (k, 3) to ``node`` (k,)
        is at most sqrt(r2) (k,) — both the box and the cylinder bound must pass."""
        nd = np.take(self.nd, node, axis=0)  # the same rows as self.nd[node], ~2.5x faster
        if self.obb is not None:  # oriented box [c, w1, w2, w3, half] and the puck along w2
            d = P - nd[:, 0:3]
            acc = np.zeros(len(P))
            for j in range(3):
                x = np.einsum("ij,ij->i", d, nd[:, 3 + 3 * j: 6 + 3 * j])
                if j == 1:
                    z2 = x.copy()  # the height along the puck's axis w2, used below
                x = np.abs(x, out=x)
                x -= nd[:, 12 + j]
                np.maximum(x, 0.0, out=x)
                acc += x * x
                if j == 1:
                    ez = x
            ok = acc <= r2
            rr = np.einsum("ij,ij->i", d, d) - z2 * z2
            er = np.sqrt(np.maximum(rr, 0.0)) - nd[:, 16]
            np.maximum(er, 0.0, out=er)
            ok &= ez * ez + er * er <= r2
            return ok
        g = np.maximum(nd[:, 0:3] - P, 0.0)
        g += np.maximum(P - nd[:, 3:6], 0.0)
        ok = np.einsum("ij,ij->i", g, g) <= r2
        d = P - nd[:, 6:9]
        z = np.abs(np.einsum("ij,ij->i", d, nd[:, 9:12]))
        rr = np.einsum("ij,ij->i", d, d) - z * z
        er = np.sqrt(np.maximum(rr, 0.0)) - nd[:, 13]
        np.maximum(er, 0.0, out=er)
        ez = z - nd[:, 12]
        np.maximum(ez, 0.0, out=ez)
        ok &= ez * ez + er * er <= r2
        return ok

    def leaf_pairs(self, P, r2, groups=None):
        """All (query, leaf) pairs whose node bounds come within sqrt(r2) of the query.

        Parameters
        ----------
        P : (k, 3) float
        r2 : (k,) float — squared search radii
        groups : None or :func:`query_groups` of P — the packet traversal's groups, when
            several trees are asked about the same points (built once; the same pairs)

        Returns
        -------
        qi, leaf : (n,) int64 — leaf = row of ``prims``
        """
        k = len(P)
        r2 = (np.sqrt(np.maximum(r2, 0.0)) + self.slack) ** 2
        if k * self.NL <= _FLAT_PAIRS:
            # few queries on a small tree (e.g. sphere tracing against one level's passes):
            # test every leaf at once instead of L levels of small steps. A superset of the
            # breadth-first answer in the same order (by query, then leaf): a leaf within the
            # radius has every ancestor within it, and the extra leaves hold nothing within it
            q = np.repeat(np.arange(k), self.NL)
            node = np.tile(np.arange(self.NL, 2 * self.NL), k)
            keep = self._within_bound(P[q], node, r2[q])
            return q[keep], node[keep] - self.NL
        tail = self.group_tail
        if k >= GROUP_MIN and self.L > tail + 1:
            q, node = self._group_descent(P, r2, self.L - tail, groups)
        else:
            q = np.arange(k)
            node = np.ones(k, dtype=np.int64)
        keep = self._within_bound(np.take(P, q, axis=0), node, np.take(r2, q))
        q, node = q[keep], node[keep]
        two = np.arange(2)
        for _ in range(self.L - int(np.log2(node[0])) if len(node) else 0):
            q = np.repeat(q, 2)
            node = (2 * node[:, None] + two).reshape(-1)
            keep = self._within_bound(np.take(P, q, axis=0), node, np.take(r2, q))
            q, node = q[keep], node[keep]
        return q, node - self.NL

    def _group_descent(self, P, r2, depth, groups=None):
        """Packet traversal of the top ``depth`` levels: the queries in groups of
        ``_GROUP`` neighbours (median splits), each group walks the tree as one sphere
        around its mean whose radius holds every member's search sphere (r_q + |p_q − c|);
        the nodes it reaches at level ``depth`` are handed to its members. Returns
        (query, node) pairs sorted by query, then node: a superset of the per-query walk's
        pairs at that level (a node within a member's radius is within the group's, the
        distance to a bound being 1-Lipschitz), far fewer bound tests where the tree is
        wide (the upper levels are tested once per group instead of once per query)."""
        slots = query_groups(P) if groups is None else groups
        ok = slots >= 0
        ids = np.where(ok, slots, 0)
        cnt = ok.sum(axis=1)
        Pg = np.take(P, ids, axis=0)
        c = np.where(ok[:, :, None], Pg, 0.0).sum(axis=1) / cnt[:, None]
        off = np.sqrt(np.einsum("gmi,gmi->gm", Pg - c[:, None, :], Pg - c[:, None, :]))
        rg = (np.where(ok, np.sqrt(np.take(r2, ids)) + off, 0.0).max(axis=1) * (1.0 + 1e-12)
              + self.slack)
        rg2 = rg * rg
        ng = len(slots)
        g = np.arange(ng)
        node = np.ones(ng, dtype=np.int64)
        keep = self._within_bound(c, node, rg2)
        g, node = g[keep], node[keep]
        two = np.arange(2)
        for _ in range(depth):
            g = np.repeat(g, 2)
            node = (2 * node[:, None] + two).reshape(-1)
            keep = self._within_bound(np.take(c, g, axis=0), node, np.take(rg2, g))
            g, node = g[keep], node[keep]
        # hand the nodes to the members: (query, node), sorted by query (stable: by node)
        mem = np.take(slots, g, axis=0)
        node = np.broadcast_to(node[:, None], mem.shape)[mem >= 0]
        q = mem[mem >= 0]
        # a stable sort by query (radix sort on 16-bit keys: the same permutation, ~5x faster)
        order = np.argsort(q.astype(np.int16) if len(P) <= 32767 else q, kind="stable")
        return np.take(q, order), np.take(node, order)

    def pairs(self, P, r2):
        """All (query, primitive) pairs whose node bounds come within sqrt(r2) of the query.

        Parameters
        ----------
        P : (k, 3) float
        r2 : (k,) float — squared search radii

        Returns
        -------
        qi, prim : (n,) int64 — a superset of the primitives within the radii
        """
        q, leaf = self.leaf_pairs(P, r2)
        if self.leaf_box is not None and len(q):
            # the leaves' oriented boxes (a filter: the order is kept)
            bx = self.leaf_box[leaf]
            d = np.einsum("ni,nij->nj", P[q] - bx[:, 0:3], bx[:, 3:12].reshape(-1, 3, 3))
            g = np.maximum(bx[:, 12:15] - d, 0.0)
            g += np.maximum(d - bx[:, 15:18], 0.0)
            rr = (np.sqrt(np.maximum(r2[q], 0.0)) + self.slack) ** 2
            keep = np.einsum("ij,ij->i", g, g) <= rr
            q, leaf = q[keep], leaf[keep]
        B = self.prims.shape[1]
        prim = self.prims[leaf].reshape(-1)
        q = np.repeat(q, B)
        ok = prim >= 0
        return q[ok], prim[ok]


def query_groups(P):
    """Groups of ``_GROUP`` neighbouring queries (k, 3) for :meth:`ClusterTree.leaf_pairs`'
    packet traversal: (g, _GROUP) query ids, −1 padded (median splits, empty groups
    dropped)."""
    slots, _ = _median_slots(P, _GROUP)
    return slots[np.any(slots >= 0, axis=1)]


def group_argmin(k, qi, values, ids):
    """Per query the minimum value and the id achieving it (the last listed of equal ones).

    Parameters
    ----------
    k : int — the number of queries
    qi : (p,) int — the query of each candidate
    values : (p,) float — the candidates' values (e.g. squared distances, mm²)
    ids : (p,) int — the candidates' primitive ids

    Returns
    -------
    best : (k,) float — inf for a query without candidates
    arg : (k,) int64 — −1 for a query without candidates
    """
    best = np.full(k, np.inf)
    np.minimum.at(best, qi, values)
    win = values <= best[qi]
    arg = np.full(k, -1, dtype=np.int64)
    arg[qi[win]] = ids[win]
    return best, arg


def nearest(tree: ClusterTree, P, d2fn, keepfn=None, chunk=CHUNK, fastfn=None, near=None):
    """Exact nearest primitive to each point.

    The primitives with the nearest centroids give an upper bound u; then every primitive in
    a node whose bounds lie within u, and that ``keepfn`` (if given) keeps, is evaluated
    exactly. Returns (d2 (k,), prim (k,)).

    ``keepfn(P, qi, prim, u2)`` (optional) returns the mask (n,) of the pairs (query ``qi``,
    primitive ``prim``) whose lower bound of the squared distance is ≤ ``u2`` (n,) ≥ 0; a
    valid lower bound never drops the nearest primitive.

    ``near`` (optional, (k, 3)): the centroids are looked up nearest to these points instead
    of P (a guess of where each point's nearest primitive is). Any points give a valid bound
    and the same result, bit for bit and ties included (every primitive within u is listed
    after the looked-up ones, in tree order, and the last of equal distances wins); points
    close to the primitives spare the k-d search its slow case, a query far from every
    centroid (a ball centre 6 mm off the surface, a surface point under the centre polylines).

    ``fastfn(P, qi, prim)`` (optional) returns (d2 (n,), tol (float)): the same squared
    distances by a cheaper formula, each within ``tol`` of ``d2fn``'s (NaN: no estimate,
    always evaluate). Then only the
    candidates within 2 tol of their query's smallest ``fastfn`` value — a superset of every
    candidate that can reach the exact minimum, ties included — are evaluated with ``d2fn``,
    in their original order, so the result is the one without ``fastfn``, bit for bit.
    """
    k = len(P)
    d2 = np.full(k, np.inf)
    arg = np.full(k, -1, dtype=np.int64)
    if tree.m == 0:
        return d2, arg

    def run(s):
        Pc = P[s : s + chunk]
        kc = len(Pc)
        _, j = tree.kd.query(Pc if near is None else near[s : s + chunk], k=tree.kd_k)
        pr = np.asarray(j, dtype=np.int64).reshape(-1)
        qi = np.repeat(np.arange(kc), tree.kd_k)
        u2, _ = group_argmin(kc, qi, d2fn(Pc, qi, pr), pr)
        u2 = u2 * (1.0 + 1e-9)
        q2, p2 = tree.pairs(Pc, u2)
        if keepfn is not None and len(q2):
            keep = keepfn(Pc, q2, p2, u2[q2])
            q2, p2 = q2[keep], p2[keep]
        qi = np.concatenate([qi, q2])
        pr = np.concatenate([pr, p2])
        if fastfn is not None and len(qi):
            fa, tol = fastfn(Pc, qi, pr)
            always = np.isnan(fa)
            fbest = np.full(kc, np.inf)
            np.minimum.at(fbest, qi, np.where(always, np.inf, fa))
            keep = always | (fa <= fbest[qi] + 2.0 * tol)
            qi, pr = qi[keep], pr[keep]
        best, a = group_argmin(kc, qi, d2fn(Pc, qi, pr), pr)
        d2[s : s + chunk] = best
        arg[s : s + chunk] = a

    map_chunks(run, k, chunk)
    return d2, arg


def within(tree: ClusterTree, P, radius, chunk=CHUNK):
    """Candidate (query, primitive) pairs within ``radius`` of each point: a superset (the
    nodes' bounds decide), every primitive truly within is listed.

    Parameters
    ----------
    tree : ClusterTree
    P : (k, 3) float, mm — query points
    radius : (k,) float, mm
    chunk : int — queries per chunk of the traversal

    Returns
    -------
    query, primitive : (p,) int64 each
    """
    r2 = np.asarray(radius, dtype=np.float64) ** 2

    def run(s):
        q, p = tree.pairs(P[s : s + chunk], r2[s : s + chunk])
        return q + s, p

    out = map_chunks(run, len(P), chunk)
    if not out:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    return np.concatenate([q for q, _ in out]), np.concatenate([p for _, p in out])
