"""The surface samples of the generator's intrusion checks (paper 001 §3, the ball kept
clear of the mesh away from its contact): every vertex, edge midpoint and face centroid of
the mesh, searched from ball centres through a k-d tree over the vertices alone. The
compiled kernels answer the same question on a tree over all samples
(:func:`..kernels.knn.points_within`); this is the numpy reference. Lengths mm.
"""

from __future__ import annotations

import itertools

import numpy as np

__all__ = ["THREADED_QUERY_MIN", "PROBE_TIE_BAND", "PROBE_RADIUS_SLACK"]

#: k-d tree queries of fewer points than this run on the calling thread: scipy starts its
#: worker threads per call, which costs more than the search of a few hundred points
#: (measured at 1M triangles: 10–50 ball centres ~30 µs a point on one thread, ~100 µs with
#: workers=-1). Every point's answer is the same either way.
THREADED_QUERY_MIN = 512


def _workers(n: int) -> int:
    """``workers`` for a k-d tree query of ``n`` points (see ``THREADED_QUERY_MIN``)."""
    return -1 if n >= THREADED_QUERY_MIN else 1


#: relative width (on squared distances) of the band around a search bound inside which
#: :class:`_ProbeSamples` leaves the decision to the k-d tree over all samples: its own sums
#: of squares differ from ours by a few ulps
PROBE_TIE_BAND = 1e-12
#: slack (mm) added to the vertex search radius of :class:`_ProbeSamples` for the rounding of
#: the midpoints and centroids (~1e-14 mm at blade coordinates)
PROBE_RADIUS_SLACK = 1e-9


