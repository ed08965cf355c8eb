"""The compiled faces' tree (kernels/src/face_bvh.rs: boxes and oriented boxes over runs of
faces) against the numpy reference: the same nearest faces (the least squared distance of
closest_on_triangles, then the lowest id), closest points and signed distances, at points
on and 0–25 mm off both sides of a dense thin blade, on its vertices and above the middles
of its edges (exact ties), asked in path order (each point searched from the previous
one's face) and shuffled."""

from __future__ import annotations

import numpy as np
import pytest

from blisk_cam.core.geometry.distance import MeshDistance, NearestFaces
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.kernels import backend
from blisk_cam.core.runtime import parallel
from tests.support.blades import tube_blade
from tests.support.kernels import needs_compiled

compiled = needs_compiled("FaceTree")


def _blade():
    """A thin twisted tube blade, 6 mm thick, 30 mm chord: 80k faces, edges ~0.25 mm."""
    V, F, _ = tube_blade(n_u=400, n_v=101)
    return TriMesh.from_arrays(V, F)


def _points(mesh):
    """(k, 3) mm in path order: a loop around the blade at mid-span going out from the
    surface to 25 mm and back (outside), then in to 2.9 mm below it (inside the blade: up
    to 2.5 mm deep); the vertices of a span line; points 6 mm above the middles of
    consecutive edges and above vertices (ties between the faces around them)."""
    V, n = mesh.V, mesh.vertex_normals
    ring = np.arange(400) + 50 * 400  # the loop of vertices at mid-span
    s = 25.0 * np.sin(np.linspace(0.0, np.pi, 400)) ** 2
    out = V[ring] + s[:, None] * n[ring]
    inside = V[ring] - 2.9 * np.sin(np.linspace(0.0, np.pi, 400))[:, None] * n[ring]
    span = np.arange(101) * 400 + 7
    a, b = ring, np.roll(ring, -1)
    mid = 0.5 * (V[a] + V[b])
    nm = n[a] + n[b]
    nm /= np.linalg.norm(nm, axis=1)[:, None]
    return np.vstack([out, inside, V[span], mid + 6.0 * nm, V[ring] + 6.0 * n[ring],
                      V[span] + 12.0 * n[span]])


def _numpy(fn, P, chunk=100):
    """fn on the numpy backend, in chunks of points (its candidate lists grow with the
    distance: every face within 25 mm)."""
    with backend.numpy_only():
        parts = [fn(P[i:i + chunk]) for i in range(0, len(P), chunk)]
    return [np.concatenate(x) for x in zip(*parts, strict=True)]


def _figures(md, P):
    q = md.query(P)
    return q.signed_distance, q.point, q.face, q.feature, q.bary


@compiled
def test_face_tree_answers_are_numpys_off_a_dense_blade():
    mesh = _blade()
    P = _points(mesh)
    rng = np.random.default_rng(11)
    order = rng.permutation(len(P))
    nf_ref = NearestFaces(mesh)
    ref = _numpy(nf_ref.query, P)
    ref_md = _numpy(lambda X: _figures(MeshDistance(mesh, faces=nf_ref), X), P)
    d = np.abs(ref_md[0])
    # what the points are: far off and deep inside, with exact ties among the faces
    assert d.max() > 24.0 and (ref_md[0] < -2.0).any() and (d == 0.0).any()
    assert (ref_md[3] >= 4).sum() > 100 and ((ref_md[3] >= 1) & (ref_md[3] <= 3)).sum() > 100
    for disks in (False, True):
        for threads in (1, 2):
            with parallel(threads):
                nf = NearestFaces(mesh, disks=disks)
                for idx in (np.arange(len(P)), order):  # path order, then shuffled
                    got = nf.query(P[idx])
                    for g, r in zip(got, ref, strict=True):
                        np.testing.assert_array_equal(g, r[idx])
                    got = _figures(MeshDistance(mesh, faces=nf), P[idx])
                    for g, r in zip(got, ref_md, strict=True):
                        np.testing.assert_array_equal(g, r[idx])


@compiled
@pytest.mark.parametrize("disks", [False, True])
def test_face_tree_ties_go_to_the_lowest_face_whatever_the_previous_point(disks):
    """Points on the vertices of a span line and above them, each asked right after a point
    whose nearest face is the highest of the faces around the vertex (the face a search
    from the previous point's face meets first): the lowest face id wins, as in numpy."""
    from blisk_cam.core.kernels.closest import face_tree, nearest_faces

    mesh = _blade()
    V, F = mesh.V, mesh.F
    vt = np.arange(101) * 400 + 7
    cen = V[F].mean(axis=1)
    # for each vertex, its highest face, and a point just above that face's centroid
    hi = np.array([np.flatnonzero((F == v).any(axis=1)).max() for v in vt])
    lead = cen[hi] + 0.01 * mesh.face_normals[hi]
    P = np.empty((2 * len(vt) * 2, 3))
    P[0::4], P[1::4] = lead, V[vt]
    P[2::4], P[3::4] = lead + 0.5 * mesh.face_normals[hi], V[vt] + 6.0 * mesh.vertex_normals[vt]
    ref = _numpy(lambda X: (NearestFaces(mesh).query(X)[1],), P)[0]
    assert np.all(ref[0::4] == hi) and np.all(ref[1::4] < hi)  # the tie is a real one
    tree = face_tree(V, F, disks)
    for threads in (1, 2):
        np.testing.assert_array_equal(nearest_faces(tree, P, threads), ref)
