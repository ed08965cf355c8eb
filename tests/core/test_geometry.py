"""The shared geometry kernels: NearestFaces (the generator's projector) returns the distances
MeshDistance (the checker's tree) returns, and the lowest face id among exact ties; threaded
queries equal one thread."""

from __future__ import annotations

import numpy as np

from blisk_cam.core.geometry.distance import MeshDistance, NearestFaces
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.kernels.backend import numpy_only
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.runtime import parallel


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


def test_nearest_faces_agree_with_mesh_distance():
    """Same exact distances as the checker's tree on points on shared edges and vertices
    (ties) and off the surface; the same face wherever only one face is that close."""
    from blisk_cam.core.geometry.closest import closest_on_triangles

    mesh, P = _mesh_and_points()
    cp = MeshDistance(mesh).query(P)
    q, face, bary = NearestFaces(mesh).query(P)
    V, F = mesh.V, mesh.F
    d2 = closest_on_triangles(P, V[F[face, 0]], V[F[face, 1]], V[F[face, 2]])[1]
    assert np.array_equal(np.sqrt(d2), cp.distance)
    assert np.abs(q - cp.point).max() < 1e-9
    assert np.allclose(bary.sum(axis=1), 1.0) and bary.min() >= -1e-12
    differ = face != cp.face  # only where MeshDistance found a face at exactly the distance
    d2_md = closest_on_triangles(P[differ], V[F[cp.face[differ], 0]], V[F[cp.face[differ], 1]],
                                 V[F[cp.face[differ], 2]])[1]
    assert np.array_equal(d2_md, d2[differ])
    assert np.all(face[differ] < cp.face[differ])


def test_nearest_faces_follow_the_tie_rule_by_brute_force():
    """The rule stated directly: every face's exact distance, the smallest wins; of faces at
    exactly that distance, the lowest face id — on points on shared edges and vertices
    (ties), on edge points with t ≠ ½, and off the surface."""
    from blisk_cam.core.geometry.closest import closest_on_triangles

    d = make_demo_blisk(resolution=0.12)
    mesh = TriMesh.from_arrays(d.blade_vertices, d.blade_faces)
    V, F = mesh.V, mesh.F
    rng = np.random.default_rng(11)
    e = F[rng.integers(0, len(F), 250)]
    t = rng.random(250)[:, None]
    P = np.vstack([0.5 * (V[e[:, 0]] + V[e[:, 1]]), V[e[:, 1]] + t * (V[e[:, 2]] - V[e[:, 1]]),
                   V[rng.integers(0, len(V), 250)],
                   V[rng.integers(0, len(V), 150)] + rng.normal(scale=1.0, size=(150, 3))])
    want = np.empty(len(P), dtype=np.int64)
    n_tied = 0
    A, B, C = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    for i, p in enumerate(P):
        d2 = closest_on_triangles(np.broadcast_to(p, A.shape), A, B, C)[1]
        tied = np.nonzero(d2 == d2.min())[0]
        n_tied += len(tied) > 1
        want[i] = tied.min()
    assert n_tied > 200  # the rule is exercised
    _, face, _ = NearestFaces(mesh).query(P)
    assert np.array_equal(face, want)
    # and one query per point gives each point the face of the batch
    nf = NearestFaces(mesh)
    assert np.array_equal([nf.query(p)[1][0] for p in P[::7]], want[::7])


def test_threaded_queries_equal_one_thread():
    mesh, P = _mesh_and_points()
    P = np.vstack([P] * 4)  # several chunks
    md = MeshDistance(mesh)
    with parallel(1):
        a = md.query(P)
    with parallel(2):
        b = md.query(P)
    assert np.array_equal(a.face, b.face) and np.array_equal(a.distance, b.distance)


def test_fast_filter_leaves_the_exact_search_unchanged():
    """The face-frame distances only drop candidates that cannot reach the minimum: faces,
    points and distances equal the search without the filter, bit for bit (points on edges
    and vertices — ties — and points 6 mm off the surface, where many faces are near-equal)."""
    from blisk_cam.core.geometry.bvh import nearest

    mesh, P = _mesh_and_points()
    rng = np.random.default_rng(3)
    far = mesh.V[rng.integers(0, mesh.n_vertices, 3000)]
    far = far + 6.0 * mesh.vertex_normals[rng.integers(0, mesh.n_vertices, 3000)]
    P = np.vstack([P, far])
    md = MeshDistance(mesh)
    d_fast, f_fast = nearest(md.tree, P, md._d2, md._lb_keep, fastfn=md._fast_d2)
    d_ref, f_ref = nearest(md.tree, P, md._d2, md._lb_keep)
    assert np.array_equal(f_fast, f_ref)
    assert np.array_equal(d_fast, d_ref)


