"""From a triangle soup to an indexed, consistently oriented mesh: the user's arrays checked
(:func:`input_vertex_values`), coincident corners welded (exact duplicates by a hash table,
close ones within the weld tolerance by a scan along one direction or a k-d tree), degenerate
and repeated faces dropped, and the edge table with the face-orientation parity the
:class:`~.mesh.TriMesh` orientation uses. Vertex order is kept (the first of equal corners
wins). Lengths in mm.
"""

from __future__ import annotations

import numpy as np

from ..errors import MeshError
from ..kernels import mesh_orient as compiled_orient
from ..kernels import weld as compiled_weld
from ..kernels import weld_near as compiled_near
from ..runtime import workers

__all__ = ["input_vertex_values"]


#: a unit direction in no special relation to the coordinate axes or common planes: the
#: weld sorts the vertices by their projection on it
_WELD_DIRECTION = np.array([0.5377, 0.6233, 0.5677]) / np.linalg.norm([0.5377, 0.6233, 0.5677])


#: the close-pair scan along that projection gives way to a k-d tree when a vertex has more
#: than this many others within the weld tolerance of its projection
_WELD_SCAN_MAX = 32


#: odd 64-bit multipliers of the weld's hash rounds (the golden ratio's and the mixing
#: constants of MurmurHash3 / xxHash64 / SplitMix64)
_HASH_MULT = np.array(
    [0x9E3779B97F4A7C15, 0xC2B2AE3D27D4EB4F, 0x165667B19E3779F9, 0xFF51AFD7ED558CCD,
     0xC4CEB9FE1A85EC53, 0x94D049BB133111EB, 0xBF58476D1CE4E5B9, 0x27D4EB2F165667C5],
    dtype=np.uint64,
)


#: rounds of the hash table before the exact fallback (≤ len(_HASH_MULT))
_HASH_ROUNDS = 8


def _first_equal_point(cols):
    """For each point, the index of the first point equal to it, (k,) int64.

    Parameters
    ----------
    cols : three (k,) float64 arrays — the x, y, z coordinates (finite, no −0.0, so equal
        coordinates are equal bits)

    A hash table built in vectorised rounds, no sort: each point's 64-bit hash of its bits
    (multiplicative hashing, Knuth TAOCP vol. 3 §6.4) picks a slot of a table with ≥ k slots;
    the slot keeps the lowest index of the points landing in it. A point whose coordinates
    equal its slot holder's has found its first equal point (the holder is the lowest index
    of everything in the slot, so of the point's group). The groups that lost their slot to
    another group — all of a group's points share a slot — try again in a fresh table with
    another multiplier; every round settles at least the group of each occupied slot's
    holder, in practice all but a few per cent. What is left after ``_HASH_ROUNDS`` rounds
    (never seen) is grouped exactly by :func:`_first_equal_row`. O(k) expected; about 2x
    faster than one stable argsort of the 3M corners of a 1M-triangle STL.
    """
    first = compiled_weld.first_equal_point(*cols)
    if first is not None:  # the compiled kernel: the same answer
        return first
    c = [x.view(np.uint64) for x in cols]
    k = len(c[0])
    idx_t = np.int32 if k < 2**31 - 1 else np.int64
    with np.errstate(over="ignore"):  # multiplicative hashing: the top bits are the mixed ones
        h = c[0] * _HASH_MULT[0]
        h ^= c[1]
        h *= _HASH_MULT[1]
        h ^= c[2]
        h *= _HASH_MULT[2]
    first = None
    act = None  # the unsettled points (None: all)
    ha, ca = h, c
    for r in range(_HASH_ROUNDS):
        n = k if act is None else len(act)
        bits = max((n - 1).bit_length(), 1)
        with np.errstate(over="ignore"):
            slot = ((ha if r == 0 else ha * _HASH_MULT[r]) >> np.uint64(64 - bits)).view(np.intp)
        ids = np.arange(k, dtype=idx_t) if act is None else act.astype(idx_t)
        table = np.empty(1 << bits, dtype=idx_t)
        # the lowest index of each slot: written last when writing in descending order, as
        # numpy does; checked, and taken by np.minimum.at (2x slower) if it was not so
        table[slot[::-1]] = ids[::-1]
        cand = table[slot]
        if np.any(cand > ids):
            np.minimum.at(table, slot, ids)
            cand = table[slot]
        cand = cand.astype(np.intp)
        eq = c[0][cand] == ca[0]
        eq &= c[1][cand] == ca[1]
        eq &= c[2][cand] == ca[2]
        if act is None:
            first = cand
            if eq.all():
                return first
            act = np.flatnonzero(~eq)
        else:
            first[act[eq]] = cand[eq]
            act = act[~eq]
            if len(act) == 0:
                return first
        ha, ca = h[act], [x[act] for x in c]
    sub = _first_equal_row(np.stack(ca, axis=1).view(np.int64))
    first[act] = act[sub]  # act ascends and holds whole groups: act[sub] is the group's first
    return first


