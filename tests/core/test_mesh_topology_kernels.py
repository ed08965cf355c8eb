"""The compiled mesh topology (the edge table by a counting sort, its interior pairs, the
face normals, the vertex normals' sums) against the numpy reference: the prepared mesh —
vertices, faces, maps, counts, orientation flips and everything cached (edges, face
adjacency, normals, loops) — bit for bit the same on both backends, on an open patch,
closed solids, a mesh with flipped faces, several components, and a non-manifold mesh
refused with the same message."""

import numpy as np
import pytest

from blisk_cam.core.errors import MeshError
from blisk_cam.core.geometry import weld
from blisk_cam.core.geometry.mesh import TriMesh, triangle_normals
from blisk_cam.core.kernels import backend
from blisk_cam.core.kernels import weld as compiled_weld
from tests.support.kernels import needs_compiled
from tests.support.mesh_files import icosphere

kernel = pytest.mark.skipif(
    compiled_weld.edge_table(np.array([[0, 1, 2]]), 3) is None,
    reason="the compiled kernels (with the edge table) are not installed or numpy runs",
)


def _same(a, b, where):
    if isinstance(a, np.ndarray):
        assert isinstance(b, np.ndarray) and a.dtype == b.dtype and a.shape == b.shape, where
        assert np.array_equal(a.view(np.uint8), b.view(np.uint8)), where
    elif isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _same(x, y, f"{where}[{i}]")
    else:
        assert a == b, where


def _both(V, F):
    """The mesh prepared on the compiled and the numpy backend, compared in full."""
    a = TriMesh.from_arrays(V, F)
    _ = a.vertex_normals, a.boundary_loops()
    with backend.numpy_only():
        b = TriMesh.from_arrays(V, F)
        _ = b.vertex_normals, b.boundary_loops()
    for name in ("V", "F", "vertex_map", "face_map", "flipped_faces", "welded_vertices",
                 "dropped_faces"):
        _same(getattr(a, name), getattr(b, name), name)
    assert sorted(a._cache) == sorted(b._cache)
    for key in a._cache:
        _same(a._cache[key], b._cache[key], key)
    return a


def _soup(V, F):
    """The triangle soup of a mesh (every corner its own vertex), as an STL gives it."""
    return V[F].reshape(-1, 3), np.arange(3 * len(F)).reshape(-1, 3)


@kernel
def test_open_patch():
    x, y = np.meshgrid(np.linspace(0, 10, 30), np.linspace(0, 5, 20))
    V = np.stack([x.ravel(), y.ravel(), 0.1 * np.sin(x.ravel())], axis=1)
    i = np.arange(29)[None, :] + 30 * np.arange(19)[:, None]
    i = i.ravel()
    F = np.concatenate([np.stack([i, i + 1, i + 31], 1), np.stack([i, i + 31, i + 30], 1)])
    mesh = _both(*_soup(V, F))
    assert mesh.n_vertices == 600 and len(mesh.boundary_loops()) == 1  # measured: one rim


@kernel
def test_closed_solids_with_flipped_faces_and_several_components():
    V1, F1 = icosphere(3)
    V2 = V1 * 0.5 + [3.0, 0.0, 0.0]
    F2 = F1[:, ::-1] + len(V1)  # a second sphere, inside out
    V = np.concatenate([V1, V2])
    F = np.concatenate([F1, F2])
    rng = np.random.default_rng(3)
    F = F[rng.permutation(len(F))]  # the components interleaved in face order
    flip = rng.random(len(F)) < 0.1
    F[flip] = F[flip][:, ::-1]
    mesh = _both(*_soup(V, F))
    assert mesh.boundary_loops() == [] and mesh.flipped_faces > 0
    # measured: both spheres end up outward (positive volume about their own centres)
    n2 = triangle_normals(mesh.V, mesh.F)
    c = mesh.V[mesh.F].mean(axis=1)
    far = c[:, 0] > 1.5
    for sel, centre in ((~far, [0, 0, 0]), (far, [3, 0, 0])):
        assert np.sum(np.einsum("ij,ij->i", c[sel] - centre, n2[sel])) > 0


@kernel
def test_a_non_manifold_mesh_is_refused_the_same_way():
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1.0]])
    F = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]])  # three faces on edge 0–1
    with pytest.raises(MeshError) as a:
        TriMesh.from_arrays(V, F)
    with backend.numpy_only(), pytest.raises(MeshError) as b:
        TriMesh.from_arrays(V, F)
    assert str(a.value) == str(b.value) and "non-manifold" in str(a.value)
    assert compiled_weld.edge_table(F, len(V)) is None