def test_bottom_and_side_bounds_hold_every_cutter():
    """The fast swept cutter's two bounds: every point of the profile region with z ≥ f is
    within max_radius of the axis (the side), every point below f within R_b of the disc of
    radius e at height f (the bottom) — for bull noses (with and without a conical bottom),
    a flat end mill and a tapered ball."""
    from blisk_cam.core.tool.cutter import Cutter
    from blisk_cam.core.verify.sweep import _bottom_reach

    cutters = (Cutter.bull(6.0, 2.0), Cutter("bull", 12.0, 2.0, alpha=np.radians(20.0)),
               Cutter.flat(6.0), Cutter.taper(3.0, np.radians(10.0)), Cutter.bull(5.0, 4.9))
    for cut in cutters:
        rho, z = np.meshgrid(np.linspace(0.0, cut.max_radius + 1.0, 400),
                             np.linspace(-1.0, cut.h + 1.0, 900), indexing="ij")
        rho, z = rho.ravel(), z.ravel()
        inside = cut.signed_distance_rz(rho, z) <= 0.0
        hi = inside & (z >= cut.f)
        assert np.all(rho[hi] <= cut.max_radius * (1 + 1e-12)), cut
        lo = inside & (z < cut.f)
        d = np.hypot(np.maximum(rho[lo] - cut.e, 0.0), cut.f - z[lo])
        assert lo.any() == (cut.f > 0), cut  # a flat end mill has no part below f = 0
        assert d.max(initial=0.0) <= _bottom_reach(cut) * (1 + 1e-12), cut


def test_nearest_faces_on_thin_faces_of_many_sizes_by_brute_force():
    """A surface of needles and slivers whose sizes span three octaves and more (every
    circumradius size class, and the smallest-faces class holding everything below), points
    on edges, vertices and off the surface: the smallest exact distance, of ties the lowest
    face id, and the closest point of that face."""
    from blisk_cam.core.geometry.closest import closest_on_triangles

    rng = np.random.default_rng(5)
    x = np.cumsum(np.geomspace(0.002, 0.5, 60))  # column widths: 250 : 1
    y = np.cumsum(rng.uniform(0.05, 0.2, 12))
    X, Y = np.meshgrid(x, y, indexing="ij")
    V = np.column_stack([X.ravel(), Y.ravel(), 0.05 * np.sin(3 * X.ravel()) * Y.ravel()])
    i = np.arange(len(x) - 1)[:, None] * len(y) + np.arange(len(y) - 1)[None, :]
    i = i.ravel()
    F = np.vstack([np.column_stack([i, i + len(y), i + 1]),
                   np.column_stack([i + 1, i + len(y), i + len(y) + 1])])
    F = F[rng.permutation(len(F))]
    mesh = TriMesh.from_arrays(V, F)
    V, F = mesh.V, mesh.F
    e = F[rng.integers(0, len(F), 300)]
    t = rng.random(300)[:, None]
    P = np.vstack([0.5 * (V[e[:, 0]] + V[e[:, 1]]), V[e[:, 1]] + t * (V[e[:, 2]] - V[e[:, 1]]),
                   V[rng.integers(0, len(V), 200)],
                   V[rng.integers(0, len(V), 300)] + rng.normal(scale=0.3, size=(300, 3))])
    A, B, C = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    want = np.empty(len(P), dtype=np.int64)
    for k, p in enumerate(P):
        d2 = closest_on_triangles(np.broadcast_to(p, A.shape), A, B, C)[1]
        want[k] = np.nonzero(d2 == d2.min())[0].min()
    q2, _, _, bary2 = closest_on_triangles(P, A[want], B[want], C[want])
    with numpy_only():  # the numpy reference
        nf = NearestFaces(mesh)
        q, face, bary = nf.query(P)
        assert len(nf._trees) >= 5  # several size classes are searched
    assert np.array_equal(face, want)
    assert np.array_equal(q, q2) and np.array_equal(bary, bary2)
    # and the installed kernels (the compiled ones when built: the same decisions)
    q, face, bary = NearestFaces(mesh).query(P)
    assert np.array_equal(face, want)
    assert np.array_equal(q, q2) and np.array_equal(bary, bary2)