def _first_equal_row(K):
    """For each row of an integer array (k, c), the index of the first row equal to it.

    Rows are grouped by a 64-bit mix of their columns, sorted stably (so the first of a group
    is its lowest index); a hash collision is detected exactly and falls back to a lexsort.
    O(k log k) on one int64 key instead of ``np.unique(axis=0)`` on rows.
    """
    K = np.ascontiguousarray(K, dtype=np.int64)
    k = len(K)
    if k == 0:
        return np.zeros(0, dtype=np.int64)
    if K.shape[1] == 1:
        h = K[:, 0]
    else:
        with np.errstate(over="ignore"):
            h = np.zeros(k, dtype=np.int64)
            for j in range(K.shape[1]):
                h = (h ^ K[:, j]) * np.int64(-7046029254386353131)  # 0x9E3779B97F4A7C15 (odd)
                h ^= h >> np.int64(29)
    order = np.argsort(h, kind="stable")
    hs = h[order]
    head = np.ones(k, dtype=bool)
    head[1:] = hs[1:] != hs[:-1]
    grp_first = order[np.maximum.accumulate(np.where(head, np.arange(k), 0))]
    if not np.array_equal(K[order], K[grp_first]):  # a collision: exact (slower) path
        order = np.lexsort(K.T[::-1])
        Ks = K[order]
        head[1:] = np.any(Ks[1:] != Ks[:-1], axis=1)
        grp_first = order[np.maximum.accumulate(np.where(head, np.arange(k), 0))]
    first = np.empty(k, dtype=np.int64)
    first[order] = grp_first
    return first


def _checked_arrays(V, F):
    """(V (n, 3) float64, F (m, 3) int64, used (n,) bool): the input arrays checked (shapes,
    indices, finite used vertices); raises MeshError naming the problem."""
    V = np.asarray(V, dtype=np.float64)  # never written to: every result is a new array
    F = np.asarray(F)
    if V.ndim != 2 or V.shape[1] != 3:
        raise MeshError(f"vertices must be an (n, 3) array, got shape {V.shape}")
    if F.size == 0 or len(V) == 0:
        raise MeshError("the mesh has no faces: select a mesh object with triangles (or quads)")
    if F.ndim != 2 or F.shape[1] != 3:
        raise MeshError(f"faces must be an (m, 3) array of vertex indices, got shape {F.shape}")
    if not np.issubdtype(F.dtype, np.integer):
        if not np.all(np.isfinite(F)) or np.any(F != np.round(F)):
            raise MeshError("face indices must be integers")
    F = F.astype(np.int64, copy=False)
    n_in = len(V)
    fmin, fmax = int(F.min()), int(F.max())
    if fmin < 0 or fmax >= n_in:
        raise MeshError(f"face indices out of range [0, {n_in - 1}] (found {fmin}..{fmax})")
    used = np.zeros(n_in, dtype=bool)
    used[F.ravel()] = True
    bad = None if np.isfinite(V).all() else used & ~np.all(np.isfinite(V), axis=1)
    if bad is not None and np.any(bad):
        raise MeshError(f"{int(np.sum(bad))} vertices used by faces have NaN or infinite "
                        f"coordinates (the first is vertex {int(np.argmax(bad))}); fix or delete "
                        "them before generating paths")
    return V, F, used


