"""A binary STL read and welded exactly in one compiled pass (``mesh_io.read_stl_welded``):
the distinct corners in the order of their first appearance and the faces over them, and the
mesh built from them (``TriMesh.from_arrays(..., soup_corners=...)``) bit for bit the mesh the
numpy reader's float64 soup gives (−0.0 corners, a pair merged by the weld tolerance, a
degenerate and a repeated face among them). Where it does not apply (numpy kernels, ASCII,
NaN, a truncated file) it answers None and ``read_mesh`` reads the file."""

import numpy as np
import pytest

from blisk_cam.core.errors import MeshError
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.geometry.mesh_io import (
    UNITS,
    read_mesh,
    read_mesh_for_weld,
    read_stl_welded,
    read_trimesh,
    to_mm,
)
from blisk_cam.core.kernels import backend
from blisk_cam.core.part.blisk import make_demo_blisk
from tests.support.mesh_files import write_ascii_stl, write_binary_stl, write_obj

kernel = pytest.mark.skipif(
    backend.extension() is None
    or getattr(backend.extension(), "stl_corners_welded", None) is None,
    reason="the compiled kernels (with stl_corners_welded) are not installed or numpy runs",
)


def _soup():
    """A demo blade's faces as a float32-exact soup (V (3m, 3), F (m, 3)) with −0.0 corners,
    one corner a float32 step off its vertex (within the weld tolerance), a degenerate and a
    repeated face."""
    d = make_demo_blisk(resolution=0.3)
    S = d.blade_vertices[d.blade_faces].astype(np.float32).astype(np.float64)
    S = np.concatenate([S, S[:1, [0, 0, 1]], S[1:2]])  # a degenerate face, a repeated one
    C = S.reshape(-1, 3)
    # a vertex on x = 0 whose first corner reads −0.0 (and every other corner 0.0)
    v = np.flatnonzero(np.all(C == C[40], axis=1))
    C[v, 0] = 0.0
    C[v[0], 0] = -0.0
    # a corner of the vertex nearest z = 0 nudged by one float32 step: a distinct point
    # closer than the weld tolerance
    _, inverse, counts = np.unique(C, axis=0, return_inverse=True, return_counts=True)
    shared = counts[inverse.ravel()] > 1
    near = np.flatnonzero(shared)[np.argmin(np.abs(C[shared, 2]))]
    w = np.flatnonzero(np.all(C == C[near], axis=1))
    z32 = np.float32(C[w[-1], 2])
    C[w[-1], 2] = float(np.nextafter(z32, np.float32(1.0)))
    return C, np.arange(len(C)).reshape(-1, 3)


def _first_appearances(C):
    """The measured truth: the distinct corners (−0.0 as 0.0) in the order of their first
    appearance, each its first corner's value, and each corner's index among them."""
    _, first, inverse = np.unique(C + 0.0, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first)
    rank = np.empty(len(order), dtype=np.int64)
    rank[order] = np.arange(len(order))
    return C[first[order]], rank[inverse.ravel()].reshape(-1, 3)


def _same_bits(x, y):
    return x.dtype == y.dtype and x.shape == y.shape and np.array_equal(
        x.view(np.uint8), y.view(np.uint8))


@kernel
def test_the_stl_welded_as_read_is_the_soups_weld(tmp_path):
    C, S = _soup()
    path = write_binary_stl(tmp_path / "blade.stl", C, S)
    V, F, corners = read_stl_welded(path)
    assert corners == C.size // 3
    V_want, F_want = _first_appearances(C)
    assert _same_bits(V, V_want) and _same_bits(F, F_want)
    assert np.signbit(V[:, 0]).sum() == 1  # the −0.0 of the vertex's first corner, kept
    a = TriMesh.from_arrays(*read_mesh(path))  # the numpy reader's soup, welded
    b = TriMesh.from_arrays(V, F, soup_corners=corners)
    assert a.n_vertices == len(V) - 1  # the nudged corner merged by the tolerance
    for name in ("V", "F", "face_map"):
        assert _same_bits(getattr(a, name), getattr(b, name)), name
    assert a.dropped_faces == b.dropped_faces == 2
    assert (a.welded_vertices, a.flipped_faces) == (b.welded_vertices, b.flipped_faces)
    assert b.vertex_map is None


