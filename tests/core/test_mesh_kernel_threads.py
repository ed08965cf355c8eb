"""The mesh kernels that split their passes over threads (the edge table's counting sort,
the orientation's per-face terms, the face components' count and the repeats' test) give
on two threads what they give on one, bit for bit, and what the numpy reference gives — on
meshes large enough for the split (the kernels keep a small job on one thread), with the
faces shuffled and flipped, several components, and the cases the kernels hand back to
numpy (an edge of three faces, ids out of range, a label out of range)."""

import numpy as np
import pytest

from blisk_cam.core.geometry import weld
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.kernels import backend, mesh_orient
from blisk_cam.core.kernels import weld as compiled_weld
from blisk_cam.core.runtime import parallel
from tests.support.kernels import needs_compiled

kernel = needs_compiled("edge_table_arrays", "orient_face_terms", "face_components",
                        "repeats_on_edges")


def _bits(a, b, what):
    a, b = np.asarray(a), np.asarray(b)
    assert a.dtype == b.dtype and a.shape == b.shape, what
    assert np.array_equal(a.view(np.uint8), b.view(np.uint8)), what


@pytest.fixture(scope="module")
def grid():
    """A wavy open sheet of 300 × 300 vertices, jittered (178 802 faces, 537 k half-edges:
    several times the kernels' least work per thread), its faces shuffled, a tenth of them
    flipped, and a second, smaller sheet beside it (two components)."""
    rng = np.random.default_rng(24)
    k = 300
    x, y = np.meshgrid(np.linspace(0.0, 90.0, k), np.linspace(0.0, 60.0, k))
    x = x + rng.uniform(-0.05, 0.05, size=x.shape)
    V = np.stack([x.ravel(), y.ravel(), 2.0 * np.sin(0.1 * x.ravel()) * np.cos(0.07 * y.ravel())],
                 axis=1)
    i = (np.arange(k - 1)[None, :] + k * np.arange(k - 1)[:, None]).ravel()
    F = np.concatenate([np.stack([i, i + 1, i + k + 1], 1), np.stack([i, i + k + 1, i + k], 1)])
    small = F[F.max(axis=1) < 40 * k] + len(V)  # a second sheet, offset in z
    V = np.concatenate([V, V + [0.0, 0.0, 25.0]])
    F = np.concatenate([F, small])
    F = F[rng.permutation(len(F))]
    flip = rng.random(len(F)) < 0.1
    F[flip] = F[flip][:, ::-1]
    return V, np.ascontiguousarray(F)


@kernel
def test_the_edge_table_on_two_threads_is_the_one_thread_table(grid):
    V, F = grid
    one = compiled_weld.edge_table(F, len(V), 1)
    two = compiled_weld.edge_table(F, len(V), 2)
    with backend.numpy_only():
        ref = weld._edge_table(F, len(V))
    assert sorted(one) == sorted(two) == sorted(ref)
    for key in ref:
        _bits(one[key], ref[key], key)
        _bits(two[key], ref[key], key)
    assert len(ref["edges"]) > 250_000  # measured: the table is the sheet's
    # a third face on an edge of two, the edge's lower vertex among the last: refused on any
    # threads
    a, b = ref["edges"][np.flatnonzero(ref["edge_faces"][:, 1] >= 0)[-1]]
    G = np.concatenate([F, [[a, b, len(V) - 1]]])
    assert compiled_weld.edge_table(G, len(V), 1) is None
    assert compiled_weld.edge_table(G, len(V), 2) is None


@kernel
def test_the_face_terms_on_two_threads_are_the_one_thread_terms(grid):
    V, F = grid
    rng = np.random.default_rng(5)
    labels = rng.integers(0, 4, size=len(F)).astype(np.int32)
    one = mesh_orient.orient_face_terms(V, F, labels, 4, 1)
    two = mesh_orient.orient_face_terms(V, F, labels, 4, 2)
    mesh = TriMesh(V=V, F=F)
    with backend.numpy_only():
        vol, area, ref = mesh._face_volume_terms(labels, 4)
    c = mesh._cache
    want = (c["n2"], c["fn_area2"], c["fn"], c["areas"], vol, area, ref)
    for x, y, w, name in zip(one, two, want, ("n2", "ln", "fn", "areas", "volume", "area",
                                              "mean"), strict=True):
        _bits(x, w, name)
        _bits(y, w, name)
    # an id out of range, or a label, in the second half: numpy's turn on any threads
    G = F.copy()
    G[-5, 1] = len(V)
    bad = labels.copy()
    bad[-3] = 4
    for th in (1, 2):
        assert mesh_orient.orient_face_terms(V, G, labels, 4, th) is None
        assert mesh_orient.orient_face_terms(V, F, bad, 4, th) is None


@kernel
def test_the_components_and_repeats_on_two_threads_are_the_one_thread_ones(grid):
    V, F = grid
    hei = compiled_weld.edge_table(F, len(V), 1)["edge_halfedges"]
    one = mesh_orient.face_components(F, hei, 1)
    two = mesh_orient.face_components(F, hei, 2)
    assert one[0] == two[0] == 2 and one[2] == two[2]
    assert one[2] > 10_000  # measured: the flipped tenth's edges run the same way
    _bits(one[1], two[1], "labels")
    assert not mesh_orient.repeats_on_edges(F, hei, 1)
    assert not mesh_orient.repeats_on_edges(F, hei, 2)
    # a lone triangle (unused vertices) and its repeat, corners rotated, after all the
    # faces: found on any threads
    n = len(V)
    R = np.concatenate([F, [[n - 1, n - 2, n - 3], [n - 2, n - 3, n - 1]]])
    topo = weld._edge_table(R, len(V))
    for th in (1, 2):
        assert mesh_orient.repeats_on_edges(R, topo["edge_halfedges"], th)


@kernel
def test_a_soup_prepared_on_two_threads_is_the_one_thread_mesh(grid):
    """The whole preparation (weld, edge table, orientation) inside ``parallel(2)`` and
    ``parallel(1)``: the same mesh, everything cached the same."""
    V, F = grid
    S, G = V[F].reshape(-1, 3), np.arange(3 * len(F)).reshape(-1, 3)
    got = []
    for th in (1, 2):
        with parallel(th):
            m = TriMesh.from_arrays(S, G)
            _ = m.vertex_normals, m.boundary_loops()
        got.append(m)
    a, b = got
    for name in ("V", "F", "vertex_map", "face_map"):
        _bits(getattr(a, name), getattr(b, name), name)
    assert (a.flipped_faces, a.welded_vertices, a.dropped_faces) == (
        b.flipped_faces, b.welded_vertices, b.dropped_faces)
    assert a.flipped_faces > 0  # measured: the flipped tenth is turned back
    assert sorted(a._cache) == sorted(b._cache)
    for key in a._cache:
        if isinstance(a._cache[key], np.ndarray):
            _bits(a._cache[key], b._cache[key], key)
    assert len(a.boundary_loops()) == len(b.boundary_loops()) == 2
    for x, y in zip(a.boundary_loops(), b.boundary_loops(), strict=True):
        _bits(x, y, "loop")