def _welded(V, used, weld_tolerance, distinct=False):
    """The used vertices welded (exact duplicates, then clusters closer than the tolerance, to
    their lowest input id): (V (k, 3), vertex_map (n,) input → mesh vertex or -1, number
    welded). ``distinct``: no two vertices are equal (−0.0 as 0.0), the exact pass is known
    (the caller welded exactly already)."""
    n_in = len(V)
    Vu = V if used.all() else V[used]
    iu = None if Vu is V else np.nonzero(used)[0]  # None: every input vertex is used
    # representative (lowest input index) of every used vertex: exact duplicates, then
    # clusters closer than tol. + 0.0 turns −0.0 into 0.0. The compiled kernel reads the
    # rows; the reference hashes contiguous columns
    if distinct:  # every vertex its own representative
        first = pos = np.arange(len(Vu))
    else:
        first = compiled_weld.first_equal_rows(Vu)
        if first is None:
            first = _first_equal_point([Vu[:, j] + 0.0 for j in range(3)])
        pos = np.flatnonzero(first == np.arange(len(first)))  # the representatives, ascending
    # every used vertex equals one of them (all of them: pos is every row, no gather)
    rows = Vu[pos] if len(pos) < len(Vu) else Vu
    rcols = None
    extent = compiled_near.weld_extents(rows)  # the same values, no column copies
    if extent is None:
        rcols = list((rows + 0.0).T)
        extent = [c.max() - c.min() for c in rcols]
    diag = float(np.linalg.norm(extent))
    if diag == 0.0:
        raise MeshError("all vertices coincide: the mesh has no extent")
    tol = 1e-7 * diag if weld_tolerance is None else float(weld_tolerance)
    if not np.isfinite(tol) or tol < 0:
        raise MeshError(f"weld tolerance must be a finite number ≥ 0 mm, got {weld_tolerance}")
    rep = first if iu is None else iu[first]
    ir = pos if iu is None else iu[pos]  # the representatives' input ids
    merged = False
    # all used and distinct (an STL welded as read): the compiled scan says when numpy's
    # finds no pair (nothing to merge), without its projections and sort
    clear = (distinct and iu is None and tol > 0
             and compiled_near.weld_no_close_pairs(V, _WELD_DIRECTION, tol, _WELD_SCAN_MAX))
    if tol > 0 and len(pos) > 1 and not clear:  # clusters closer than tol: lowest input id
        d = _WELD_DIRECTION
        if rcols is None:
            rcols = list((rows + 0.0).T)
        u = (rcols[0] * d[0] + rcols[1] * d[1]) + rcols[2] * d[2]
        u_order = np.argsort(u, kind="stable")
        us = u[u_order]
        pairs = None
        if not np.any(us[1:] == us[:-1]):  # distinct vertices, distinct projections
            pairs = _close_pairs(V, ir[u_order], tol, u=us)
        if pairs is None:  # vertices sharing a projection, or crowding one across it
            from scipy.spatial import cKDTree  # optional: on first use (~60 ms)

            pairs = cKDTree(V[ir], balanced_tree=False, compact_nodes=False).query_pairs(
                tol, output_type="ndarray"
            )
            pairs = ir[pairs] if len(pairs) else np.zeros((0, 2), dtype=np.int64)
        if len(pairs):
            from scipy import sparse  # optional: only for vertices within the tolerance
            from scipy.sparse import csgraph  # optional: as above

            loc = np.searchsorted(ir, pairs)  # input ids → positions among the reps
            g = sparse.coo_matrix(
                (np.ones(len(loc)), (loc[:, 0], loc[:, 1])), shape=(len(ir), len(ir))
            )
            _, lab = csgraph.connected_components(g, directed=False)
            low = np.full(lab.max() + 1, n_in, dtype=np.int64)
            np.minimum.at(low, lab, ir)
            remap = np.arange(n_in)
            remap[ir] = low[lab]
            rep = remap[rep]
            merged = True
    if merged or iu is not None:
        is_rep = np.zeros(n_in, dtype=bool)
        is_rep[rep] = True
        new_id = np.cumsum(is_rep, dtype=np.int64)
        new_id -= 1
        vertex_map = np.full(n_in, -1, dtype=np.int64)
        vertex_map[iu if iu is not None else slice(None)] = new_id[rep]
        V = V[is_rep]
    else:  # every vertex used, exact duplicates only: mesh vertex i is representative i
        rank = np.empty(n_in, dtype=np.int64)
        rank[pos] = np.arange(len(pos))
        vertex_map = rank[first]
        V = V[pos]
    welded = len(first) - len(V)
    return V, vertex_map, welded


