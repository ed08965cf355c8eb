"""Triangle meshes as arrays: validation, welding, adjacency, orientation, normals, boundaries.

The core never sees a Blender object. A :class:`TriMesh` is built from ``V`` (n, 3) float64
(mm, world frame) and ``F`` (m, 3) int64, checked once at the boundary, and then offers the
topology the slicer needs (unique edges, edge → faces), consistently oriented outward
normals, smooth (interpolated) vertex normals and boundary loops. The user's arrays are
never modified.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from scipy import sparse
from scipy.sparse import csgraph
from scipy.spatial import cKDTree

from .errors import MeshError

__all__ = ["TriMesh", "triangle_normals", "chain_graph_paths"]


def triangle_normals(V, F):
    """Un-normalised face normals (twice the area vector), (m, 3) float."""
    a = V[F[:, 0]]
    return np.cross(V[F[:, 1]] - a, V[F[:, 2]] - a)


def chain_graph_paths(n_nodes: int, links, *, strict: bool = True):
    """Order the nodes of a graph whose nodes have degree ≤ 2 into paths and cycles.

    Parameters
    ----------
    n_nodes : int
    links : (k, 2) int — undirected links between node ids

    Returns
    -------
    list of (order (p,) int, closed bool), one per connected component with at least one link.
    Open paths start at an end node (degree 1). Uses scipy's depth-first order, which on a
    graph of maximum degree 2 visits the nodes in chain order.

    strict : bool — raise :class:`MeshError` on nodes of degree > 2 (non-manifold); with
        False the links at such nodes are dropped, splitting the chains there.
    """
    links = np.asarray(links, dtype=np.int64).reshape(-1, 2)
    if len(links) == 0:
        return []
    g = sparse.coo_matrix(
        (np.ones(len(links)), (links[:, 0], links[:, 1])), shape=(n_nodes, n_nodes)
    ).tocsr()
    g = ((g + g.T) > 0).astype(np.int8)
    deg = np.diff(g.indptr)
    if np.any(deg > 2) and not strict:
        bad = deg > 2
        links = links[~(bad[links[:, 0]] | bad[links[:, 1]])]
        return chain_graph_paths(n_nodes, links, strict=True) if len(links) else []
    if np.any(deg > 2):
        raise MeshError(
            f"{int(np.sum(deg > 2))} places where more than two pieces of a curve meet "
            "(non-manifold mesh); clean the mesh (merge by distance, remove loose and "
            "duplicate faces) and try again"
        )
    ncomp, labels = csgraph.connected_components(g, directed=False)
    used = deg > 0
    comps = np.unique(labels[used])
    out = []
    # one start node per component: an end (degree 1) if there is one, else any node
    order_nodes = np.lexsort((deg != 1, labels))  # by component, ends first
    first_idx = np.searchsorted(labels[order_nodes], comps)
    starts = order_nodes[first_idx]
    for start in starts:
        closed = bool(deg[start] == 2)
        order = csgraph.depth_first_order(g, int(start), directed=False, return_predecessors=False)
        out.append((np.asarray(order, dtype=np.int64), closed))
    return out


@dataclass
class TriMesh:
    """A checked, welded, consistently oriented triangle mesh.

    Attributes
    ----------
    V : (n, 3) float64, mm
    F : (m, 3) int64, counter-clockwise seen from outside (normals out of the material)
    flipped_faces : int — how many input faces had their winding reversed to make it consistent
    welded_vertices : int — how many input vertices were merged into others
    dropped_faces : int — faces removed because two of their corners were the same vertex
    """

    V: np.ndarray
    F: np.ndarray
    flipped_faces: int = 0
    welded_vertices: int = 0
    dropped_faces: int = 0
    _cache: dict = field(default_factory=dict, repr=False)

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_arrays(cls, V, F, *, weld_tolerance: float | None = None, orient: bool = True):
        """Check and prepare a mesh.

        Parameters
        ----------
        V : (n, 3) array-like of float, mm
        F : (m, 3) array-like of int
        weld_tolerance : float, mm — vertices closer than this are merged. Default 1e-7 of the
            bounding-box diagonal (merges the duplicated corners of STL files, nothing else).
        orient : bool — make the winding consistent and the normals point outward.

        Raises
        ------
        MeshError naming the problem (empty, NaN, bad indices, non-manifold, non-orientable).
        """
        V = np.array(V, dtype=np.float64, copy=True)
        F = np.array(F, copy=True)
        if V.ndim != 2 or V.shape[1] != 3:
            raise MeshError(f"vertices must be an (n, 3) array, got shape {V.shape}")
        if F.size == 0 or len(V) == 0:
            raise MeshError("the mesh has no faces: select a mesh object with triangles (or quads)")
        if F.ndim != 2 or F.shape[1] != 3:
            raise MeshError(f"faces must be an (m, 3) array of vertex indices, got shape {F.shape}")
        if not np.issubdtype(F.dtype, np.integer):
            if not np.all(np.isfinite(F)) or np.any(F != np.round(F)):
                raise MeshError("face indices must be integers")
        F = F.astype(np.int64)
        if F.min() < 0 or F.max() >= len(V):
            raise MeshError(
                f"face indices out of range [0, {len(V) - 1}] (found {F.min()}..{F.max()})"
            )
        bad = ~np.all(np.isfinite(V), axis=1)
        if np.any(bad[np.unique(F)]):
            raise MeshError(
                f"{int(np.sum(bad))} vertices have NaN or infinite coordinates; "
                "fix or delete them before generating paths"
            )
        # drop unused vertices (and with them unused NaNs)
        used, F = np.unique(F, return_inverse=True)
        F = F.reshape(-1, 3)
        V = V[used]
        diag = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0)))
        if diag == 0.0:
            raise MeshError("all vertices coincide: the mesh has no extent")
        tol = 1e-7 * diag if weld_tolerance is None else float(weld_tolerance)
        n_before = len(V)
        V, F = _weld(V, F, tol)
        welded = n_before - len(V)
        keep = (F[:, 0] != F[:, 1]) & (F[:, 1] != F[:, 2]) & (F[:, 2] != F[:, 0])
        dropped = int(np.sum(~keep))
        F = F[keep]
        if len(F) == 0:
            raise MeshError("every face is degenerate (corners coincide): the mesh has no area")
        # duplicate faces (same three vertices) would make edges non-manifold
        key = np.sort(F, axis=1)
        _, first = np.unique(key, axis=0, return_index=True)
        if len(first) < len(F):
            dropped += len(F) - len(first)
            F = F[np.sort(first)]
        mesh = cls(V=V, F=F, welded_vertices=welded, dropped_faces=dropped)
        if orient:
            mesh._orient()
        return mesh

    # ------------------------------------------------------------------ topology
    @property
    def n_vertices(self) -> int:
        return len(self.V)

    @property
    def n_faces(self) -> int:
        return len(self.F)

    def _edges(self):
        c = self._cache
        if "edges" not in c:
            F = self.F
            he = np.stack([F, np.roll(F, -1, axis=1)], axis=2).reshape(-1, 2)  # (3m, 2)
            lo = np.minimum(he[:, 0], he[:, 1])
            hi = np.maximum(he[:, 0], he[:, 1])
            key = lo * np.int64(len(self.V)) + hi
            uniq, inv, counts = np.unique(key, return_inverse=True, return_counts=True)
            if np.any(counts > 2):
                raise MeshError(
                    f"{int(np.sum(counts > 2))} edges are shared by more than two faces "
                    "(non-manifold mesh); clean it (merge by distance, delete interior or "
                    "duplicate faces) and try again"
                )
            edges = np.stack([uniq // len(self.V), uniq % len(self.V)], axis=1)
            face_of_he = np.repeat(np.arange(len(F)), 3)
            order = np.argsort(inv, kind="stable")
            inv_sorted = inv[order]
            starts = np.searchsorted(inv_sorted, np.arange(len(uniq)))
            ef = np.full((len(uniq), 2), -1, dtype=np.int64)
            ef[:, 0] = face_of_he[order[starts]]
            second = counts == 2
            ef[second, 1] = face_of_he[order[starts[second] + 1]]
            he_idx = np.full((len(uniq), 2), -1, dtype=np.int64)
            he_idx[:, 0] = order[starts]
            he_idx[second, 1] = order[starts[second] + 1]
            c["edges"] = edges
            c["face_edges"] = inv.reshape(-1, 3)
            c["edge_faces"] = ef
            c["edge_halfedges"] = he_idx
            c["halfedges"] = he
        return c

    @property
    def edges(self) -> np.ndarray:
        """(e, 2) int64 unique edges, lower vertex index first."""
        return self._edges()["edges"]

    @property
    def face_edges(self) -> np.ndarray:
        """(m, 3) int64: edge ids of (v0v1, v1v2, v2v0) of each face."""
        return self._edges()["face_edges"]

    @property
    def edge_faces(self) -> np.ndarray:
        """(e, 2) int64: the one or two faces of each edge (−1 where there is none)."""
        return self._edges()["edge_faces"]

    def _orient(self):
        """Make the winding consistent (per connected component) and the normals outward."""
        c = self._edges()
        ef, hei, he = c["edge_faces"], c["edge_halfedges"], c["halfedges"]
        interior = ef[:, 1] >= 0
        # two faces sharing an edge are consistent when they traverse it in opposite directions
        h0 = he[hei[interior, 0]]
        h1 = he[hei[interior, 1]]
        inconsistent = (h0[:, 0] == h1[:, 0]).astype(np.int8)
        f0, f1 = ef[interior, 0], ef[interior, 1]
        m = len(self.F)
        flip = np.zeros(m, dtype=bool)
        if np.any(inconsistent):
            flip = _parity_flip(m, f0, f1, inconsistent)
            if np.any(flip):
                F = self.F.copy()
                F[flip] = F[flip][:, ::-1]
                self.F = F
                self._cache.clear()
                c = self._edges()
                ef, hei, he = c["edge_faces"], c["edge_halfedges"], c["halfedges"]
                h0 = he[hei[interior, 0]]
                h1 = he[hei[interior, 1]]
                if np.any(h0[:, 0] == h1[:, 0]):
                    raise MeshError(
                        "the mesh is not orientable (a Möbius-like strip or inconsistent "
                        "duplicate surfaces); recalculate normals in Blender or clean the mesh"
                    )
        # outward: capped signed volume of each connected component
        ncomp, labels = csgraph.connected_components(
            sparse.coo_matrix((np.ones(len(f0)), (f0, f1)), shape=(m, m)), directed=False
        )
        vol = self._capped_signed_volume(labels, ncomp)
        inward = vol < 0
        if np.any(inward):
            F = self.F.copy()
            sel = inward[labels]
            F[sel] = F[sel][:, ::-1]
            flip ^= sel
            self.F = F
            self._cache.clear()
        self.flipped_faces = int(np.sum(flip))

    def _capped_signed_volume(self, labels, ncomp):
        """Signed volume per face component with every boundary loop closed by a fan to its
        centroid (so an open blade tube — hub and tip left open — has a meaningful sign)."""
        V, F = self.V, self.F
        a, b, cc = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
        ref = V.mean(axis=0)
        per_face = np.einsum("ij,ij->i", a - ref, np.cross(b - ref, cc - ref)) / 6.0
        vol = np.bincount(labels, weights=per_face, minlength=ncomp)
        for loop in self.boundary_loops():
            pts = V[loop]
            cen = pts.mean(axis=0)
            nxt = np.roll(pts, -1, axis=0)
            # boundary half-edges run in face order; the cap closes them in the same sense
            cap = np.einsum("ij,ij->i", nxt - ref, np.cross(pts - ref, np.broadcast_to(cen - ref, pts.shape)))
            face = self._boundary_face_of_vertex(loop[0])
            vol[labels[face]] += cap.sum() / 6.0
        return vol

    def _boundary_face_of_vertex(self, v):
        rows = np.nonzero(np.any(self.F == v, axis=1))[0]
        return int(rows[0])

    def boundary_loops(self):
        """Boundary loops as lists of vertex ids, each ordered along the face winding.

        Returns
        -------
        list of (k,) int64 arrays (a closed loop does not repeat its first vertex).
        """
        c = self._cache
        if "loops" not in c:
            e = self._edges()
            boundary = e["edge_faces"][:, 1] < 0
            he = e["halfedges"][e["edge_halfedges"][boundary, 0]]  # directed as in the face
            loops = []
            if len(he):
                nxt = np.full(len(self.V), -1, dtype=np.int64)
                nxt[he[:, 0]] = he[:, 1]
                # strict=False: a bow-tie vertex (two loops touching) splits the chains there
                for order, _closed in chain_graph_paths(len(self.V), he, strict=False):
                    if len(order) >= 2 and nxt[order[0]] != order[1]:
                        order = order[::-1]
                    loops.append(order)
            c["loops"] = loops
        return c["loops"]

    # ------------------------------------------------------------------ geometry
    @cached_property
    def bbox_diagonal(self) -> float:
        return float(np.linalg.norm(self.V.max(axis=0) - self.V.min(axis=0)))

    @property
    def face_normals(self) -> np.ndarray:
        """(m, 3) unit face normals (zero for zero-area faces)."""
        c = self._cache
        if "fn" not in c:
            n = triangle_normals(self.V, self.F)
            ln = np.linalg.norm(n, axis=1)
            c["fn_area2"] = ln
            c["fn"] = n / np.where(ln > 0, ln, 1.0)[:, None]
        return c["fn"]

    @property
    def face_areas(self) -> np.ndarray:
        """(m,) face areas, mm²."""
        self.face_normals
        return self._cache["fn_area2"] * 0.5

    @property
    def vertex_normals(self) -> np.ndarray:
        """(n, 3) unit vertex normals: area-weighted mean of the incident face normals.

        Area weighting, not angle weighting: on scanned meshes a sliver triangle has a
        near-180° corner whose (noisy, possibly flipped) normal would dominate an angle-
        weighted mean, while its area, and so its weight, is ~0."""
        c = self._cache
        if "vn" not in c:
            n2 = triangle_normals(self.V, self.F)  # twice the area vector
            acc = np.zeros_like(self.V)
            for k in range(3):
                acc += _scatter_add(len(self.V), self.F[:, k], n2)
            ln = np.linalg.norm(acc, axis=1)
            c["vn"] = acc / np.where(ln > 0, ln, 1.0)[:, None]
        return c["vn"]

    def interpolate_normals(self, faces, bary):
        """Smooth normals at points given by face ids (k,) and barycentric coords (k, 3)."""
        vn = self.vertex_normals
        F = self.F[np.asarray(faces)]
        b = np.asarray(bary, dtype=np.float64)
        n = (vn[F] * b[:, :, None]).sum(axis=1)
        ln = np.linalg.norm(n, axis=1)
        return n / np.where(ln > 0, ln, 1.0)[:, None]


def _scatter_add(n, idx, values):
    """Sum (k, 3) values into (n, 3) rows by index, vectorised with bincount."""
    out = np.empty((n, values.shape[1]))
    for j in range(values.shape[1]):
        out[:, j] = np.bincount(idx, weights=values[:, j], minlength=n)
    return out


def _weld(V, F, tol):
    """Merge vertices closer than ``tol``; returns new (V, F)."""
    # exact duplicates first (the common STL case), cheaply
    uniq, inv = np.unique(V, axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    if tol > 0 and len(uniq) > 1:
        pairs = cKDTree(uniq).query_pairs(tol, output_type="ndarray")
        if len(pairs):
            g = sparse.coo_matrix(
                (np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(uniq), len(uniq))
            )
            _, lab = csgraph.connected_components(g, directed=False)
            # representative: mean of each cluster
            cnt = np.bincount(lab)
            rep = _scatter_add(lab.max() + 1, lab, uniq) / cnt[:, None]
            uniq, inv = rep, lab[inv]
    return uniq, inv[F]


def _parity_flip(m, f0, f1, inconsistent):
    """Solve flip[f0] xor flip[f1] = inconsistent over a spanning forest (vectorised).

    Builds a BFS tree per component and accumulates the parity to the root by pointer
    jumping (O(m log m)), no per-face Python loop.
    """
    w = inconsistent.astype(np.float64) + 1.0  # 1 = consistent, 2 = flip (weights > 0)
    g = sparse.coo_matrix((w, (f0, f1)), shape=(m, m)).tocsr()
    g = g.maximum(g.T)
    ncomp, labels = csgraph.connected_components(g, directed=False)
    pred = np.full(m, -9999, dtype=np.int64)
    roots = np.unique(labels, return_index=True)[1]
    tree_parity = np.zeros(m, dtype=np.int8)
    for r in roots:
        _, p = csgraph.breadth_first_order(g, int(r), directed=False, return_predecessors=True)
        sel = p >= 0
        pred[sel] = p[sel]
    has = pred >= 0
    idx = np.nonzero(has)[0]
    tree_parity[idx] = (np.asarray(g[idx, pred[idx]]).ravel() > 1.5).astype(np.int8)
    anc = np.where(has, pred, np.arange(m))
    par = tree_parity.copy()
    for _ in range(int(np.ceil(np.log2(max(m, 2)))) + 1):
        par = par ^ par[anc]
        anc = anc[anc]
    # par[v] is now the xor of the tree edges from v to its root: flip v relative to the root
    return par.astype(bool)