class _ProbeSamples:
    """The surface samples of the intrusion checks — every vertex, edge midpoint and face
    centroid, numbered ``v``, ``nv + e``, ``nv + ne + f`` — searched from ball centres with the
    answers of a k-d tree over all of them (:meth:`_Generator._probe_tree`), found through a
    k-d tree over the vertices alone.

    A ball centre lies ~ρ from the surface, which touches the ball's sphere: a k-d search
    around it must open every leaf whose box the sphere cuts, a patch of millimetres around
    the contact, and it opens 6× fewer points among the vertices than among all samples.
    What makes that exact: a midpoint m of an edge (u, v) and a centroid g of a face (a, b, c)
    satisfy ``|m − x|² = (|u − x|² + |v − x|²)/2 − |u − v|²/4`` and
    ``|g − x|² = mean |a_i − x|² − (1/9) Σ_{i<j} |a_i − a_j|²``, so a sample within D of x has a
    vertex within ``sqrt(D² + L²/3)`` (L the longest edge), and every sample belongs to the
    faces around that vertex (with the L of those faces, at most). The candidates are
    measured exactly; the rare row where a squared distance falls within ``PROBE_TIE_BAND`` of
    the bound is answered by the full tree, so every answer is the full tree's. (The k nearest
    samples the same way would cost more than the full tree's own search: the candidates of
    the k-th nearest must be sorted per row.)
    """

    def __init__(self, mesh, vertex_faces, full_tree):
        V, F, e = mesh.V, mesh.F, mesh.edges
        self.V, self.F, self.E, self.nv, self.ne = V, F, e, len(V), len(e)
        self.ptr, self.fids, self.corner = vertex_faces
        self.face_edges = mesh.face_edges  # (v0v1, v1v2, v2v0): corner j starts edge j
        # L_f² / 3 of the faces around each vertex, at most (the reach of its samples)
        # V.take with contiguous indices: ~5x faster than V[e[:, 0]] (a strided index) here
        de = V.take(np.ascontiguousarray(e[:, 0]), axis=0) - V.take(np.ascontiguousarray(
            e[:, 1]), axis=0)
        l2 = np.einsum("ij,ij->i", de, de)
        fe = self.face_edges
        face_l2 = np.maximum(np.maximum(l2[fe[:, 0]], l2[fe[:, 1]]), l2[fe[:, 2]]) / 3.0
        deg = np.diff(self.ptr)
        self.vcover2 = np.zeros(self.nv)
        if len(self.fids):
            has = deg > 0
            self.vcover2[has] = np.maximum.reduceat(face_l2[self.fids], self.ptr[:-1][has])
        self.cover2 = float(self.vcover2.max()) if self.nv else 0.0
        self._vtree = None  # built on the first numpy search (the compiled screens need none)
        self._full_tree = full_tree  # callable: the k-d tree over all samples, built on demand
        self.fallback_rows = 0

    def sample_points(self, sid):
        """(k, 3) coordinates (mm) of the samples ``sid`` (k,): a vertex, ``0.5 (u + v)`` of
        an edge, ``(a + b + c) / 3`` of a face — the very sums, so the very numbers, of
        :meth:`_Generator._probe_tree`."""
        V, nv, ne = self.V, self.nv, self.ne
        out = np.empty((len(sid), 3))
        isv, isc = sid < nv, sid >= nv + ne
        ise = ~isv & ~isc
        out[isv] = V[sid[isv]]
        e = self.E[sid[ise] - nv]
        out[ise] = 0.5 * (V[e[:, 0]] + V[e[:, 1]])
        f = self.F[sid[isc] - nv - ne]
        out[isc] = (V[f[:, 0]] + V[f[:, 1]] + V[f[:, 2]]) / 3.0
        return out

    def all_points(self):
        """(nv + ne + nf, 3) every sample, in id order."""
        V, F, e = self.V, self.F, self.E

        def corner(ids, j):  # V.take with a contiguous index: a strided one gathers ~5x slower
            return V.take(np.ascontiguousarray(ids[:, j]), axis=0)

        # centroids as V[F].mean(axis=1) sums them ((a + b) + c) / 3, without its (m, 3, 3)
        # copy and strided reduction
        cen = (corner(F, 0) + corner(F, 1) + corner(F, 2)) / 3.0
        return np.vstack([V, 0.5 * (corner(e, 0) + corner(e, 1)), cen])

    def any_within(self, C, bound):
        """(q,) bool: a sample lies closer than ``bound`` (mm) to the point — the k-d tree's
        ``isfinite(query(C, k=1, distance_upper_bound=bound)[0])``."""
        q = len(C)
        out = np.zeros(q, dtype=bool)
        if q == 0:
            return out
        b2 = bound * bound
        lo, hi = b2 * (1.0 - PROBE_TIE_BAND), b2 * (1.0 + PROBE_TIE_BAND)
        if self._vtree is None:
            from scipy.spatial import cKDTree  # optional: on first use (~60 ms)

            self._vtree = cKDTree(self.V, leafsize=64, balanced_tree=False, compact_nodes=False)
        lists = self._vtree.query_ball_point(C, np.sqrt(b2 + self.cover2) + PROBE_RADIUS_SLACK,
                                            workers=_workers(q), return_sorted=False)
        cnt = np.fromiter(map(len, lists), dtype=np.int64, count=q)
        v = np.fromiter(itertools.chain.from_iterable(lists), dtype=np.int64,
                        count=int(cnt.sum()))
        row = np.repeat(np.arange(q), cnt)
        d = self.V[v] - C[row]
        d2 = np.einsum("ij,ij->i", d, d)
        out[row[d2 < lo]] = True
        amb = [row[(d2 >= lo) & (d2 <= hi)]]
        # the faces around the vertices that can hold a sample inside, of the rows not decided
        reach = np.sqrt(b2 + self.vcover2[v]) + PROBE_RADIUS_SLACK
        keep = ~out[row] & (d2 < reach * reach)
        v, row = v[keep], row[keep]
        deg = self.ptr[v + 1] - self.ptr[v]
        k = np.repeat(self.ptr[v] - (np.cumsum(deg) - deg), deg) + np.arange(int(deg.sum()))
        f, j = self.fids[k], self.corner[k]
        fe = self.face_edges
        row = np.tile(np.repeat(row, deg), 3)
        d = self.sample_points(np.concatenate([self.nv + self.ne + f, self.nv + fe[f, j],
                                               self.nv + fe[f, (j + 2) % 3]])) - C[row]
        d2 = np.einsum("ij,ij->i", d, d)
        out[row[d2 < lo]] = True
        amb.append(row[(d2 >= lo) & (d2 <= hi)])
        amb = np.unique(np.concatenate(amb))
        amb = amb[~out[amb]]
        if len(amb):
            self.fallback_rows += len(amb)
            dist, _ = self._full_tree().query(C[amb], k=1, distance_upper_bound=bound)
            out[amb] = np.isfinite(dist)
        return out
