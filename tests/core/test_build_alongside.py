"""The one-time compiled builds the plan starts on a side thread (issue 21): the passes'
tables (the faces around each vertex, the tree over the mesh's samples) and the orient
stage's face tree (``NearestFaces.build_alongside``) give the same answers as built on first
use, on 1 and 2 threads.

Tests skip (saying why) when the extension is not built: the numpy kernels build nothing
alongside."""

from __future__ import annotations

import numpy as np
import pytest

from blisk_cam.core.geometry.distance import NearestFaces
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.kernels import knn as compiled_knn
from blisk_cam.core.kernels import mesh_tables as compiled_tables
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.paths.passes import _Generator
from blisk_cam.core.runtime import parallel
from tests.support.kernels import needs_compiled

compiled = needs_compiled(why="nothing is built alongside")


@pytest.fixture(scope="module")
def demo():
    d = make_demo_blisk(resolution=0.3)
    return d, TriMesh.from_arrays(d.blade_vertices, d.blade_faces)


def _centres(mesh, rng, n=400):
    """Points around the surface: on it, 6 mm off it (ball centres) and between."""
    f = rng.integers(0, len(mesh.F), n)
    p = mesh.V[mesh.F[f]].mean(axis=1)
    return p + rng.uniform(0.0, 6.5, n)[:, None] * mesh.face_normals[f]


@compiled
@pytest.mark.parametrize("threads", [1, 2])
def test_passes_tables_built_alongside_answer_as_built_on_first_use(demo, threads):
    d, mesh = demo
    with parallel(threads):
        gen = _Generator(mesh, d.axis, d.hub_cone, d.tip_cone, 6.0, 0.05, 0.01)
        ptr, face, corner = gen._vertex_face_table()
        tree = gen._compiled_probe_tree()
    ref_ptr, ref_face, ref_corner = compiled_tables.vertex_face_table(mesh.F, len(mesh.V))
    assert np.array_equal(ptr, ref_ptr) and np.array_equal(face, ref_face)
    assert np.array_equal(corner, ref_corner)
    assert face.dtype == np.int32 and corner.dtype == np.int8  # kept narrow (made so)
    # the faces of each vertex hold it (an independent check of the table)
    v = np.repeat(np.arange(len(mesh.V)), np.diff(ptr))
    assert np.array_equal(mesh.F[face, corner], v)
    ref = compiled_tables.sample_tree(mesh.V, mesh.edges, mesh.F, 1)
    C = _centres(mesh, np.random.default_rng(5))
    got = compiled_knn.nearest_k(tree, C, 8, 6.05, 1)
    assert np.array_equal(got, compiled_knn.nearest_k(ref, C, 8, 6.05, 1))
    assert (got >= 0).any()
    for bound in (0.5, 5.0, 6.0):
        assert np.array_equal(compiled_knn.points_within(tree, C, bound, 1),
                              compiled_knn.points_within(ref, C, bound, 1))


@compiled
@pytest.mark.parametrize("threads", [1, 2])
def test_face_tree_built_alongside_answers_as_built_on_first_use(demo, threads):
    _, mesh = demo
    P = _centres(mesh, np.random.default_rng(9))
    with parallel(threads):
        early = NearestFaces(mesh)
        early.build_alongside()
        early.build_alongside()  # a second call starts nothing more
        got = early.query(P)
    ref = NearestFaces(mesh).query(P)
    for a, b in zip(got, ref, strict=True):
        assert np.array_equal(a, b)
    # the closest points are on their faces, no farther than a brute-force check's nearest
    q, face = got[0], got[1]
    tri = mesh.V[mesh.F]
    brute = np.linalg.norm(tri.mean(axis=1)[None, :, :] - P[:40, None, :], axis=2).min(axis=1)
    assert np.all(np.linalg.norm(q[:40] - P[:40], axis=1) <= brute + 1e-9)
    assert np.all(face >= 0)


@needs_compiled("vertex_face_table_narrow", why="nothing to compare")
def test_narrow_vertex_face_table_holds_the_int64_values():
    """The table made narrow at once (faces int32, corners int8) holds the int64 table's
    values, on a mesh with vertices in no face (empty rows) and many faces per vertex."""
    rng = np.random.default_rng(21)
    F = rng.integers(0, 500, size=(30_000, 3))
    F[:, 1] = (F[:, 0] + 1 + rng.integers(0, 498, 30_000)) % 500  # distinct corners
    F[:, 2] = np.where((F[:, 2] == F[:, 0]) | (F[:, 2] == F[:, 1]), -1, F[:, 2])
    F = F[F[:, 2] >= 0]
    wide = compiled_tables.vertex_face_table(F, 510)
    narrow = compiled_tables.vertex_face_table(F, 510, narrow=True)
    assert [a.dtype for a in narrow] == [np.int64, np.int32, np.int8]
    for a, b in zip(wide, narrow, strict=True):
        assert np.array_equal(a, b.astype(np.int64))
    ptr, face, corner = narrow
    assert ptr[-1] == 3 * len(F) and np.all(ptr[500:] == ptr[-1])  # 500..509: no face
    v = np.repeat(np.arange(510), np.diff(ptr))
    assert np.array_equal(F[face, corner], v)
    assert all(np.all(np.diff(face[ptr[i]:ptr[i + 1]]) > 0) for i in range(0, 500, 37))
