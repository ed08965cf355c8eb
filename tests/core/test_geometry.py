"""The shared geometry kernels: NearestFaces (the generator's projector) returns exactly what
MeshDistance (the checker's tree) returns, ties included; threaded queries equal one thread."""

from __future__ import annotations

import numpy as np

from blisk_cam.core.demo import make_demo_blisk
from blisk_cam.core.geometry import MeshDistance, NearestFaces, parallel
from blisk_cam.core.mesh import TriMesh


def _mesh_and_points():
    d = make_demo_blisk(resolution=0.3)
    mesh = TriMesh.from_arrays(d.blade_vertices, d.blade_faces)
    rng = np.random.default_rng(7)
    V, F = mesh.V, mesh.F
    e = F[rng.integers(0, len(F), 3000)]
    mids = 0.5 * (V[e[:, 0]] + V[e[:, 1]])  # on shared edges: two faces at the same distance
    verts = V[rng.integers(0, len(V), 2000)]  # on vertices: a fan of faces
    near = V[rng.integers(0, len(V), 3000)] + rng.normal(scale=2.0, size=(3000, 3))
    return mesh, np.vstack([mids, verts, near])


def test_nearest_faces_equal_mesh_distance_ties_included():
    mesh, P = _mesh_and_points()
    cp = MeshDistance(mesh).query(P)
    q, face, bary = NearestFaces(mesh).query(P)
    assert np.array_equal(face, cp.face)
    assert np.array_equal(q, cp.point)
    assert np.array_equal(bary, cp.bary)


def test_threaded_queries_equal_one_thread():
    mesh, P = _mesh_and_points()
    P = np.vstack([P] * 4)  # several chunks of 16384
    md = MeshDistance(mesh)
    with parallel(1):
        a = md.query(P)
    with parallel(2):
        b = md.query(P)
    assert np.array_equal(a.face, b.face) and np.array_equal(a.distance, b.distance)