def _close_pairs(V, ids, tol, u=None):
    """All pairs (p, 2) of the points ``ids`` (sorted by their projection on
    ``_WELD_DIRECTION``) at most ``tol`` apart, as ``cKDTree.query_pairs`` finds them: two
    such points have projections at most ``tol`` apart, so only neighbours in that order
    within ``tol`` of projection are measured. ``None`` when a point has more than
    ``_WELD_SCAN_MAX`` such neighbours (points crowding one plane across the direction: the
    caller then asks a k-d tree). ``u`` : (len(ids),) float — the projections of ``V[ids]``
    if the caller has them (computed as here)."""
    d = _WELD_DIRECTION
    if u is None:
        P = V[ids]
        u = (P[:, 0] * d[0] + P[:, 1] * d[1]) + P[:, 2] * d[2]
    slack = tol * (1.0 + 1e-9) + 1e-12 * max(float(u[-1]), -float(u[0]), 0.0)
    out = []
    near = np.flatnonzero(u[1:] - u[:-1] <= slack)
    for o in range(1, _WELD_SCAN_MAX + 2):
        if o > 1:
            # u[i + o] − u[i] ≤ slack needs u[i + o − 1] − u[i] ≤ slack (u ascends, rounding
            # is monotone): only the previous offset's survivors are measured
            near = near[near < len(u) - o]
            near = near[u[near + o] - u[near] <= slack]
        if len(near) == 0:
            break
        if o > _WELD_SCAN_MAX:
            return None
        a, b = ids[near], ids[near + o]
        diff = V[b] - V[a]
        d2 = diff[:, 0] * diff[:, 0] + diff[:, 1] * diff[:, 1] + diff[:, 2] * diff[:, 2]
        close = d2 <= tol * tol
        out.append(np.stack([a[close], b[close]], axis=1))
    if not out:
        return np.zeros((0, 2), dtype=np.int64)
    pairs = np.concatenate(out)
    return np.sort(pairs, axis=1)


def _kept_faces(F, nv_mesh):
    """Faces without equal corners and without repeats: (keep (m,) bool, F[keep], the edge
    table dict or None, its interior pairs or None — None also when the compiled kernels
    did not need them); raises MeshError if none is left."""
    keep = (F[:, 0] != F[:, 1]) & (F[:, 1] != F[:, 2]) & (F[:, 2] != F[:, 0])
    if not np.any(keep):
        raise MeshError("every face is degenerate (corners coincide): the mesh has no area")
    # repeated faces (same three vertices) would make their edges non-manifold. Without
    # an edge of three or more faces, two faces repeat each other exactly when they share
    # an edge and the corner opposite it: checked on the edge table, which the mesh keeps.
    # An edge of more faces (repeats, or non-manifold) takes the search over all faces.
    Fk = F if keep.all() else F[keep]
    try:
        topo = _edge_table(Fk, nv_mesh)
    except MeshError:
        topo = None
    pairs = None
    repeats = True
    if topo is not None:
        # compiled: read from the edge table, no pairs built (the orientation then reads the
        # table too); numpy: the pairs, kept for the orientation
        repeats = compiled_orient.repeats_on_edges(Fk, topo["edge_halfedges"], workers())
        if repeats is None:
            pairs = _interior_pairs(topo)
            repeats = _repeats_on_edges(Fk, *pairs)
    if repeats:
        topo = pairs = None
        kept = np.nonzero(keep)[0]
        Fs = np.sort(F[kept], axis=1)
        nv = np.int64(nv_mesh)
        if nv_mesh < 2_000_000:  # n³ < 2⁶³: one exact int64 key per face, in near-sorted runs
            first = _first_equal_row(((Fs[:, 0] * nv + Fs[:, 1]) * nv + Fs[:, 2])[:, None])
        else:
            first = _first_equal_row(Fs)
        keep[kept[first != np.arange(len(kept))]] = False
        Fk = F[keep]
    return keep, Fk, topo, pairs


