"""The weld's exact-duplicate pass read from the rows: the first equal row of every row
(−0.0 as 0.0); the welded mesh bit for bit the same on one and two threads and on both
backends."""

import numpy as np
import pytest

from blisk_cam.core.geometry import weld
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.kernels import backend
from blisk_cam.core.kernels import weld as compiled_weld
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.runtime import parallel

rows_kernel = pytest.mark.skipif(
    compiled_weld.first_equal_rows(np.zeros((1, 3))) is None,
    reason="the compiled kernels (with first_equal_rows) are not installed or numpy runs",
)


def _lowest_equal_row(P):
    """The measured truth: the lowest index of the rows equal to each row."""
    _, first_of_row, inverse = np.unique(P + 0.0, axis=0, return_index=True,
                                         return_inverse=True)
    return first_of_row[inverse.ravel()]


@rows_kernel
def test_first_equal_rows_is_the_lowest_equal_row():
    rng = np.random.default_rng(21)
    base = np.round(rng.normal(size=(4000, 3)), 2)  # many exact duplicates after rounding
    P = base[rng.integers(0, len(base), size=30_000)]
    P[rng.random(len(P)) < 0.2] *= -1.0
    P[P == 0.0] = -0.0  # −0.0 and 0.0 are one coordinate
    got = compiled_weld.first_equal_rows(P)
    np.testing.assert_array_equal(got, _lowest_equal_row(P))
    np.testing.assert_array_equal(got, weld._first_equal_point([P[:, j] + 0.0 for j in range(3)]))
    # the rows at an odd byte of a buffer (as dask hands a task's arrays over): the same
    buf = bytearray(P.nbytes + 4)
    odd = np.frombuffer(buf, dtype=np.float64, offset=4, count=P.size).reshape(P.shape)
    odd[...] = P
    assert not odd.flags.aligned
    np.testing.assert_array_equal(compiled_weld.first_equal_rows(odd), got)


@rows_kernel
def test_first_equal_rows_when_most_rows_are_distinct():
    """The kernel's table is sized for an STL's soup (~6 corners a vertex) and grows when the
    rows are mostly distinct: the answer stays the lowest equal row, as the numpy twin's."""
    rng = np.random.default_rng(2121)
    distinct = rng.normal(size=(40_000, 3))
    P = np.concatenate([distinct, distinct[rng.integers(0, len(distinct), size=8_000)]])
    P = P[rng.permutation(len(P))]
    got = compiled_weld.first_equal_rows(P)
    want = _lowest_equal_row(P)
    assert np.sum(want == np.arange(len(P))) == len(distinct)  # the table grew past k/6
    np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(got, weld._first_equal_point([P[:, j] + 0.0 for j in range(3)]))


def test_the_welded_mesh_is_the_same_on_one_and_two_threads_and_both_backends():
    d = make_demo_blisk(resolution=0.3)
    F = d.blade_faces
    V = d.blade_vertices[F].reshape(-1, 3)  # a triangle soup, as an STL gives it
    S = np.arange(len(V)).reshape(-1, 3)
    meshes = []
    for threads in (1, 2):
        with parallel(threads):
            meshes.append(TriMesh.from_arrays(V, S))
    with backend.numpy_only():
        meshes.append(TriMesh.from_arrays(V, S))
    a = meshes[0]
    assert a.n_vertices == len(np.unique(V, axis=0))  # the soup's corners welded
    for b in meshes[1:]:
        for name in ("V", "F", "vertex_map", "face_map"):
            x, y = getattr(a, name), getattr(b, name)
            assert x.dtype == y.dtype and np.array_equal(x.view(np.uint8), y.view(np.uint8))
        assert (a.welded_vertices, a.dropped_faces, a.flipped_faces) == (
            b.welded_vertices, b.dropped_faces, b.flipped_faces)