@kernel
def test_the_edge_table_against_the_reference():
    rng = np.random.default_rng(7)
    Vs, Fs = icosphere(2)
    n = len(Vs)
    perm = rng.permutation(n)  # vertex ids in no order: long unsorted key runs
    F = perm[Fs][:300]  # an open piece, boundary edges included
    got = compiled_weld.edge_table(F, n + 5)
    with backend.numpy_only():
        ref = weld._edge_table(F, n + 5)
    assert sorted(got) == sorted(ref)
    for key in ref:
        _same(got[key], ref[key], key)


@kernel
def test_triangle_normals_and_interior_pairs_against_the_reference():
    rng = np.random.default_rng(11)
    V = rng.normal(size=(400, 3)) * [1e3, 1.0, 1e-3]  # magnitudes far apart: rounding shows
    F = rng.integers(0, 400, size=(900, 3))
    got = compiled_weld.triangle_normals(V, F)
    assert got is not None
    with backend.numpy_only():
        ref = triangle_normals(V, F)
    _same(got, ref, "normals")
    np.testing.assert_allclose(got, np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]))
    assert compiled_weld.triangle_normals(V, F - 400) is None  # negative ids: numpy's turn
    Vs, Fs = icosphere(2)
    topo = weld._edge_table(Fs[:200], len(Vs))
    got = compiled_weld.interior_pairs(topo["edge_halfedges"])
    with backend.numpy_only():
        ref = weld._interior_pairs(topo)
    assert 0 < len(ref[0]) < len(topo["edges"])  # some edges of one face, some of two
    for x, y in zip(got, ref, strict=True):
        _same(x, y, "pairs")


def test_the_reference_edge_table_widens_int32_faces():
    """numpy 1.x's default int on Windows is int32: faces of that type over more than 46 341
    vertices must give the int64 table (the key lower * n + higher overflowed in int32)."""
    n = 60_000
    a = np.arange(n - 2)
    F = np.stack([a, a + 1, a + 2], axis=1)  # a triangle strip over every vertex
    with backend.numpy_only():
        ref = weld._edge_table(F.astype(np.int64), n)
        got = weld._edge_table(F.astype(np.int32), n)
    for key in ref:
        _same(ref[key], got[key], key)
    assert len(ref["edges"]) == 2 * (n - 2) + 1  # each triangle adds two edges to the first's
    assert ref["edges"].max() == n - 1


@needs_compiled("vertex_normals_of", why="nothing to compare")
def test_vertex_normals_against_the_reference():
    """The vertex normals in one compiled call: the bits of numpy's bincount per corner, the
    corners added in order, the norm and the quotient (many faces on few vertices, signs and
    magnitudes mixed; vertices in no face stay zero)."""
    rng = np.random.default_rng(2121)
    F = rng.integers(0, 300, size=(20_000, 3))
    n2 = rng.normal(size=(20_000, 3)) * 10.0 ** rng.integers(-8, 8, size=(20_000, 1))
    got = compiled_weld.vertex_normals(310, F, n2)  # vertices 300..309 in no face
    want = np.zeros((310, 3))
    for k in range(3):
        want += np.stack([np.bincount(F[:, k], weights=n2[:, j], minlength=310)
                          for j in range(3)], axis=1)
    want = want / np.where((ln := np.linalg.norm(want, axis=1)) > 0, ln, 1.0)[:, None]
    assert np.array_equal(got.view(np.uint8), want.view(np.uint8))
    assert not got[300:].any() and np.all(np.abs(np.linalg.norm(got[:300], axis=1) - 1) < 1e-15)
    assert compiled_weld.vertex_normals(299, F, n2) is None  # an id out of range
    mesh = TriMesh(V=np.zeros((310, 3)), F=F)  # the mesh's reference gives the same bits
    assert np.array_equal(got.view(np.uint8), mesh._vertex_normals_numpy(n2).view(np.uint8))


def test_row_norm_sums_the_squares_in_order():
    """The order the compiled vertex normals (and interpolated normals) take from numpy:
    ``np.linalg.norm(x, axis=1)`` of (n, 3) rows is sqrt((x0² + x1²) + x2²) on this machine
    (whatever its SIMD loops), not another order, which differs in ~10 % of the rows."""
    rng = np.random.default_rng(7)
    x = rng.normal(size=(200_000, 3)) * 10.0 ** rng.integers(-3, 4, size=(200_000, 1))
    sq = x * x
    in_order = np.sqrt((sq[:, 0] + sq[:, 1]) + sq[:, 2])
    assert np.array_equal(np.linalg.norm(x, axis=1), in_order)
    assert not np.array_equal(in_order, np.sqrt(sq[:, 0] + (sq[:, 1] + sq[:, 2])))
