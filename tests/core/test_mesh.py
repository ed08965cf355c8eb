"""TriMesh.from_arrays: welding, vertex/face maps, NaN handling, orientation (measured)."""

import numpy as np
import pytest
from conftest import tube_blade
from hypothesis import given, settings
from hypothesis import strategies as st

from blisk_cam.core.errors import MeshError
from blisk_cam.core.mesh import TriMesh


def _outward_tube(**kw):
    V, F, _ = tube_blade(**kw)
    return V, F[:, ::-1].copy()  # conftest's tube is wound inward; this is its outward winding


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
    from blisk_cam.core import mesh as M

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
    """Distinct vertices with equal projections on the weld direction take the exact bitwise
    path; every group of equal rows still maps to its lowest index."""
    from blisk_cam.core import mesh as M

    rng = np.random.default_rng(4)
    d = M._WELD_DIRECTION
    A = rng.random((200, 3))
    P = np.vstack([A, A[::-1], A[:50]])
    P[5] = [d[1], 0.0, 0.0]  # projection d1 d0
    P[6] = [0.0, d[0], 0.0]  # projection d0 d1: the same number, another row
    first, order = M._first_equal_point(P + 0.0)
    assert order is None
    want = np.array([np.flatnonzero((P == row).all(axis=1))[0] for row in P])
    assert np.array_equal(first, want)
    first2, order2 = M._first_equal_point(np.delete(P, 6, axis=0) + 0.0)
    assert order2 is not None
    Q = np.delete(P, 6, axis=0)
    assert np.array_equal(first2, [np.flatnonzero((Q == r).all(axis=1))[0] for r in Q])
