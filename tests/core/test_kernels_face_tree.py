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


def _ball_centres(mesh, r0, offset=6.0, nsub=8):
    """(k, 3) mm in path order, as verify asks for them (:func:`measure._subsample`: ``nsub``
    points per segment, the nodes included): ball centres ``offset`` mm off the faces of a
    section of ``mesh`` at radius ``r0`` mm around the z axis (the faces' centroids within
    0.5 mm of it, each next one the nearest one left, each pushed out along its normal),
    then the centres above the vertices of the same section (vertex + offset × its normal:
    a convex vertex's faces all tie there), run forth and back."""
    V, F = mesh.V, mesh.F
    runs = []
    for x, n in ((V[F].mean(axis=1), mesh.face_normals), (V, mesh.vertex_normals)):
        r = np.hypot(x[:, 0], x[:, 1])
        sel = list(np.flatnonzero(np.abs(r - r0) < 0.5))
        chain = [sel.pop(0)]  # each next node the nearest one left: a path-like order
        while sel:
            j = int(np.argmin(np.linalg.norm(x[sel] - x[chain[-1]], axis=1)))
            chain.append(sel.pop(j))
        sel = np.array(chain)
        nodes = x[sel] + offset * n[sel]
        t = np.arange(nsub) / nsub
        a, b = nodes[:-1], nodes[1:]
        runs.append(np.vstack([(a[:, None] + t[None, :, None] * (b - a)[:, None]).reshape(-1, 3),
                               nodes[-1:]]))
    runs.append(runs[-1][::-1])
    return np.vstack(runs)


def _closest_figures(mesh, P, face):
    """(face, q, d2, feature, bary) of closest_on_triangles at each point and its face."""
    from blisk_cam.core.geometry.closest import closest_on_triangles

    V, F = mesh.V, mesh.F[face]
    q, d2, feat, bary = closest_on_triangles(P, V[F[:, 0]], V[F[:, 1]], V[F[:, 2]])
    return face, q, d2, feat, bary


@compiled
@pytest.mark.parametrize("r0", [200.0, 235.0])
def test_face_tree_ball_centres_in_path_order_are_numpys(rotor37, r0):
    """Rotor 37 as stored (20k faces, slivers down to 0.07 mm): ball centres 6 mm off a
    section, 8 per segment in path order (consecutive centres 0.01–0.2 mm apart), over
    the faces and over the vertices (exact ties), then shuffled and reversed: the compiled
    nearest faces and closest-point figures are the numpy reference's bit for bit, on 1
    and 2 threads, with the faces' own bounds (verify's tree) and without; a brute force
    over every face agrees on a subset."""
    from blisk_cam.core.geometry.closest import closest_on_triangles
    from blisk_cam.core.kernels.closest import face_tree, nearest_closest

    V, F, _, _ = rotor37
    mesh = TriMesh.from_arrays(V, F)
    P = _ball_centres(mesh, r0)
    ref_face = _numpy(lambda X: (NearestFaces(mesh).query(X)[1],), P, chunk=500)[0]
    ref = _closest_figures(mesh, P, ref_face)
    # what the points are: mostly 6 mm off (less at the thin edges), close together, many of
    # them at exact ties
    step = np.linalg.norm(np.diff(P, axis=0), axis=1)
    assert len(P) > 2000 and np.median(step) < 0.1
    assert np.mean(np.sqrt(ref[2]) > 5.0) > 0.9
    assert (ref[3] >= 4).sum() > 50 and ((ref[3] >= 1) & (ref[3] <= 3)).sum() > 500
    # the reference against every face, on a subset (ties: the lowest id)
    A, B, C = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    for i in np.linspace(0, len(P) - 1, 40).astype(int):
        d2 = closest_on_triangles(np.repeat(P[i:i + 1], len(F), 0), A, B, C)[1]
        assert ref_face[i] == np.flatnonzero(d2 == d2.min())[0]
    rng = np.random.default_rng(5)
    orders = (np.arange(len(P)), rng.permutation(len(P)), np.arange(len(P))[::-1])
    for disks in (True, False):
        tree = face_tree(mesh.V, mesh.F, disks)
        for threads in (1, 2):
            for idx in orders:
                got = nearest_closest(tree, P[idx], threads)
                for g, r in zip(got, ref, strict=True):
                    np.testing.assert_array_equal(g, r[idx])
