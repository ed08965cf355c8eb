"""TriMesh.from_arrays: welding, vertex/face maps, NaN handling, orientation (measured)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from blisk_cam.core.errors import MeshError
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.kernels.backend import numpy_only
from tests.support.blades import tube_blade


def _outward_tube(**kw):
    V, F, _ = tube_blade(**kw)
    return V, F[:, ::-1].copy()  # tube_blade is wound inward; this is its outward winding


@pytest.fixture(scope="module")
def tube_arrays():
    V, F = _outward_tube(n_u=48, n_v=12)
    assert _outward_fraction(TriMesh.from_arrays(V, F, orient=False)) > 0.9  # measured, not assumed
    assert _outward_fraction(TriMesh.from_arrays(V, F[:, ::-1], orient=False)) < 0.1
    return V, F


def _outward_fraction(mesh):
    """Share of faces whose normal points away from the tube's axis line (through the vertex
    centroid, along z): a measured 'outward' test for the convex-ish tube sections."""
    d = mesh.V[mesh.F].mean(axis=1) - mesh.V.mean(axis=0)
    d[:, 2] = 0.0
    return float(np.mean(np.einsum("ij,ij->i", mesh.face_normals, d) > 0))


def test_clean_input_is_kept_as_is(tube_arrays):
    V, F = tube_arrays
    m = TriMesh.from_arrays(V, F)
    assert np.array_equal(m.V, V) and np.array_equal(m.F, F)
    assert np.array_equal(m.vertex_map, np.arange(len(V)))
    assert np.array_equal(m.face_map, np.arange(len(F)))
    assert (m.flipped_faces, m.welded_vertices, m.dropped_faces) == (0, 0, 0)


def test_stl_soup_is_welded_and_the_map_points_at_equal_vertices(tube_arrays):
    V, F = tube_arrays
    soup = V[F].reshape(-1, 3)
    m = TriMesh.from_arrays(soup, np.arange(len(soup)).reshape(-1, 3))
    assert m.n_vertices == len(V) and m.welded_vertices == len(soup) - len(V)
    assert np.array_equal(m.V[m.vertex_map], soup)  # every input corner → its own coordinates
    # first occurrence order: mesh vertex k is the k-th distinct corner of the soup
    first = np.unique(m.vertex_map, return_index=True)[1]
    assert np.all(np.diff(first) > 0)


def test_near_duplicates_merge_onto_the_lowest_index_vertex():
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1e-9, 0], [1, 1, 0]], float)
    F = np.array([[0, 1, 2], [3, 4, 2]])
    m = TriMesh.from_arrays(V, F)
    assert m.welded_vertices == 1 and m.n_vertices == 4
    assert m.vertex_map.tolist() == [0, 1, 2, 1, 3]
    assert np.array_equal(m.V[1], V[1])  # the survivor's coordinates, not a mean
    # an explicit zero tolerance merges exact duplicates only
    m0 = TriMesh.from_arrays(V, F, weld_tolerance=0.0)
    assert m0.welded_vertices == 0 and m0.n_vertices == 5


def test_unused_and_unused_nan_vertices_are_dropped_and_mapped_to_minus_one(tube_arrays):
    V, F = tube_arrays
    V2 = np.vstack([V[:5], [[np.nan, 0, 0]], V[5:], [[1e6, 1e6, 1e6]]])
    F2 = np.where(F >= 5, F + 1, F)
    m = TriMesh.from_arrays(V2, F2)
    assert m.vertex_map[5] == -1 and m.vertex_map[-1] == -1
    assert np.array_equal(m.V, V)  # order kept, nothing else moved
    keep = m.vertex_map >= 0
    assert np.array_equal(m.V[m.vertex_map[keep]], V2[keep])


def test_nan_vertex_used_by_a_face_is_refused_with_count_and_first_index(tube_arrays):
    V, F = tube_arrays
    V2 = V.copy()
    V2[[7, 30]] = [np.nan, 0, np.inf]
    with pytest.raises(MeshError, match=r"2 vertices used by faces have NaN or infinite.*vertex 7"):
        TriMesh.from_arrays(V2, F)


def test_degenerate_and_repeated_faces_are_dropped(tube_arrays):
    V, F = tube_arrays
    F2 = np.vstack([F, F[3][::-1], [[0, 0, 1]], F[10][[1, 2, 0]]])
    m = TriMesh.from_arrays(V, F2)
    assert m.dropped_faces == 3 and m.n_faces == len(F)
    assert np.array_equal(m.face_map[: len(F)], np.arange(len(F)))
    assert np.all(m.face_map[len(F):] == -1)


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 2**31 - 1), st.floats(0.0, 1.0))
def test_any_inconsistent_winding_of_the_tube_comes_out_outward(seed, share):
    V, F = _outward_tube(n_u=24, n_v=6)
    ref = TriMesh.from_arrays(V, F, orient=False)
    rng = np.random.default_rng(seed)
    flip = rng.random(len(F)) < share
    Fx = F.copy()
    Fx[flip] = Fx[flip][:, ::-1]
    m = TriMesh.from_arrays(V, Fx)
    # same faces, every one wound as the outward reference, whatever came in
    assert np.allclose(np.einsum("ij,ij->i", m.face_normals, ref.face_normals), 1.0)
    assert m.flipped_faces == int(flip.sum())
    assert _outward_fraction(m) > 0.9


def test_whole_tube_wound_inward_is_turned_outward(tube_arrays):
    V, F = tube_arrays
    m = TriMesh.from_arrays(V, F[:, ::-1])
    assert m.flipped_faces == len(F) and np.array_equal(m.F, F)


def _one_blade_side():
    """A cambered open patch (one side of a blade): no inside of its own."""
    u = np.linspace(-20, 20, 21)
    v = np.linspace(0, 30, 11)
    uu, vv = np.meshgrid(u, v, indexing="ij")
    zz = 3.0 * (1 - (uu / 20.0) ** 2)  # 3 mm sag: its capped volume is far from 0
    V = np.stack([uu, vv, zz], -1).reshape(-1, 3)
    idx = np.arange(len(V)).reshape(len(u), len(v))
    a, b, c, d = idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]
    F = np.vstack([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    return V, F


def test_open_patch_keeps_its_input_winding_either_way():
    V, F = _one_blade_side()
    for Fin in (F, F[:, ::-1]):
        m = TriMesh.from_arrays(V, Fin)
        assert m.flipped_faces == 0 and np.array_equal(m.F, Fin)


def test_open_patch_with_a_minority_of_flipped_faces_takes_the_majority_winding():
    V, F = _one_blade_side()
    rng = np.random.default_rng(1)
    for base in (F, F[:, ::-1]):
        flip = rng.random(len(F)) < 0.3
        Fx = base.copy()
        Fx[flip] = Fx[flip][:, ::-1]
        m = TriMesh.from_arrays(V, Fx)
        assert np.array_equal(m.F, base) and m.flipped_faces == int(flip.sum())


def test_mobius_strip_is_refused():
    n = 40
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    V = []
    for w in (-1.0, 1.0):
        rr = 10 + w * np.cos(t / 2)
        V.append(np.stack([rr * np.cos(t), rr * np.sin(t),
                           w * np.sin(t / 2)], -1))
    V = np.vstack(V)  # rows 0..n−1: w = −1, n..2n−1: w = +1
    i = np.arange(n)
    j = (i + 1) % n
    a, b, c, d = i, j, j + n, i + n
    # the last cell closes with a half twist: its w = +1 row meets the w = −1 row
    c = np.where(i == n - 1, 0, c)
    b = np.where(i == n - 1, n, b)
    F = np.vstack([np.stack([a, b, c], -1), np.stack([a, c, d], -1)])
    with pytest.raises(MeshError, match="not orientable"):
        TriMesh.from_arrays(V, F)


def _kd_pairs(P, tol):
    from scipy.spatial import cKDTree

    pairs = cKDTree(P).query_pairs(tol, output_type="ndarray")
    return {tuple(p) for p in np.sort(pairs, axis=1).tolist()}


def test_weld_close_pairs_are_the_kd_tree_pairs():
    """The close-pair scan along the weld direction finds exactly the pairs a k-d tree finds,
    on clustered points (near duplicates) and on points crowding one plane across the
    direction (the scan gives way to the tree there; the weld's result is the same)."""
    from blisk_cam.core.geometry import weld as M

    rng = np.random.default_rng(3)
    base = rng.random((4000, 3)) * 10.0
    P = np.vstack([base, base[:1500] + rng.normal(scale=4e-6, size=(1500, 3))])
    tol = 1e-5
    order = np.argsort(P @ M._WELD_DIRECTION, kind="stable")
    got = M._close_pairs(P, order, tol)
    assert {tuple(p) for p in got.tolist()} == _kd_pairs(P, tol)
    assert len(got) > 1000  # the clusters were there to find
    # a plane across the direction: every point projects within tol of the others
    e1 = np.cross(M._WELD_DIRECTION, [1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(M._WELD_DIRECTION, e1)
    Q = rng.random((300, 1)) * e1 + rng.random((300, 1)) * e2
    assert M._close_pairs(Q, np.argsort(Q @ M._WELD_DIRECTION, kind="stable"), 0.05) is None


def test_weld_of_rows_sharing_a_projection_is_exact():
    """Distinct vertices with equal projections on the weld direction: the close-pair search
    gives way to the k-d tree; every group of equal rows still maps to its lowest index, and
    a near duplicate still merges."""
    from blisk_cam.core.geometry import weld as M

    rng = np.random.default_rng(4)
    d = M._WELD_DIRECTION
    A = rng.random((200, 3))
    P = np.vstack([A, A[::-1], A[:50]])
    P[5] = [d[1], 0.0, 0.0]  # projection d1 d0
    P[6] = [0.0, d[0], 0.0]  # projection d0 d1: the same number, another row
    want = np.array([np.flatnonzero((P == row).all(axis=1))[0] for row in P])
    assert np.array_equal(M._first_equal_point([P[:, j] + 0.0 for j in range(3)]), want)
    P[7] = P[6] + [1e-9, 0.0, 0.0]  # within the default tolerance (1e-7 × diagonal) of P[6]
    m = TriMesh.from_arrays(P, np.arange(len(P)).reshape(-1, 3), orient=False)
    vm = m.vertex_map
    assert vm[7] == vm[6] != vm[5]
    assert np.array_equal(m.V[vm], np.where(np.arange(len(P))[:, None] == 7, P[6], P))
    assert m.n_vertices == len(np.unique(P, axis=0)) - 1


def test_exact_duplicates_through_hash_collisions_and_the_exact_fallback(monkeypatch):
    """The hash rounds of the weld: every point maps to the lowest index of its equal points,
    including after slot collisions; with a single round the rest goes to the exact lexsort
    fallback, with the same answer."""
    from blisk_cam.core.geometry import weld as M

    rng = np.random.default_rng(8)
    base = rng.integers(-3, 4, size=(3000, 3)).astype(float) * 0.25  # ~340 distinct points
    base[rng.random(3000) < 0.1] *= -1.0  # −0.0 must already be 0.0: the caller adds 0.0
    P = base + 0.0
    _, inv = np.unique(P, axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    low = np.full(inv.max() + 1, len(P))
    np.minimum.at(low, inv, np.arange(len(P)))
    want = low[inv]
    cols = [P[:, j] + 0.0 for j in range(3)]
    assert np.array_equal(M._first_equal_point(cols), want)  # the installed kernels
    calls = []
    exact = M._first_equal_row
    monkeypatch.setattr(M, "_HASH_ROUNDS", 1)
    monkeypatch.setattr(M, "_first_equal_row", lambda K: calls.append(len(K)) or exact(K))
    with numpy_only():  # the numpy reference's rounds and fallback
        assert np.array_equal(M._first_equal_point(cols), want)
    assert calls and 0 < calls[0] < len(P)  # collisions went to the fallback, not everything
    distinct = rng.random((500, 3))
    assert np.array_equal(M._first_equal_point([distinct[:, j] for j in range(3)]),
                          np.arange(500))


def _assert_edge_table_is_a_rebuild(m):
    """The edge table the weld cached (and renumbered for flipped faces) is the one a fresh
    mesh of the same V, F builds."""
    fresh = TriMesh(V=m.V, F=m.F)
    for key in ("edges", "face_edges", "edge_faces", "edge_halfedges"):
        assert np.array_equal(m._edges()[key], fresh._edges()[key]), key


def test_flipped_stl_soup_comes_out_consistently_oriented(tube_arrays):
    """An STL soup with 40 % of its faces flipped: welded, and every edge then traversed once
    in each direction (counted on the directed half-edges, not with the mesh's own tables)."""
    V, F = tube_arrays
    rng = np.random.default_rng(7)
    flip = rng.random(len(F)) < 0.4
    Fx = F.copy()
    Fx[flip] = Fx[flip][:, ::-1]
    soup = V[Fx].reshape(-1, 3)
    m = TriMesh.from_arrays(soup, np.arange(len(soup)).reshape(-1, 3))
    he = np.stack([m.F.ravel(), np.roll(m.F, -1, axis=1).ravel()], axis=1)
    fwd = set(map(tuple, he.tolist()))
    assert len(fwd) == len(he)  # no directed edge twice: no two faces disagree on one
    open_edges = [e for e in fwd if e[::-1] not in fwd]
    assert len(open_edges) == 2 * 48  # only the hub and tip loops (n_u = 48 each)
    assert m.flipped_faces == int(flip.sum()) and _outward_fraction(m) > 0.9
    _assert_edge_table_is_a_rebuild(m)
    m_in = TriMesh.from_arrays(soup, np.arange(len(soup)).reshape(-1, 3)[:, ::-1])
    assert np.array_equal(m_in.F, m.F)  # the whole soup reversed: turned outward as well
    _assert_edge_table_is_a_rebuild(m_in)


def test_a_repeated_face_whose_edges_have_no_third_face_is_dropped(tube_arrays):
    """A lone triangle given twice (reversed or rotated) has edges of two faces only — no
    non-manifold edge shows the repeat; it is still dropped."""
    V, F = tube_arrays
    V2 = np.vstack([V, [[500.0, 0.0, 0.0], [501.0, 0.0, 0.0], [500.0, 1.0, 0.0]]])
    lone = np.array([[len(V), len(V) + 1, len(V) + 2]])
    for again in (lone[:, ::-1], lone[:, [1, 2, 0]]):
        m = TriMesh.from_arrays(V2, np.vstack([F, lone, again]))
        assert m.dropped_faces == 1 and m.n_faces == len(F) + 1
        assert m.face_map[-2] == len(F) and m.face_map[-1] == -1
        _assert_edge_table_is_a_rebuild(m)
