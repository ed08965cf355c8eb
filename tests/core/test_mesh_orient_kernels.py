"""The compiled orientation pass of ``TriMesh`` (the face components by union–find over the
edge table, the repeat check read from it, one pass for the faces' area vectors, unit
normals, areas and per-component volume and area sums) against the numpy/scipy reference:
the same labels, counts and decisions, and the same bits for every float (numpy's einsum
adds a row's three products in an order that depends on its SIMD loop; the kernel is told
which)."""

import numpy as np
from scipy import sparse
from scipy.sparse import csgraph

from blisk_cam.core.geometry import weld
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.kernels import backend, mesh_orient
from tests.support.kernels import needs_compiled
from tests.support.mesh_files import icosphere

kernel = needs_compiled("face_components", "repeats_on_edges", "orient_face_terms")


def _bits(a, b, where):
    assert a.dtype == b.dtype and a.shape == b.shape, where
    assert np.array_equal(a.view(np.uint8), b.view(np.uint8)), where


def _pieces():
    """Two spheres (one inside out), an open patch and a lone zero-area face (collinear
    corners), faces shuffled and a tenth of them reversed: V (n, 3), F (m, 3)."""
    V1, F1 = icosphere(2)
    V2 = V1 * 0.5 + [3.0, 0.0, 0.0]
    x, y = np.meshgrid(np.linspace(0, 2, 6), np.linspace(0, 1, 4))
    V3 = np.stack([x.ravel() - 5.0, y.ravel(), 0.05 * x.ravel() ** 2], axis=1)
    i = (np.arange(5)[None, :] + 6 * np.arange(3)[:, None]).ravel()
    F3 = np.concatenate([np.stack([i, i + 1, i + 7], 1), np.stack([i, i + 7, i + 6], 1)])
    V4 = np.array([[0.0, 9.0, 0.0], [1.0, 9.0, 0.0], [2.0, 9.0, 0.0]])
    V = np.concatenate([V1, V2, V3, V4])
    n1, n2, n3 = len(V1), len(V1) + len(V2), len(V1) + len(V2) + len(V3)
    F = np.concatenate([F1, F1[:, ::-1] + n1, F3 + n2, [[n3, n3 + 1, n3 + 2]]])
    rng = np.random.default_rng(5)
    F = F[rng.permutation(len(F))]
    flip = rng.random(len(F)) < 0.1
    F[flip] = F[flip][:, ::-1]
    return V, F


def test_the_einsum_order_probe_tells_numpy_s_order():
    """The order the probe reports is the one numpy's einsum adds a row's products in, on
    rows of mixed magnitudes and signs (where the orders give different last bits)."""
    order = mesh_orient.einsum_outer_first()
    assert order is not None  # measured: (p0 + p2) + p1 here (numpy 1.26, SSE/AVX-512)
    rng = np.random.default_rng(4)
    a = rng.normal(size=(100_000, 3)) * 10.0 ** rng.integers(-3, 4, size=(100_000, 3))
    b = rng.normal(size=(100_000, 3))
    p = a * b
    want = (p[:, 0] + p[:, 2]) + p[:, 1] if order else (p[:, 0] + p[:, 1]) + p[:, 2]
    other = (p[:, 0] + p[:, 1]) + p[:, 2] if order else (p[:, 0] + p[:, 2]) + p[:, 1]
    got = np.einsum("ij,ij->i", a, b)
    assert np.array_equal(got, want) and not np.array_equal(got, other)


@kernel
def test_face_components_and_repeats_against_the_reference():
    V, F = _pieces()
    topo = weld._edge_table(F, len(V))
    hei = topo["edge_halfedges"]
    count, labels, inconsistent = mesh_orient.face_components(F, hei)
    h0, h1, f0, f1 = weld._interior_pairs(topo)
    g = sparse.coo_matrix((np.ones(len(f0)), (f0, f1)), shape=(len(F), len(F)))
    ref_count, ref_labels = csgraph.connected_components(g, directed=False)
    assert count == ref_count == 4
    _bits(labels, ref_labels, "labels")
    ref_inconsistent = int(np.sum(F.ravel()[h0] == F.ravel()[h1]))
    assert inconsistent == ref_inconsistent > 0
    assert mesh_orient.repeats_on_edges(F, hei) is weld._repeats_on_edges(F, h0, h1, f0, f1)
    assert not mesh_orient.repeats_on_edges(F, hei)
    # a face repeated with the opposite winding: its edges have the two faces each
    R = np.array([[0, 1, 2], [2, 1, 0]])
    topo = weld._edge_table(R, 3)
    assert mesh_orient.repeats_on_edges(R, topo["edge_halfedges"])
    assert weld._repeats_on_edges(R, *weld._interior_pairs(topo))


@kernel
def test_the_face_terms_against_the_reference():
    """Area vectors, norms, unit normals, areas and the per-component sums, bit for bit, on
    coordinates of magnitudes far apart and zero-area faces (collinear corners, two equal
    corners)."""
    rng = np.random.default_rng(12)
    V = rng.normal(size=(500, 3)) * [1e3, 1.0, 1e-3] + [250.0, -40.0, 7.0]
    V[10] = V[11] + 0.5 * (V[12] - V[11])  # not exactly collinear in floats: tiny normal
    V[20] = 2.0 * V[21] - V[22]
    F = rng.integers(0, 500, size=(3000, 3))
    F[:3] = [[11, 10, 12], [21, 20, 22], [5, 5, 6]]
    F[3] = [7, 8, 7]
    labels = rng.integers(0, 6, size=len(F)).astype(np.int32)
    labels[labels == 4] = 3  # a component with no faces
    got = mesh_orient.orient_face_terms(V, F, labels, 6)
    mesh = TriMesh(V=V, F=F)
    with backend.numpy_only():
        vol, area, ref = mesh._face_volume_terms(labels, 6)
    c = mesh._cache
    for x, y, name in zip(got, (c["n2"], c["fn_area2"], c["fn"], c["areas"], vol, area, ref),
                          ("n2", "ln", "fn", "areas", "volume", "area", "mean"), strict=True):
        _bits(x, y, name)
    assert np.all(got[2][2:4] == 0.0) and np.all(got[3][2:4] == 0.0)  # equal corners: zero
    assert got[4][4] == 0.0 and got[5][4] == 0.0
    assert mesh_orient.orient_face_terms(V, F, labels, 5) is None  # a label out of range
    assert mesh_orient.orient_face_terms(V, F - 500, labels, 6) is None  # numpy's turn


@kernel
def test_the_pieces_come_out_the_same_on_both_backends():
    """The whole mesh (faces, flips, everything cached) on both backends, for the shuffled
    pieces with reversed faces and a zero-area face."""
    V, F = _pieces()
    a = TriMesh.from_arrays(V, F)
    with backend.numpy_only():
        b = TriMesh.from_arrays(V, F)
    assert a.flipped_faces == b.flipped_faces > 0
    _bits(a.F, b.F, "F")
    assert sorted(a._cache) == sorted(b._cache)
    for key, x in a._cache.items():
        if isinstance(x, np.ndarray):
            _bits(x, b._cache[key], key)
    assert np.any(a.face_areas == 0.0)  # the collinear face
