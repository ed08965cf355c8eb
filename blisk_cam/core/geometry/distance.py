"""Exact distances from points to a triangle mesh: :class:`MeshDistance` (one tree over
the whole mesh) and :class:`NearestFaces` (k-d trees of face centroids by size
class), both returning :class:`~.closest.ClosestPoints`. All lengths in mm.
"""

from __future__ import annotations

import itertools

import numpy as np

from ..kernels import closest as compiled_closest
from ..kernels.backend import extension
from ..runtime import alongside, workers
from .bvh import ClusterTree, nearest
from .closest import ClosestPoints, _capsule_distance, _cross, _edge_capsules, closest_on_triangles
from .mesh import TriMesh
from .vectors import dot

__all__ = ["MeshDistance", "NearestFaces", "closest_points"]

# NearestFaces: circumradius size classes (6, half an octave each)
_NF_CLASSES, _NF_PER_OCTAVE = 6, 2


class MeshDistance:
    """Reusable exact closest-point queries on a :class:`TriMesh`.

    Parameters
    ----------
    mesh : TriMesh
    leaf_size : int — triangles per tree leaf
    compiled : bool — with the compiled kernels running, the nearest faces come from their
        tree (:class:`NearestFaces`' kernel): the same distances and points, but of faces at
        exactly the same distance (a point on a shared edge or vertex) the lowest id instead
        of the last in this tree's leaf order. Verify opts in.
    faces : NearestFaces or None — one already made on ``mesh``: the nearest faces come from
        it on either backend (the same distances and points, ties by the lowest id as with
        ``compiled``) and its trees are shared; no tree of this class is built (the link
        check: at 1M faces that tree took longer than the whole plan)
    """

    def __init__(self, mesh: TriMesh, *, leaf_size: int = 8, compiled: bool = False,
                 faces: NearestFaces | None = None):
        self.mesh = mesh
        V, F = mesh.V, mesh.F
        if faces is not None and faces.mesh is not mesh:
            raise ValueError("MeshDistance: faces must be a NearestFaces of the same mesh")
        self._faces = faces
        if faces is None and compiled and extension() is not None:
            self._faces = NearestFaces(mesh, disks=True)
        self._frames = None
        if self._faces is not None:  # the numpy tree is not needed, nor its corner arrays
            return  # (3 × 24 MB at 1M faces, made and first touched for nothing)
        self._A, self._B, self._C = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
        T = V[F]
        self._cen = T.mean(axis=1)
        self._rad = np.linalg.norm(T - self._cen[:, None, :], axis=2).max(axis=1)
        self._n = mesh.face_normals  # zero for zero-area faces: the bound is then a sphere
        # per-query tests for the last 2 levels: queries far off the surface (ball centres,
        # 6 mm) come in groups whose common sphere reaches many more leaves than each member
        # (Rotor 37's centre polylines: 1.6 -> 1.1 s; surface points unchanged)
        self.tree = ClusterTree(T, flat=True, leaf_size=leaf_size, group_tail=2, leaf_obb=True)
        # the capsule of each face around its longest edge (see :meth:`_lb_keep`)
        self._cap = _edge_capsules(self._A, self._B, self._C,
                                   float(np.abs(T).max()) if len(T) else 1.0)

    def _face_frames(self):
        """(m, 31) per face: A, unit normal n, then per edge (AB, BC, CA) its start, unit
        direction, length and in-plane outward normal (direction × n); zero-area faces get
        n = 0 (see :meth:`_fast_d2`); the same for slivers."""
        if self._frames is None:
            A, B, C = self._A, self._B, self._C
            n = _cross(B - A, C - A)
            nl = np.sqrt(dot(n, n))
            longest = np.sqrt(np.maximum.reduce([dot(B - A, B - A), dot(C - B, C - B),
                                                 dot(A - C, A - C)]))
            # slivers (an angle below ~0.06°) are always evaluated exactly: their normal, from
            # rounded edges, is off by ~ε / sin(angle)
            ok = nl > 1e-3 * np.maximum(longest, 1e-300) ** 2
            n = np.where(ok[:, None], n / np.where(ok, nl, 1.0)[:, None], 0.0)
            cols = [A, n]
            for S, E in ((A, B), (B, C), (C, A)):
                d = E - S
                L = np.sqrt(dot(d, d))
                e = d / np.where(L > 0, L, 1.0)[:, None]
                cols += [S, e, L[:, None], _cross(e, n)]
            self._frames = np.ascontiguousarray(np.hstack(cols))
        return self._frames

    def _fast_d2(self, P, qi, f):
        """Squared point–triangle distances (n,) from per-face frames — the plane height z and
        the in-plane distance to the triangle (0 inside; else the nearest edge segment, from
        its signed offset s and its parameter t): z² + min_i (s_i² + (t_i − clamp t_i)²) —
        and their error bound (a float, mm²). Zero-area faces and slivers give NaN (always
        evaluated exactly)."""
        G = self._face_frames()[f]
        p = P[qi]
        d = p - G[:, 0:3]
        z = np.einsum("ij,ij->i", d, G[:, 3:6])
        out = np.full(len(p), np.inf)
        inside = np.ones(len(p), bool)
        for j in range(3):
            c = 6 + 10 * j
            w = p - G[:, c : c + 3]
            t = np.einsum("ij,ij->i", w, G[:, c + 3 : c + 6])
            sg = np.einsum("ij,ij->i", w, G[:, c + 7 : c + 10])
            inside &= sg <= 0.0
            t -= np.clip(t, 0.0, G[:, c + 6])
            np.minimum(out, sg * sg + t * t, out=out)
        d2 = z * z + np.where(inside, 0.0, out)
        dd = np.einsum("ij,ij->i", d, d)
        d2 = np.where(np.any(G[:, 3:6] != 0.0, axis=1), d2, np.nan)
        # both formulas round by a few ε |p − A|² (|p − A| ≥ every distance here); far wider
        tol = 1e-10 * (1.0 + float(dd.max(initial=0.0)))
        return d2, tol

    def _d2(self, P, qi, f):
        return closest_on_triangles(P[qi], self._A[f], self._B[f], self._C[f])[1]

    def _lb_keep(self, P, qi, f, u2):
        """Whether a lower bound of the squared distance to each face is ≤ ``u2`` (n,) ≥ 0
        ((n,) bool): the larger of the squared distances to the disk (in the face plane,
        around the centroid) and to the capsule (around the longest edge, radius the opposite
        vertex's height) that contain the face, less a rounding pad of 1e-12 |p − centroid|².
        The capsule is what prunes slivers and needles (a scanned blade's leading edge: a
        disk of half their length around a face 0.03 mm wide let ~70 faces per ball centre
        through to the point–triangle kernels on Rotor 37, the capsule ~10), and it is tested
        first (it drops ~75 % of a ball centre's candidates there), the disk only on the
        pairs it keeps: max(a, b) − pad ≤ u2 exactly when a − pad and b − pad both are."""
        p = P[qi]
        d = p - self._cen[f]
        dd = dot(d, d)
        c = _capsule_distance(p, self._cap[f])
        keep = c * c - 1e-12 * dd <= u2
        i = np.flatnonzero(keep)
        d, dd, fi = d[i], dd[i], f[i]
        z = dot(d, self._n[fi])
        rad = np.sqrt(np.maximum(dd - z * z, 0.0))
        e = np.maximum(rad - self._rad[fi] * (1.0 + 1e-12), 0.0)
        keep[i] = z * z + e * e - 1e-12 * dd <= u2[i]
        return keep

    def query(self, points, near=None) -> ClosestPoints:
        """Closest points on the mesh to (k, 3) points (mm); exact.

        The side uses the pseudo-normal of the closest feature: the face normal in a face
        interior, the sum of the two face normals on an edge, the angle-weighted vertex
        normal at a vertex — so points near edges and vertices get the right sign.

        ``near`` (optional, (k, 3) mm): guesses of the closest points (e.g. the contact
        points under ball centres); they only make the search faster — the result is the
        same bit for bit, ties included (see :func:`_nearest`); or a function returning them,
        called only when this tree searches (the compiled faces' kernel needs no guess).
        """
        if callable(near):
            near = near() if self._faces is None else None
        P = np.ascontiguousarray(np.asarray(points, dtype=np.float64).reshape(-1, 3))
        k = len(P)
        if k == 0:
            z = np.zeros(0)
            return ClosestPoints(z, np.zeros((0, 3)), np.zeros(0, np.int64), np.zeros((0, 3)),
                                 np.zeros(0, np.int8), z)
        if near is not None:
            near = np.ascontiguousarray(np.asarray(near, dtype=np.float64).reshape(-1, 3))
            if near.shape != P.shape:
                raise ValueError(f"MeshDistance.query: near must give one guess per point, "
                                 f"got {len(near)} for {k} points")
        got = self._faces.closest_compiled(P) if self._faces is not None else None
        if got is not None:  # the faces and their closest points, compiled (the same floats)
            face, q, d2, feat, bary = got
        else:
            if self._faces is not None:
                face = self._faces.faces(P)
            else:
                _, face = nearest(self.tree, P, self._d2, fastfn=self._fast_d2, near=near,
                                   keepfn=self._lb_keep)
            V, Ff = self.mesh.V, self.mesh.F[face]  # the rows of A, B, C: the same values
            q, d2, feat, bary = closest_on_triangles(P, V[Ff[:, 0]], V[Ff[:, 1]], V[Ff[:, 2]])
        mesh = self.mesh
        fn = mesh.face_normals
        pn = fn[face]  # (a new array: fancy indexing copies)
        on_edge = (feat >= 1) & (feat <= 3)
        if np.any(on_edge):
            e = mesh.face_edges[face[on_edge], feat[on_edge] - 1]
            ef = mesh.edge_faces[e]
            n2 = np.where((ef[:, 1] >= 0)[:, None], fn[np.maximum(ef[:, 1], 0)], 0.0)
            pn[on_edge] = fn[ef[:, 0]] + n2
        on_vert = feat >= 4
        if np.any(on_vert):
            v = mesh.F[face[on_vert], feat[on_vert] - 4]
            pn[on_vert] = mesh.vertex_normals[v]
        sign = np.sign(dot(P - q, pn))
        return ClosestPoints(np.sqrt(d2), q, face, bary, feat, sign)