def test_where_it_does_not_apply_read_mesh_reads_the_file(tmp_path):
    C, S = _soup()
    path = write_binary_stl(tmp_path / "blade.stl", C, S)
    with backend.numpy_only():
        assert read_stl_welded(path) is None
    ascii_path = write_ascii_stl(tmp_path / "ascii.stl", C[:30], S[:10])
    assert read_stl_welded(ascii_path) is None
    raw = path.read_bytes()
    (tmp_path / "short.stl").write_bytes(raw[:-7])
    assert read_stl_welded(tmp_path / "short.stl") is None
    assert read_stl_welded(tmp_path / "missing.stl") is None
    C[5, 1] = np.nan
    bad = write_binary_stl(tmp_path / "nan.stl", C, S)
    assert read_stl_welded(bad) is None
    with pytest.raises(MeshError, match="NaN or infinite"):
        read_mesh(bad)


def _same_mesh(a, b):
    """The welded meshes agree bit for bit (vertices, faces, the face map, the counts)."""
    for name in ("V", "F", "face_map"):
        assert _same_bits(getattr(a, name), getattr(b, name)), name
    assert (a.welded_vertices, a.dropped_faces, a.flipped_faces) == (
        b.welded_vertices, b.dropped_faces, b.flipped_faces)


@kernel
@pytest.mark.parametrize("units", ["mm", "in"])
def test_read_trimesh_is_the_mesh_of_the_files_soup(tmp_path, units):
    """``read_trimesh`` (the readers of the commands: nc's part meshes, simulate's and rough's
    blade with a hub profile, batch's sweep) gives the mesh the numpy reader's soup scaled to
    mm gives, the STL welded as it is read (no map from a soup), in any units."""
    C, S = _soup()
    path = write_binary_stl(tmp_path / "blade.stl", C, S)
    want = TriMesh.from_arrays(to_mm(read_mesh(path)[0], units), read_mesh(path)[1])
    V, F, corners = read_mesh_for_weld(path, units)
    assert corners == C.size // 3 and len(V) < len(C)  # welded as read
    got = read_trimesh(path, units)
    _same_mesh(got, want)
    assert got.vertex_map is None
    assert float(np.abs(got.V).max()) == pytest.approx(
        float(np.abs(C).max()) * UNITS[units], rel=1e-12)


def test_read_trimesh_reads_the_other_files_as_read_mesh(tmp_path):
    """An OBJ, an ASCII STL, or the numpy kernels: the arrays of ``read_mesh`` (corners
    None), the same mesh; unknown units and a missing file are refused as ``to_mm`` and
    ``read_mesh`` refuse them."""
    C, S = _soup()
    n = 300  # faces: a small part of the blade
    sub_C, sub_S = C[: 3 * n], S[:n]
    want = TriMesh.from_arrays(sub_C, sub_S)
    for path in (write_obj(tmp_path / "b.obj", sub_C, sub_S),
                 write_ascii_stl(tmp_path / "a.stl", sub_C, sub_S)):
        V, F, corners = read_mesh_for_weld(path)
        assert corners is None and len(V) == len(read_mesh(path)[0])
        got = read_trimesh(path)
        assert got.vertex_map is not None
        np.testing.assert_allclose(got.V, want.V, atol=1e-4)  # the text's digits
        assert np.array_equal(got.F, want.F)
    stl = write_binary_stl(tmp_path / "blade.stl", C, S)
    with backend.numpy_only():
        V, F, corners = read_mesh_for_weld(stl)
        assert corners is None and len(V) == len(C)
        _same_mesh(read_trimesh(stl), TriMesh.from_arrays(*read_mesh(stl)))
    with pytest.raises(MeshError, match="unknown mesh units"):
        read_mesh_for_weld(stl, "ft")
    with pytest.raises(MeshError, match="not found"):
        read_trimesh(tmp_path / "missing.stl")


@kernel
def test_the_commands_part_meshes_are_read_welded(tmp_path, capsys):
    """nc's ``--part-mesh`` and the mesh a paths file recorded (in its units) are read by
    ``read_trimesh``: a binary STL welded as it is read, the soup's mesh."""
    from types import SimpleNamespace

    from blisk_cam.cli.nc import _part_mesh, planned_mesh_stats, recorded_mesh

    C, S = _soup()
    path = write_binary_stl(tmp_path / "blade.stl", C, S)
    got = _part_mesh(SimpleNamespace(part_mesh=str(path)))
    assert got.vertex_map is None
    _same_mesh(got, TriMesh.from_arrays(*read_mesh(path)))
    rec = recorded_mesh(SimpleNamespace(stats=planned_mesh_stats(path, "in")))
    assert rec.vertex_map is None
    _same_mesh(rec, TriMesh.from_arrays(to_mm(read_mesh(path)[0], "in"), read_mesh(path)[1]))
    assert "constant-error measured against" in capsys.readouterr().err