def _edge_table(F, n):
    """The edges of faces F (m, 3) int64 over n vertices, as a dict of arrays:

    * ``edges`` (e, 2) int64 — unique edges, lower vertex first, sorted;
    * ``face_edges`` (m, 3) — edge ids of (v0v1, v1v2, v2v0) of each face;
    * ``edge_halfedges`` (e, 2) — the half-edges (3f + k runs from corner k to corner k + 1
      of face f) of each edge, ascending, −1 where there is no second;
    * ``edge_faces`` (e, 2) — their faces (−1 where there is none).

    Raises MeshError when an edge has more than two faces (non-manifold).
    The compiled kernel gives the same arrays by a counting sort (None: this reference).
    """
    got = compiled_weld.edge_table(F, n, workers())  # the same arrays on any threads
    if got is not None:
        return got
    n = np.int64(n)
    # int64 as the kernel reads them: an int32 F (numpy 1.x's default int on Windows) would
    # overflow the key lower * n + higher in place past 46 341 vertices
    F = np.asarray(F, dtype=np.int64)
    ha = F.ravel()
    hb = F[:, [1, 2, 0]].ravel()
    key = np.minimum(ha, hb)
    key *= n
    key += np.maximum(ha, hb)  # lower * n + higher vertex
    del hb
    # stable sort: the keys come in long sorted runs (faces share vertices in order),
    # which timsort exploits (~4x faster than np.unique's quicksort on 4M half-edges)
    order = np.argsort(key, kind="stable")
    ks = key[order]
    del key
    head = np.empty(len(ks), dtype=bool)
    head[0] = True
    np.not_equal(ks[1:], ks[:-1], out=head[1:])
    starts = np.flatnonzero(head)
    counts = np.diff(starts, append=len(ks))
    if np.any(counts > 2):
        raise MeshError(
            f"{int(np.sum(counts > 2))} edges are shared by more than two faces "
            "(non-manifold mesh); clean it (merge by distance, delete interior or "
            "duplicate faces) and try again"
        )
    uniq = ks[starts]
    del ks
    edge_id = np.cumsum(head, dtype=np.int64)
    edge_id -= 1
    inv = np.empty(len(order), dtype=np.int64)
    inv[order] = edge_id
    del edge_id
    he1 = order.take(starts + 1, mode="clip")  # the second half-edge, where counts == 2
    he1[counts == 1] = -1
    he_idx = np.stack([order[starts], he1], axis=1)
    lo = uniq // n
    return {
        "edges": np.stack([lo, uniq - lo * n], axis=1),
        "face_edges": inv.reshape(-1, 3),
        "edge_faces": he_idx // 3,  # floor division: −1 stays −1
        "edge_halfedges": he_idx,
    }


def _halfedge_ends(F, h):
    """(len(h), 2) int64: from and to vertex of the half-edges h (3f + k runs from corner k
    to corner k + 1 of face f, F (m, 3))."""
    f, k = np.divmod(h, 3)
    return np.stack([F[f, k], F[f, (k + 1) % 3]], axis=1)


