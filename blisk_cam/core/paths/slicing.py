"""Mesh ∩ linear morphing cone → ordered polylines (paper 001 §3.1.1–3.1.2).

Every vertex gets the ratio ``s`` of the LMC through it (the morph field, closed-form, see
:mod:`..part.cones`). A level ``s_i`` crosses the faces whose vertex ratios straddle it; on each
crossing edge the point is the exact root of the cone equation along the edge (the paper's
Eq. 9, generalised: square ``α r(t) = −(β z(t) + γ)`` into a quadratic in the edge parameter
``t`` and keep the root where the unsquared equation holds), not a linear interpolation of
``s``. The crossing edges are chained through the faces into closed loops or open curves;
several components per level are returned separately.

The same holds for the linear morphing revolution surfaces between two profile generatrices
(paper 001 §4.2, :mod:`..part.profiles`): their generatrix is a polyline, and each crossing edge is
solved exactly on the line of the polyline segment the crossing lies on.

Robustness: vertices within ``on_tol`` mm of the LMC count as lying on it and are assigned to
the side *outside* the region for the end levels (``s = 0`` → below, ``s = 1`` → above), so a
boundary loop that lies on cone 1 or cone 2 (float32 STL noise ≈ 1e-5 mm) comes out as the
first/last curve itself, made of the boundary vertices, instead of a ragged noisy crossing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..geometry.axis import Axis, meridional
from ..geometry.closest import barycentric
from ..geometry.mesh import TriMesh, chain_graph_paths
from ..geometry.vectors import cross2
from ..kernels import slicing as compiled_slicing
from ..part.cones import MorphingCones
from ..part.profiles import MorphingProfiles
from ..runtime import workers

__all__ = ["LevelCurve", "MeshConeSlicer"]


@dataclass
class LevelCurve:
    """One connected component of mesh ∩ LMC(s), ordered.

    Attributes
    ----------
    s : float
    closed : bool — a closed loop (last point connects to the first; not repeated)
    points : (k, 3) float, mm — on mesh edges, on the LMC
    normals : (k, 3) float — smooth normals (vertex normals interpolated along the edge)
    edge : (k,) int — mesh edge of each point (for a point inside a face, see ``face``: the
        edge of the point before it, a side of that face)
    t : (k,) float — parameter of each point along its edge (from ``edges[:, 0]``); NaN for a
        point inside a face
    face : (k,) int — −1 for a point on its mesh edge; for a point inside a face (the corner
        of an LMRS level curve where it crosses the circle swept by a vertex of the generatrix,
        see :meth:`MeshConeSlicer.slice`) that face's id. Defaults to all −1.
    """

    s: float
    closed: bool
    points: np.ndarray
    normals: np.ndarray
    edge: np.ndarray
    t: np.ndarray
    face: np.ndarray | None = None

    def __post_init__(self):
        if self.face is None:
            self.face = np.full(len(self.points), -1, dtype=np.int64)

    def __len__(self) -> int:
        return len(self.points)

    def length(self) -> float:
        p = np.vstack([self.points, self.points[:1]]) if self.closed else self.points
        return float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum())


#: corner k + 1 of corner k (0 → 1 → 2 → 0)
_NEXT_CORNER = np.array([1, 2, 0])


class MeshConeSlicer:
    """Slices one mesh with the LMC family of a cone pair (or the LMRS family of two profiles);
    precomputes the morph field once.

    Parameters
    ----------
    mesh : TriMesh
    axis : Axis
    morph : MorphingCones or MorphingProfiles (anything with ``ratio``, ``f``, ``polyline``,
        ``segment_lines``, ``cone1``/``cone2``; ``segment_of`` when the generatrix has more
        than one segment)
    on_tol : float, mm — vertices closer than this to a level's LMC are treated as on it.
    """

    def __init__(self, mesh: TriMesh, axis: Axis, morph: MorphingCones | MorphingProfiles, *,
                 on_tol: float = 1e-4):
        self.mesh = mesh
        self.axis = axis
        self.morph = morph
        self.on_tol = float(on_tol)
        got = None
        if isinstance(morph, MorphingCones):  # the same fields in two compiled passes
            p1, d1, dd, da = morph.ratio_terms()
            got = compiled_slicing.cone_slicer_field(
                mesh.V, axis.o, axis.d, mesh.F,
                (p1, d1, dd, cross2(d1, da), -cross2(dd, da), morph.line_coefficients(0.0)))
        if got is not None:
            self.r, self.z, self.radial, self.s, self.face_smin, self.face_smax = got
        else:
            self._vertex_fields()
        self.edges = mesh.edges
        self.face_edges = mesh.face_edges
        self.vertex_normals = mesh.vertex_normals
        finite = np.isfinite(self.s)
        self.s_range = (
            (float(self.s[finite].min()), float(self.s[finite].max()))
            if finite.any()
            else (np.inf, -np.inf)
        )
        # margin in s that corresponds to on_tol mm (conservative: candidate faces only)
        self._s_margin = 1e-6 + 10.0 * self.on_tol / max(self._cone_gap(), 1e-9)
        self._index_face_ranges()

    def _vertex_fields(self):
        """The numpy reference of the set-up's fields: ``r``, ``z`` (n,) mm (meridional),
        ``radial`` (n, 3) mm, ``s`` (n,) and the faces' ``face_smin``, ``face_smax`` (m,)."""
        mesh, axis = self.mesh, self.axis
        V = mesh.V
        self.r, self.z = meridional(V, axis)
        # (n, 3) radial vector of each vertex: p − z d, p = V − o (in place: the same floats
        # without a second (n, 3) temporary)
        self.radial = V - axis.o
        self.radial -= self.z[:, None] * axis.d
        self.s = self.morph.ratio(self.r, self.z)  # (n,) morph field
        # the faces' least and largest s, corner by corner into two arrays: min(min(s0, s1),
        # s2) as before, without the three (m,) corner arrays held at once (the set-up's
        # peak memory runs beside the passes' sample tree build)
        s_of = self.s
        self.face_smin = s_of[mesh.F[:, 0]]
        self.face_smax = self.face_smin.copy()
        for k in (1, 2):
            sk = s_of[mesh.F[:, k]]
            np.minimum(self.face_smin, sk, out=self.face_smin)
            np.maximum(self.face_smax, sk, out=self.face_smax)
            del sk

    #: buckets of the face index (a 16-bit key: numpy's stable argsort is then a radix sort)
    _N_BUCKETS = 1 << 16
    #: faces whose s span is at most this quantile of the spans are bucketed (narrow)
    _NARROW_QUANTILE = 0.999
    #: the buckets cover this range of s (clamped to the mesh's): the levels asked lie in
    #: [0, 1] or a hair beyond; faces outside fall into the end buckets
    _BUCKET_RANGE = (-1.0, 2.0)

    def _index_face_ranges(self):
        """Faces bucketed by their smallest s, so a level's candidates are found in a few
        buckets instead of a test of every face: a face whose s range is at most ``w``
        wide can only reach [s − m, s + m] if its smallest s lies in [s − m − w, s + m] (the
        window is taken wider, the exact test follows); the few faces wider
        than the 99.9th percentile of spans (and those with infinite s) are tested directly.
        Faces with NaN s are never candidates (as with a direct test).

        The buckets split the range of smallest s evenly (``_N_BUCKETS``, 16-bit keys, a
        radix sort); a face's bucket is a monotone function of its smallest s, so the faces
        whose smallest s lies in a window are all in the buckets of the window's two ends
        and those between (a superset, tested exactly in :meth:`_candidate_faces`)."""
        lo, hi = self.face_smin, self.face_smax
        got = compiled_slicing.slicer_face_index(lo, hi, self._NARROW_QUANTILE,
                                                 self._N_BUCKETS, self._BUCKET_RANGE)
        if got is not None:  # the same index in two compiled passes (a counting sort)
            cut, a, scale, self._narrow_faces, self._bucket_start, self._wide_faces = got
            self._bucket_lo, self._bucket_scale = np.float64(a), np.float64(scale)
            self._narrow_span = 2.0 * cut + 1e-9
            return
        with np.errstate(invalid="ignore"):  # inf − inf: NaN, a wide face below
            width = hi - lo
        finite = np.isfinite(width)
        q = self._NARROW_QUANTILE
        cut = float(np.quantile(width[finite], q)) if finite.any() else 0.0
        is_narrow = finite & (width <= cut)
        del width, finite  # (the temporaries go as soon as done: a smaller peak memory)
        narrow = np.nonzero(is_narrow)[0]
        lo_n = lo[narrow]
        nb = self._N_BUCKETS
        if len(narrow):
            a, b = float(lo_n.min()), float(lo_n.max())
            ra, rb = max(a, self._BUCKET_RANGE[0]), min(b, self._BUCKET_RANGE[1])
            if ra < rb:
                a, b = ra, rb
        else:
            a = b = 0.0
        self._bucket_lo = np.float64(a)
        self._bucket_scale = np.float64((nb - 1) / (b - a) if b > a else 0.0)
        key = self._bucket_of(lo_n).astype(np.uint16)
        del lo_n
        order = np.argsort(key, kind="stable")  # by bucket, then by face id
        self._narrow_faces = narrow[order]
        del narrow, order
        # faces of bucket k: _narrow_faces[_bucket_start[k]:_bucket_start[k + 1]]
        self._bucket_start = np.concatenate([[0], np.cumsum(np.bincount(key, minlength=nb))])
        self._narrow_span = 2.0 * cut + 1e-9  # slack: the window only pre-selects
        # wide or infinite (NaN ranges fail every comparison, so they are dropped here)
        wide = ~is_narrow & ~np.isnan(lo) & ~np.isnan(hi)
        self._wide_faces = np.nonzero(wide)[0]

    def _bucket_of(self, x):
        """Bucket (float, integral, 0 … ``_N_BUCKETS`` − 1) of smallest s ``x`` (scalar or
        array): monotone in ``x``; the same arithmetic for both."""
        v = (np.asarray(x, dtype=np.float64) - self._bucket_lo) * self._bucket_scale
        return np.floor(np.clip(v, 0.0, self._N_BUCKETS - 1))

    def _bucket_index(self, x: float) -> int:
        """``int(self._bucket_of(x))`` of one float, in Python floats: the same IEEE
        arithmetic without numpy's per-scalar overhead (this runs twice a level)."""
        v = (float(x) - float(self._bucket_lo)) * float(self._bucket_scale)
        return int(math.floor(min(max(v, 0.0), self._N_BUCKETS - 1)))

    def _candidate_faces(self, s: float, m: float):
        """Ascending ids of the faces with smin ≤ s + m and smax ≥ s − m."""
        lo = s - m - self._narrow_span
        k0, k1 = self._bucket_index(lo), self._bucket_index(s + m)
        got = compiled_slicing.slicer_candidates(
            self._narrow_faces, self._bucket_start[k0], self._bucket_start[k1 + 1],
            self._wide_faces, self.face_smin, self.face_smax, lo, s + m, s - m)
        if got is not None:  # the same ids in one call, the GIL released
            return got
        near = self._narrow_faces[self._bucket_start[k0]:self._bucket_start[k1 + 1]]
        smin = self.face_smin[near]
        near = near[(smin >= lo) & (smin <= s + m) & (self.face_smax[near] >= s - m)]
        w = self._wide_faces
        if len(w):
            w = w[(self.face_smin[w] <= s + m) & (self.face_smax[w] >= s - m)]
            near = np.concatenate([near, w])
        return np.sort(near)

    def _cone_gap(self) -> float:
        """A typical meridional distance between cone 1 and cone 2 (mm)."""
        c1, c2 = self.morph.cone1, self.morph.cone2
        v = c2.vertices
        return float(np.mean(np.abs(c1.signed_distance(v[:, 0], v[:, 1]))))

    # ------------------------------------------------------------------------------------
    def vertex_side(self, s: float, vertices, lines=None):
        """Signed meridional distance f_s of the given vertices, snapped to 0 within ``on_tol``.

        ``lines`` = ``morph.segment_lines(s)`` when the caller has them already (a cone pair's
        f_s is then evaluated from its one line, the arithmetic of ``MorphingCones.f``)."""
        if lines is not None and isinstance(self.morph, MorphingCones):
            alpha, beta, gamma = (float(v) for v in lines[0])
            f = alpha * self.r[vertices] + beta * self.z[vertices] + gamma
        else:
            f = self.morph.f(s, self.r[vertices], self.z[vertices])
        f[np.abs(f) <= self.on_tol] = 0.0
        return f

    def slice(self, s: float) -> list[LevelCurve]:
        """All components of mesh ∩ LMC(s), each ordered along the curve.

        Closed loops and open curves (where the mesh has a boundary or a hole) are returned
        as separate :class:`LevelCurve` s, largest first. Curves run so that, seen from
        outside the material, the cone-2 side (larger s) is on the right.
        """
        s = float(s)
        mesh = self.mesh
        m = self._s_margin
        cand = self._candidate_faces(s, m)
        if len(cand) == 0:
            return []
        lines = self.morph.segment_lines(s)
        got = None
        if isinstance(self.morph, MorphingCones):  # one line: the crossing in one call
            got = compiled_slicing.cone_level(
                self.r, self.z, self.radial, mesh.V, self.vertex_normals, mesh.F, self.edges,
                self.face_edges, cand, lines[0], self.on_tol, not s < 1.0)
        if got is not None:
            uedges, links, pts, t, nrm = got
            if len(uedges) == 0:
                return []
            faces = None
        else:
            crossing = self._crossing(s, cand, lines)
            if crossing is None:
                return []
            faces, uedges, links, pts, t, nrm = crossing
        nxt = np.full(len(uedges), -1, dtype=np.int64)
        nxt[links[:, 0]] = links[:, 1]
        kinked = len(lines) > 1
        if kinked:  # the face of each link, looked up by its (unordered) pair of edges
            nu = np.int64(len(uedges))
            lk = np.minimum(links[:, 0], links[:, 1]) * nu + np.maximum(links[:, 0], links[:, 1])
            lk_order = np.argsort(lk, kind="stable")
            lk_sorted, lk_face = lk[lk_order], faces[lk_order]
        curves = []
        for order, closed in chain_graph_paths(len(uedges), links):
            if len(order) >= 2 and nxt[order[0]] != order[1]:
                order = order[::-1]
            # several crossing edges can share one point (a vertex on the level): drop repeats
            p = pts[order]
            keep = np.ones(len(order), dtype=bool)
            keep[1:] = (p[1:] != p[:-1]).any(axis=1)
            if closed and len(order) > 1 and (p[-1] == p[0]).all():
                keep[-1] = False
            order = order[keep]
            if len(order) < 2:
                continue
            closed = bool(closed and len(order) > 2)
            curve = LevelCurve(
                s=s, closed=closed, points=pts[order], normals=nrm[order], edge=uedges[order],
                t=t[order],
            )
            if kinked:
                a, b = order, np.roll(order, -1)
                if not closed:
                    a, b = a[:-1], b[:-1]
                key = np.minimum(a, b) * nu + np.maximum(a, b)
                pos = np.clip(np.searchsorted(lk_sorted, key), 0, len(lk_sorted) - 1)
                seg_face = np.where(lk_sorted[pos] == key, lk_face[pos], -1)
                curve = self._insert_kink_points(curve, seg_face)
            curves.append(curve)
        if len(curves) > 1:
            curves.sort(key=lambda c: -c.length())
        return curves

    def _crossing(self, s: float, cand, lines):
        """The crossing part of :meth:`slice` (the numpy reference of the compiled
        ``cone_level``): of the candidate faces those the level crosses, their links from the
        edge entered below → above to the edge left above → below, the crossed edges
        (ascending), their crossings and the smooth normals there. None when no face is
        crossed.

        Returns
        -------
        faces (f,) int — the crossed faces; edges (u,) int; links (f, 2) int (indices into
        edges); points (u, 3) mm; t (u,); normals (u, 3)
        """
        mesh = self.mesh
        # the side of every corner (a vertex shared by several faces is evaluated once per
        # corner: the same elementwise arithmetic, cheaper than de-duplicating with a sort)
        f_corner = self.vertex_side(s, mesh.F[cand].ravel(), lines)
        # zero goes outside the region at the end levels, below otherwise
        above = (f_corner > 0 if s < 1.0 else f_corner >= 0).reshape(-1, 3)
        crossed = above.any(axis=1) & ~above.all(axis=1)  # one or two corners above
        if not crossed.any():
            return None
        faces = cand[crossed]
        ab = above[crossed]
        fe = self.face_edges[faces]  # (c, 3): edges v0v1, v1v2, v2v0
        cross_e = ab != ab[:, _NEXT_CORNER]  # edge k joins corner k and k+1
        # each crossed face has exactly two crossing edges; orient the link from the edge
        # entered below→above to the one left above→below (counter-clockwise in the face)
        k_idx = np.nonzero(cross_e)[1].reshape(-1, 2)
        rows = np.arange(len(faces))
        first_up = ~ab[rows, k_idx[:, 0]]  # corner k below → corner k+1 above: going up
        e_k = fe[rows[:, None], k_idx]  # (c, 2)
        e_up = np.where(first_up, e_k[:, 0], e_k[:, 1])
        e_dn = np.where(first_up, e_k[:, 1], e_k[:, 0])
        uedges, linv = _unique_inverse(np.concatenate([e_up, e_dn]))
        links = linv.reshape(2, -1).T  # (c, 2) directed up → dn
        pts, t = self._edge_roots(s, uedges, lines=lines)
        ev = self.edges[uedges]
        vn = self.vertex_normals
        nrm = (1.0 - t)[:, None] * vn[ev[:, 0]] + t[:, None] * vn[ev[:, 1]]
        ln = np.sqrt(np.add.reduce(nrm * nrm, axis=1))  # np.linalg.norm's arithmetic
        nrm = nrm / np.where(ln > 0, ln, 1.0)[:, None]
        return faces, uedges, links, pts, t, nrm

    def _insert_kink_points(self, curve: LevelCurve, seg_face) -> LevelCurve:
        """The level curve with its corners inside faces added (LMRS only, paper 001 §4.2).

        Inside one face the curve mesh ∩ LMRS(s) is the plane of the face cut with the
        revolution of the polyline G_s: a piecewise conic that turns a corner where it crosses
        the circle swept by a vertex A_j(s) of G_s (the boundary of morph strips j − 1 and j,
        :meth:`..part.profiles.MorphingProfiles.segment_of`). The straight segment between the
        curve's two edge roots in that face cuts the corner. Where the two ends of a segment lie in
        different strips, the corner of each strip boundary passed is inserted: the point of
        the face's plane at height z = z_j on the circle r = r_j, (r_j, z_j) = A_j(s) — the
        plane ∩ {z = z_j} is a line X0 + τ u (u = n × d, no axial part), and |q0 + τ u|² = r_j²
        (q0 the radial vector of X0) is a quadratic in τ; of its two roots the one nearer the
        segment is kept. Such a point lies on the surface exactly (it is A_j(s) revolved). It is
        kept only when it falls inside the face (barycentrics ≥ −1e-9) and G_s really turns at
        A_j (collinear segments need no corner); a segment joining two mesh vertices on the
        level (a mesh edge, e.g. of the boundary loop at s = 0) is left as it is.

        Parameters
        ----------
        curve : LevelCurve — points on edges, in order
        seg_face : (q,) int — face of each segment i → i + 1 (and last → first when closed),
            −1 where not known (the segment then stays as it is)

        Returns
        -------
        LevelCurve — the same curve with the corner points inserted (``face`` ≥ 0 for them,
        ``edge`` that of the point before, ``t`` NaN, normals interpolated in the face)
        """
        morph, axis, mesh = self.morph, self.axis, self.mesh
        P = curve.points
        k = len(P)
        q = len(seg_face)
        ia = np.arange(q)
        ib = (ia + 1) % k
        r, z = meridional(P, axis)
        j = np.asarray(morph.segment_of(r, z), dtype=np.int64)
        # two mesh vertices on the level (within on_tol, e.g. a boundary loop at s = 0 or 1):
        # the segment is the mesh edge between them, the cut itself — no corner
        at_vertex = (curve.t == 0.0) | (curve.t == 1.0)
        n_cross = np.where((seg_face >= 0) & ~(at_vertex[ia] & at_vertex[ib]),
                           np.abs(j[ib] - j[ia]), 0)
        if not np.any(n_cross):
            return curve
        seg = np.repeat(ia, n_cross)
        within = np.arange(len(seg)) - np.repeat(np.cumsum(n_cross) - n_cross, n_cross)
        ray = np.minimum(j[ia], j[ib])[seg] + 1 + within  # vertex index of G_s, 1 … m − 1
        G = morph.polyline(curve.s)
        dG = np.diff(G, axis=0)
        dG = dG / np.linalg.norm(dG, axis=1)[:, None]
        turns = np.abs(dG[ray - 1, 0] * dG[ray, 1] - dG[ray - 1, 1] * dG[ray, 0]) > 1e-12
        face = seg_face[seg]
        a, b = P[ia[seg]], P[ib[seg]]
        c = 0.5 * (a + b)
        n = mesh.face_normals[face]
        n = n / np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]
        d = np.asarray(axis.d, dtype=np.float64)
        d = d / np.linalg.norm(d)
        o = np.asarray(axis.o, dtype=np.float64)
        rj, zj = G[ray, 0], G[ray, 1]
        tri = mesh.V[mesh.F[face]]  # (p, 3, 3)
        nd = n @ d
        det = 1.0 - nd * nd  # |n × d|²: 0 when the face is normal to the axis
        ok = turns & (det > 1e-12)
        det = np.where(ok, det, 1.0)
        # X0 = c + μ1 n + μ2 d on the face's plane and at height zj, nearest to c
        h1 = np.einsum("ij,ij->i", n, tri[:, 0] - c)
        h2 = o @ d + zj - c @ d
        X0 = c + ((h1 - nd * h2) / det)[:, None] * n + ((h2 - nd * h1) / det)[:, None] * d
        u = np.cross(n, d) / np.sqrt(det)[:, None]
        q0 = X0 - o - zj[:, None] * d
        bq = np.einsum("ij,ij->i", q0, u)
        disc = bq * bq - np.einsum("ij,ij->i", q0, q0) + rj * rj
        ok &= disc >= 0
        sq = np.sqrt(np.maximum(disc, 0.0))
        cand = np.stack([X0 + (-bq + sq)[:, None] * u, X0 + (-bq - sq)[:, None] * u], 1)
        pick = np.argmin(np.linalg.norm(cand - c[:, None, :], axis=2), axis=1)
        X = cand[np.arange(len(seg)), pick]
        bary = barycentric(X, tri[:, 0], tri[:, 1], tri[:, 2])
        ok &= np.all(bary >= -1e-9, axis=1)
        if not np.any(ok):
            return curve
        seg, X, face, bary = seg[ok], X[ok], face[ok], bary[ok]
        # order: along the curve, then along each segment
        along = np.einsum("ij,ij->i", X - P[ia[seg]], P[ib[seg]] - P[ia[seg]])
        key = np.concatenate([np.arange(k, dtype=np.float64), seg + 0.5])
        sub = np.concatenate([np.zeros(k), along])
        perm = np.lexsort((sub, key))
        cat = lambda own, new: np.concatenate([own, new])[perm]  # noqa: E731
        return LevelCurve(
            s=curve.s, closed=curve.closed,
            points=cat(P, X),
            normals=cat(curve.normals, mesh.interpolate_normals(face, bary)),
            edge=cat(curve.edge, curve.edge[ia[seg]]),
            t=cat(curve.t, np.full(len(seg), np.nan)),
            face=cat(curve.face, face),
        )

    def _edge_roots(self, s: float, edge_ids, lines=None):
        """Exact crossing points of the LMC (or LMRS) at ``s`` on edges (paper Eq. 9,
        generalised).

        A cone's generatrix is one line α r + β z + γ = 0: the closed form of
        :meth:`_roots_on_lines` with scalar coefficients. An LMRS generatrix (a polyline,
        :class:`..part.profiles.MorphingProfiles`) is one line per segment: each edge is solved on
        the line of the segment its crossing lies on — the strip of the linearly interpolated
        crossing (``morph.segment_of``), moved to the neighbouring segment while the root
        falls off the segment (the crossing is then exact on the polyline), and the rare edge
        still unresolved is solved on every segment, keeping the root on its segment with the
        smallest residual.

        ``lines`` = ``morph.segment_lines(s)`` when the caller has them already.

        Returns
        -------
        points : (k, 3) float, mm
        t : (k,) float in [0, 1]
        """
        if lines is None:
            lines = self.morph.segment_lines(s)
        if isinstance(self.morph, MorphingCones):  # one line, f = α r + β z + γ: compiled
            got = compiled_slicing.cone_edge_roots(self.r, self.z, self.radial, self.mesh.V,
                                                   self.edges, edge_ids, lines[0], self.on_tol,
                                                   workers())
            if got is not None:
                return got
        ev = self.edges[edge_ids]
        i0, i1 = ev[:, 0], ev[:, 1]
        k = len(i0)
        f01 = self.vertex_side(s, np.concatenate([i0, i1]), lines)  # one call for both ends
        f0, f1 = f01[:k], f01[k:]
        if len(lines) == 1:
            alpha, beta, gamma = (float(v) for v in lines[0])
            t = self._roots_on_lines(alpha, beta, gamma, i0, i1, f0, f1, residual=False)[0]
        else:
            t = self._roots_on_polyline(s, lines, i0, i1, f0, f1)
        # vertices on the level (snapped to zero): the crossing is the vertex itself
        t = np.where(f0 == 0.0, 0.0, np.where(f1 == 0.0, 1.0, t))
        V = self.mesh.V
        v0 = V[i0]
        pts = v0 + t[:, None] * (V[i1] - v0)
        end = t == 1.0
        if np.any(end):
            pts[end] = V[i1[end]]  # exactly the vertex (x + (y − x) ≠ y in floats)
        return pts, t

    def _roots_on_polyline(self, s, lines, i0, i1, f0, f1):
        """Edge parameters t of the crossings with the LMRS polyline at ``s`` (see
        :meth:`_edge_roots`); ``lines`` (k, 3) are its segments' (α, β, γ)."""
        G = self.morph.polyline(s)
        k = len(lines)
        with np.errstate(divide="ignore", invalid="ignore"):
            tl = np.clip(np.where(f1 != f0, f0 / (f0 - f1), 0.5), 0.0, 1.0)
        q_est = self.radial[i0] + tl[:, None] * (self.radial[i1] - self.radial[i0])
        r_est = np.linalg.norm(q_est, axis=1)
        z_est = self.z[i0] + tl * (self.z[i1] - self.z[i0])
        j = np.asarray(self.morph.segment_of(r_est, z_est), dtype=np.int64)

        def solve(idx, jj):
            a, b, c = lines[jj, 0], lines[jj, 1], lines[jj, 2]
            tt, err = self._roots_on_lines(a, b, c, i0[idx], i1[idx], f0[idx], f1[idx])
            # parameter λ of the crossing along segment jj of G_s (extended at the ends)
            q = self.radial[i0[idx]] + tt[:, None] * (self.radial[i1[idx]] - self.radial[i0[idx]])
            zz = self.z[i0[idx]] + tt * (self.z[i1[idx]] - self.z[i0[idx]])
            x = np.stack([np.linalg.norm(q, axis=1), zz], 1)
            d = G[jj + 1] - G[jj]
            lam = np.einsum("ij,ij->i", x - G[jj], d) / np.einsum("ij,ij->i", d, d)
            # the end segments extend beyond the generatrix's end points
            lam = np.where((jj == 0) & (lam < 0), 0.5, lam)
            lam = np.where((jj == k - 1) & (lam > 1), 0.5, lam)
            return tt, err, lam

        idx = np.arange(len(i0))
        t, err, lam = solve(idx, j)
        eps = 1e-9
        # a root of the line (residual at rounding level, the Newton-polished roots are
        # ~1e-13 mm) that is off the segment: the crossing is on a neighbouring segment
        root_tol = 1e-9 * max(1.0, float(np.abs(G).max()))
        for _ in range(3):
            move = (err <= root_tol) & (((lam < -eps) & (j > 0)) | ((lam > 1 + eps) & (j < k - 1)))
            if not np.any(move):
                break
            m = np.nonzero(move)[0]
            j[m] += np.where(lam[m] < 0, -1, 1)
            t[m], err[m], lam[m] = solve(m, j[m])
        # no root on that line within the edge, or still off its segment (near a vertex of
        # G_s): try every segment
        bad = np.nonzero((err > root_tol) | (lam < -eps) | (lam > 1 + eps))[0]
        if len(bad):
            best_t, best_e = t[bad].copy(), np.full(len(bad), np.inf)
            for jj in range(k):
                tt, ee, ll = solve(bad, np.full(len(bad), jj))
                ok = (ll >= -eps) & (ll <= 1 + eps) & (ee < best_e)
                best_t = np.where(ok, tt, best_t)
                best_e = np.where(ok, ee, best_e)
            t[bad] = best_t
        return t

    def _roots_on_lines(self, alpha, beta, gamma, i0, i1, f0, f1, *, residual=True):
        """Exact roots on edges i0→i1 of the meridional line α r + β z + γ = 0 ((α, β) unit;
        scalars, or one line per edge).

        Along the edge X(t) = T1 + t (T2 − T1), z is linear and the radial vector is linear,
        so r(t)² is quadratic. The line squares to α² r(t)² − (β z(t) + γ)² = 0; of its roots
        in [0, 1] we keep the one where the unsquared residual is smallest, then polish with
        one Newton step.

        Returns
        -------
        t : (k,) float in [0, 1]
        residual : (k,) float, mm — |α r(t) + β z(t) + γ| at the returned t (None when
            ``residual`` is False: not computed)
        """
        q0 = self.radial[i0]
        dq = self.radial[i1] - q0
        z0 = self.z[i0]
        dz = self.z[i1] - z0
        w0 = beta * z0 + gamma
        a = alpha**2 * np.einsum("ij,ij->i", dq, dq) - (beta * dz) ** 2
        b = 2.0 * (alpha**2 * np.einsum("ij,ij->i", q0, dq) - beta * dz * w0)
        c = alpha**2 * np.einsum("ij,ij->i", q0, q0) - w0**2
        disc = np.maximum(b * b - 4 * a * c, 0.0)
        sq = np.sqrt(disc)
        with np.errstate(divide="ignore", invalid="ignore"):
            qq = -0.5 * (b + np.copysign(sq, b))
            r12 = np.empty((2, len(q0)))  # the two roots of the square (NaN: none)
            r12[0] = np.where(qq != 0, c / qq, np.nan)
            r12[1] = np.where(a != 0, qq / a, np.nan)
            lin = np.where(f1 != f0, f0 / (f0 - f1), 0.5)  # fallback: linear in f
            # a root outside the edge (or none) gives way to the fallback; the residual
            # |α r(t) + β z(t) + γ| (t clipped into [0, 1]) is evaluated, in one pass, for
            # the roots inside and for the fallback where a root is outside
            inside = np.isfinite(r12) & (r12 >= -1e-9) & (r12 <= 1 + 1e-9)
            in0, in1 = np.nonzero(inside[0])[0], np.nonzero(inside[1])[0]
            out = np.nonzero(~(inside[0] & inside[1]))[0]
            rows = np.concatenate([in0, in1, out])
            tv = np.concatenate([r12[0, in0], r12[1, in1], lin[out]])
            # NaN → −1 then clipped (as np.nan_to_num(nan=−1) would, ±inf clip the same)
            tv = np.clip(np.where(np.isnan(tv), -1.0, tv), 0.0, 1.0)
            rv = np.linalg.norm(q0[rows] + tv[:, None] * dq[rows], axis=1)
            ev = np.abs(_at(alpha, rows) * rv + _at(beta, rows) * (z0[rows] + tv * dz[rows])
                        + _at(gamma, rows))
            n0, n01 = len(in0), len(in0) + len(in1)
            tt, rr, e = np.empty((2, len(q0))), np.empty((2, len(q0))), np.empty((2, len(q0)))
            for x, v in ((tt, tv), (rr, rv), (e, ev)):
                x[:, out] = v[n01:]
                x[0, in0] = v[:n0]
                x[1, in1] = v[n0:n01]
            # the candidate with the smaller residual; r(t) comes with it
            pick = e[0] <= e[1]
            t = np.where(pick, tt[0], tt[1])
            rr = np.where(pick, rr[0], rr[1])
            # one Newton step on the unsquared residual g(t) = α r(t) + β z(t) + γ
            qt = q0 + t[:, None] * dq
            g = alpha * rr + beta * (z0 + t * dz) + gamma
            dg = alpha * np.einsum("ij,ij->i", qt, dq) / np.maximum(rr, 1e-300) + beta * dz
            tn = np.where(np.abs(dg) > 1e-300, t - g / dg, t)
        t = np.where(np.isfinite(tn) & (tn >= 0) & (tn <= 1), tn, t)
        if not residual:
            return t, None
        rr = np.linalg.norm(q0 + t[:, None] * dq, axis=1)
        return t, np.abs(alpha * rr + beta * (z0 + t * dz) + gamma)


def _at(x, idx):
    """``x[idx]`` for an array, ``x`` itself for a scalar (a line's coefficient, shared)."""
    return x[idx] if np.ndim(x) else x


def _unique_inverse(a):
    """``np.unique(a, return_inverse=True)`` for a 1-D int array, by one stable argsort
    (timsort: the edge ids of consecutive faces come in sorted runs).

    Returns
    -------
    uniq : (u,) int, ascending
    inverse : (len(a),) int64 — uniq[inverse] == a
    """
    order = np.argsort(a, kind="stable")
    srt = a[order]
    new = np.empty(len(a), dtype=bool)
    new[:1] = True
    np.not_equal(srt[1:], srt[:-1], out=new[1:])
    inverse = np.empty(len(a), dtype=np.int64)
    inverse[order] = np.cumsum(new) - 1
    return srt[new], inverse