def closest_points(mesh: TriMesh, points) -> ClosestPoints:
    """Exact closest points on ``mesh`` to (k, 3) ``points`` (see :class:`MeshDistance`)."""
    return MeshDistance(mesh).query(points)


class NearestFaces:
    """Exact closest points on a :class:`TriMesh` without a whole-mesh tree: k-d trees of
    the face centroids, one per circumradius size class (half an octave each; built on the
    first query, a fraction of a second per million faces), give each point an upper bound u
    (the exact distance to the nearest of the faces of the nearest centroid of each class);
    each class lists the faces whose centroid lies within u + the class's largest
    circumradius (not the mesh's: a few long slivers no longer widen every search), and a face
    is tested exactly only if its lower bounds — centroid distance − circumradius, distance
    to its longest edge − the height of the opposite vertex (tight on thin faces) — do not
    exceed u. For the generator's few, clustered queries (links between passes, the spiral
    blend, the passes' contacts in the orient stage) this costs far less than
    :class:`MeshDistance`'s bounding-volume tree, and it returns the same distances and
    points: the minimum of the same exact point–triangle distances. Of faces at exactly the same
    distance (a point on a shared edge or vertex) the lowest face id wins: a rule of the mesh
    alone. (It used to be "the face last in :class:`MeshDistance`'s leaf order", which needed
    that tree's whole median-split chain, about 1 s per million faces, for every plan with a
    tie; the distances, points and smooth normals are the same either way (to rounding), only
    the face id of a point on an edge can differ, and with it the face whose curvature the
    local-gouge check reads.)

    Parameters
    ----------
    mesh : TriMesh
    disks : bool — the compiled tree keeps a bound per face (7 floats a face) that makes
        queries far off the surface (ball centres) faster; the same answers
    """

    def __init__(self, mesh: TriMesh, *, disks: bool = False):
        self.mesh = mesh
        self._disks = bool(disks)
        self._trees = None
        self._ctree = None  # the compiled kernels' tree (built on first compiled query)
        self._ctree_result = None  # its build started by build_alongside

    def build_alongside(self):
        """Start building the compiled tree on a side thread (:func:`..runtime.alongside`),
        for a caller with other work before its first query (the plan: the passes before the
        orient stage). With one thread, or on the numpy backend, the tree is built on the first
        query, as without this call; the tree, and so every answer, is the same."""
        if self._ctree is None and self._ctree_result is None and extension() is not None:
            V, F, disks = self.mesh.V, self.mesh.F, self._disks
            self._ctree_result = alongside(lambda: compiled_closest.face_tree(V, F, disks))

    def _compiled_tree(self):
        """The compiled tree (built now, or taken from :meth:`build_alongside`)."""
        if self._ctree is None:
            pending, self._ctree_result = self._ctree_result, None
            self._ctree = (pending() if pending is not None else
                           compiled_closest.face_tree(self.mesh.V, self.mesh.F, self._disks))
        return self._ctree

    def _build(self):
        V, F = self.mesh.V, self.mesh.F
        A, B, C = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
        self._A, self._B, self._C = A, B, C
        # ((a + b) + c) / 3: the very operations of V[F].mean(axis=1) (a reduction over the
        # middle axis adds the rows in order, then divides by the count), a third the time
        cen = (A + B + C) / 3.0
        rad2 = np.maximum(np.maximum(dot(A - cen, A - cen), dot(B - cen, B - cen)),
                          dot(C - cen, C - cen))
        rad = np.sqrt(rad2) * (1.0 + 1e-12)
        self._cen, self._rad = cen, rad
        self._scale = float(np.abs(V).max()) if len(V) else 1.0  # for the capsules' pad
        # size classes: circumradius in (rmax / 2^((c+1)/n), rmax / 2^(c/n)], n per octave,
        # the last class everything smaller; one centroid tree per class, searched with
        # u + the largest circumradius of that class
        n = len(F)
        rmax = float(rad.max()) if n else 0.0
        with np.errstate(divide="ignore", invalid="ignore"):
            cls = np.floor(_NF_PER_OCTAVE * np.log2(rmax / rad))
        cls = np.clip(np.nan_to_num(cls, nan=0.0), 0, _NF_CLASSES - 1).astype(np.int64)
        from scipy.spatial import cKDTree  # optional: on first use (~60 ms)

        self._trees = []
        for c in range(_NF_CLASSES):
            ids = np.flatnonzero(cls == c)
            if len(ids):
                kd = cKDTree(cen[ids], balanced_tree=False, compact_nodes=False)
                self._trees.append((ids, float(rad[ids].max()), kd))

    def query(self, points):
        """(point (k, 3), face (k,), bary (k, 3)) — exact closest points to (k, 3) points."""
        P = np.ascontiguousarray(np.asarray(points, dtype=np.float64).reshape(-1, 3))
        k = len(P)
        if k == 0 or self.mesh.n_faces == 0:
            return np.zeros((0, 3)), np.zeros(0, np.int64), np.zeros((0, 3))
        if extension() is not None:
            return self._query_compiled(P)
        if self._trees is None:
            self._build()
        A, B, C = self._A, self._B, self._C
        # the upper bound u: the nearest of the faces of the nearest centroid of each class
        j = np.concatenate([ids[kd.query(P)[1]] for ids, _, kd in self._trees])
        qj = np.tile(np.arange(k), len(self._trees))
        u = np.full(k, np.inf)
        np.minimum.at(u, qj, closest_on_triangles(P[qj], A[j], B[j], C[j])[1])
        u = np.sqrt(u)
        # every face within u of p has its centroid within u + its circumradius ≤ u + the
        # largest circumradius of its class
        slack = 1e-9 * max(1.0, float(np.abs(P).max()))
        qi, f = [], []
        for ids, rc, kd in self._trees:
            lists = kd.query_ball_point(P, u + rc + slack, return_sorted=False)
            cnt = np.fromiter(map(len, lists), dtype=np.int64, count=k)
            qi.append(np.repeat(np.arange(k), cnt))
            f.append(ids[np.fromiter(itertools.chain.from_iterable(lists), dtype=np.int64,
                                     count=int(cnt.sum()))])
        qi, f = np.concatenate(qi), np.concatenate(f)
        # lower bounds: centroid distance − circumradius, then the distance to the face's
        # longest-edge capsule (:func:`_edge_capsules`, tight on thin faces); a face whose
        # bound exceeds u + slack is farther than the best
        pq = P[qi]
        ub = u[qi] + slack
        d = pq - self._cen[f]
        keep = np.sqrt(dot(d, d)) - self._rad[f] <= ub
        pq, ub, qi, f = pq[keep], ub[keep], qi[keep], f[keep]
        a, b, c = A[f], B[f], C[f]
        keep = _capsule_distance(pq, _edge_capsules(a, b, c, self._scale)) <= ub
        qi, f = qi[keep], f[keep]
        q, d2, _, bary = closest_on_triangles(pq[keep], a[keep], b[keep], c[keep])
        best = np.full(k, np.inf)
        np.minimum.at(best, qi, d2)
        win = d2 <= best[qi]
        qw, fw = qi[win], f[win]
        face = np.full(k, np.iinfo(np.int64).max, dtype=np.int64)
        np.minimum.at(face, qw, fw)  # of faces at exactly the best distance, the lowest id
        face[face == np.iinfo(np.int64).max] = -1
        # each (point, face) pair is listed once (a face is in one class): the winner's row
        # of the exact kernel is the closest point (row-wise, the same as computed alone)
        row = np.flatnonzero(f == face[qi])
        if len(row) == k:
            row = row[np.argsort(qi[row], kind="stable")]
            return q[row], face, bary[row]
        q, _, _, bary = closest_on_triangles(P, A[face], B[face], C[face])  # NaN points
        return q, face, bary

    def faces(self, points):
        """(k,) int64 — the face of :meth:`query`'s closest point to each of (k, 3) points
        (the compiled kernel's answer alone, without the closest points, when it runs)."""
        P = np.ascontiguousarray(np.asarray(points, dtype=np.float64).reshape(-1, 3))
        if len(P) and self.mesh.n_faces and extension() is not None:
            return self._compiled_faces(P)
        return self.query(P)[1]

    def closest_compiled(self, P):
        """(face, q, d2, feature, bary) of the compiled kernel for (k, 3) points: its nearest
        faces and ``closest_on_triangles`` of each point and its face, with that function's
        arithmetic (the same floats); None on the numpy backend or without points."""
        if not (len(P) and self.mesh.n_faces and extension() is not None):
            return None
        return compiled_closest.nearest_closest(self._compiled_tree(), P, workers())

    def _compiled_faces(self, P):
        """(k,) the compiled kernel's nearest face of each point (its tree built once)."""
        return compiled_closest.nearest_faces(self._compiled_tree(), P, workers())

    def _query_compiled(self, P):
        """:meth:`query` by the compiled kernel: the same faces (the least squared distance
        of :func:`closest_on_triangles`, then the lowest id), then their closest points
        computed row-wise with that arithmetic — by the kernel itself in the same call
        (:meth:`closest_compiled`: one call instead of a search and ~40 numpy operations,
        which cost more than the search on the plan's few points), or here when the
        installed kernels predate it."""
        got = self.closest_compiled(P)
        if got is not None:
            face, q, _, _, bary = got
            return q, face, bary
        face = self._compiled_faces(P)
        F = self.mesh.F[face]  # face −1 (a NaN point): any face, the point stays NaN
        V = self.mesh.V
        q, _, _, bary = closest_on_triangles(P, V[F[:, 0]], V[F[:, 1]], V[F[:, 2]])
        return q, face, bary