def _interior_pairs(topo):
    """(h0, h1, f0, f1): the two half-edges (p,) of each edge of two faces, in edge order, and
    their faces, from an edge table (:func:`_edge_table`)."""
    hei = topo["edge_halfedges"]
    got = compiled_weld.interior_pairs(hei)  # the same arrays in one pass
    if got is not None:
        return got
    two = hei[:, 1] >= 0
    h0, h1 = hei[two, 0], hei[two, 1]
    return h0, h1, h0 // 3, h1 // 3


def _repeats_on_edges(F, h0, h1, f0, f1):
    """Whether two faces of F (m, 3) repeat each other (the same three vertices, in any
    order), given the :func:`_interior_pairs` of their edge table (no edge of more than two
    faces). Such faces share all their edges; two faces sharing an edge (a, b) are repeats
    exactly when the corners opposite it are one vertex, that is when their vertex ids have
    the same sum (a + b + c)."""
    total = F[:, 0] + F[:, 1] + F[:, 2]
    return bool(np.any(total[f0] == total[f1]))


def _parity_flip(m, f0, f1, inconsistent, labels, ncomp):
    """Faces to flip so that flip[f0] xor flip[f1] = inconsistent on every interior edge.

    Solved on a BFS spanning forest (parity to the root accumulated by pointer jumping,
    O(m log m), no per-face Python loop); per component the smaller of the two classes is
    flipped (ties: the class of the lowest-index face, the BFS root, is kept).
    """
    from scipy import sparse  # optional: only a mesh with inconsistent windings needs it
    from scipy.sparse import csgraph  # optional: as above

    w = inconsistent.astype(np.float64) + 1.0  # 1 = consistent, 2 = flip (weights > 0)
    g = sparse.coo_matrix((w, (f0, f1)), shape=(m, m)).tocsr()
    g = g.maximum(g.T)
    size = np.bincount(labels, minlength=ncomp)
    roots = np.unique(labels, return_index=True)[1]
    roots = roots[size[labels[roots]] > 1]
    pred = np.full(m, -9999, dtype=np.int64)
    for r in roots:
        _, p = csgraph.breadth_first_order(g, int(r), directed=False, return_predecessors=True)
        sel = p >= 0
        pred[sel] = p[sel]
    has = pred >= 0
    idx = np.nonzero(has)[0]
    tree_parity = np.zeros(m, dtype=np.int8)
    tree_parity[idx] = (np.asarray(g[idx, pred[idx]]).ravel() > 1.5).astype(np.int8)
    anc = np.where(has, pred, np.arange(m))
    par = tree_parity.copy()
    for _ in range(int(np.ceil(np.log2(max(m, 2)))) + 1):
        par = par ^ par[anc]
        anc = anc[anc]
    # par[v] is now the xor of the tree edges from v to its root: flip v relative to the root
    par = par.astype(bool)
    invert = 2 * np.bincount(labels, weights=par, minlength=ncomp) > size
    return par ^ invert[labels]


def input_vertex_values(mesh, V, values) -> np.ndarray:
    """Per-vertex values of a ``TriMesh`` carried back to the input vertices ``V`` (n, 3).

    Uses ``mesh.vertex_map`` ((n,) input → mesh vertex, −1 if dropped) when the mesh has it;
    otherwise the nearest mesh vertex within the weld distance (1e-6 of the bounding-box
    diagonal), NaN where there is none.
    """
    values = np.asarray(values, dtype=np.float64)
    vmap = getattr(mesh, "vertex_map", None)
    if vmap is not None and len(vmap) == len(V):
        vmap = np.asarray(vmap, dtype=np.int64)
        return np.where(vmap >= 0, values[np.maximum(vmap, 0)], np.nan)
    tol = 1e-6 * max(float(np.linalg.norm(np.ptp(mesh.V, axis=0))), 1e-12)
    from scipy.spatial import cKDTree  # optional: on first use (~60 ms)

    dist, idx = cKDTree(mesh.V).query(V, k=1, distance_upper_bound=tol)
    ok = np.isfinite(dist)
    out = np.full(len(V), np.nan)
    out[ok] = values[idx[ok]]
    return out
