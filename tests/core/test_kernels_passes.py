"""The compiled kernels of the passes stage (issue 21, item 4) against the numpy reference on
the same inputs: the slicing roots bit for bit, the intrusion screens and the 8 nearest
samples as scipy's k-d tree answers them (ties: the lowest ids, on both backends).

Tests comparing the two backends skip (saying why) when the extension is not built."""

from __future__ import annotations

import types

import numpy as np
import pytest
from scipy.spatial import cKDTree

from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.kernels import backend
from blisk_cam.core.kernels import knn as compiled_knn
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.part.cones import MorphingCones
from blisk_cam.core.paths.passes import _fixed_point_lift, _Generator, _unique_per_row
from blisk_cam.core.paths.slicing import MeshConeSlicer
from tests.support.kernels import needs_compiled

compiled = needs_compiled()


@pytest.fixture(scope="module")
def demo():
    d = make_demo_blisk(resolution=0.3, fillet=True)
    mesh = TriMesh.from_arrays(d.blade_vertices, d.blade_faces)
    return d, mesh


@compiled
def test_slicing_roots_are_numpys_bit_for_bit(demo):
    """Every edge of the mesh (crossing or not: the fallbacks of the root choice run too) at
    levels inside, at the ends and beyond; then whole slices."""
    d, mesh = demo
    slicer = MeshConeSlicer(mesh, d.axis, MorphingCones(d.hub_cone, d.tip_cone))
    edges = np.arange(len(mesh.edges))
    crossings = 0
    for s in (0.0, 0.137, 0.5, 0.91, 1.0, 1.2):
        got = slicer._edge_roots(s, edges)
        with backend.numpy_only():
            ref = slicer._edge_roots(s, edges)
        for g, r in zip(got, ref, strict=True):
            assert np.array_equal(g, r, equal_nan=True), s
        crossings += np.count_nonzero((ref[1] > 0) & (ref[1] < 1))
    assert crossings > 100  # true crossings inside edges exist
    for s in (0.0, 0.4, 1.0):
        got = slicer.slice(s)
        with backend.numpy_only():
            ref = slicer.slice(s)
        assert len(got) == len(ref) > 0
        for g, r in zip(got, ref, strict=True):
            assert np.array_equal(g.points, r.points) and np.array_equal(g.t, r.t)
            assert np.array_equal(g.edge, r.edge) and np.array_equal(g.normals, r.normals)


def _grid_samples():
    """A regular grid of points in z = 0 (many exactly equal distances from points above a
    node), and ball centres above nodes, midpoints and random spots."""
    x, y = np.meshgrid(np.arange(-10.0, 10.5, 0.5), np.arange(-10.0, 10.5, 0.5))
    pts = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    rng = np.random.default_rng(4)
    C = np.vstack([
        pts[rng.choice(len(pts), 300)] + [0.0, 0.0, 6.0],
        pts[rng.choice(len(pts), 300)] + [0.25, 0.25, 5.9],
        np.column_stack([rng.uniform(-9, 9, (400, 2)), rng.uniform(5.5, 6.5, 400)]),
    ])
    return pts, C


def _brute_nearest(pts, C, k, bound):
    """The k nearest by (squared distance summed as scipy sums it, id) below bound²."""
    d = pts[None, :, :] - C[:, None, :]
    d2 = (d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1]) + d[..., 2] * d[..., 2]
    ids = np.broadcast_to(np.arange(len(pts)), d2.shape)
    order = np.lexsort((ids, d2), axis=1)[:, :k]
    near = np.take_along_axis(d2, order, axis=1) < bound * bound
    return np.where(near, order, -1)


def test_nearest_samples_by_distance_then_id_on_numpy():
    pts, C = _grid_samples()
    tree = cKDTree(pts, leafsize=64, balanced_tree=False, compact_nodes=False)
    rho = 6.0
    fake = types.SimpleNamespace(radius=rho, _probe_tree=lambda: tree)
    got = _Generator._nearest_samples_scipy(fake, C)
    ref = _brute_nearest(pts, C, 8, rho + 0.05)
    assert np.array_equal(got, ref)
    # the case the rule is for: rows whose 8th and 9th nearest are at the same distance
    ties = _brute_nearest(pts, C, 9, rho + 0.05)
    d = pts[np.maximum(ties, 0)] - C[:, None, :]
    d2 = np.einsum("qkj,qkj->qk", d, d)
    assert np.count_nonzero((ties[:, 8] >= 0) & (d2[:, 7] == d2[:, 8])) > 50


@compiled
def test_nearest_samples_compiled_equal_numpys():
    pts, C = _grid_samples()
    tree = compiled_knn.point_tree(pts, 2)
    got = compiled_knn.nearest_k(tree, C, 8, 6.05, 2)
    assert np.array_equal(got, _brute_nearest(pts, C, 8, 6.05))


@compiled
def test_points_within_is_scipys_answer(demo):
    _, mesh = demo
    V, F, e = mesh.V, mesh.F, mesh.edges
    pts = np.vstack([V, 0.5 * (V[e[:, 0]] + V[e[:, 1]]),
                     (V[F[:, 0]] + V[F[:, 1]] + V[F[:, 2]]) / 3.0])
    kd = cKDTree(pts)
    tree = compiled_knn.point_tree(pts, 2)
    rng = np.random.default_rng(9)
    C = np.vstack([
        V[rng.choice(len(V), 3000)] + rng.normal(0.0, 4.0, (3000, 3)),
        rng.uniform(V.min(0) - 7, V.max(0) + 7, (3000, 3)),
    ])
    for bound in (6.0 - 1e-5, 1.0, 0.05):
        d, _ = kd.query(C, k=1, distance_upper_bound=bound)
        got = compiled_knn.points_within(tree, C, bound, 2)
        assert np.array_equal(got, np.isfinite(d)), bound
        assert 0 < got.sum() < len(C)
    # the nearest sample right at the bound, and just inside it
    d, _ = kd.query(C[:300], k=1)
    for b in (d, np.nextafter(d, np.inf)):
        got = np.array([compiled_knn.points_within(tree, C[i:i + 1], float(b[i]), 1)[0]
                        for i in range(300)])
        ref = np.array([np.isfinite(kd.query(C[i], k=1, distance_upper_bound=b[i])[0])
                        for i in range(300)])
        assert np.array_equal(got, ref)


@compiled
def test_intrusion_screens_agree_on_both_backends(demo):
    d, mesh = demo
    gen = _Generator(mesh, d.axis, d.hub_cone, d.tip_cone, 6.0, 0.05, 0.01)
    rng = np.random.default_rng(2)
    f = rng.integers(0, len(mesh.F), 4000)
    w = rng.dirichlet(np.ones(3), 4000)
    p = np.einsum("qk,qkj->qj", w, mesh.V[mesh.F[f]])
    C = p + (6.0 + rng.uniform(-0.05, 0.05, 4000))[:, None] * mesh.interpolate_normals(f, w)
    got = gen._any_within(C, 6.0 - 1e-5)
    ref = gen._probe_samples().any_within(C, 6.0 - 1e-5)
    assert np.array_equal(got, ref) and 0 < ref.sum() < len(C)
    assert np.array_equal(gen._nearest_samples(C), _Generator._nearest_samples_scipy(gen, C))


@compiled
def test_mesh_tables_are_numpys(demo):
    """The faces around each vertex, and the tree over all samples made from the mesh: the
    same tables and the same nearest samples as from ``_ProbeSamples.all_points``."""
    d, mesh = demo
    args = (mesh, d.axis, d.hub_cone, d.tip_cone, 6.0, 0.05, 0.01)
    got = _Generator(*args)._vertex_face_table()
    with backend.numpy_only():
        ref = _Generator(*args)._vertex_face_table()
    for g, r in zip(got, ref, strict=True):
        assert g.dtype == r.dtype and np.array_equal(g, r)
    gen = _Generator(*args)
    rng = np.random.default_rng(6)
    C = mesh.V[rng.choice(len(mesh.V), 2000)] + rng.normal(0.0, 3.0, (2000, 3))
    tree = compiled_knn.point_tree(gen._probe_samples().all_points(), 2)
    assert np.array_equal(compiled_knn.nearest_k(gen._compiled_probe_tree(), C, 8, 6.05, 2),
                          compiled_knn.nearest_k(tree, C, 8, 6.05, 2))


@compiled
def test_fixed_point_lift_compiled_bit_for_bit(demo):
    """Ball centres at the surface and sunk into it, on the faces holding their 8 nearest
    samples (the lift's own candidates): the same λ as the numpy steps."""
    d, mesh = demo
    gen = _Generator(mesh, d.axis, d.hub_cone, d.tip_cone, 6.0, 0.05, 0.01)
    rng = np.random.default_rng(11)
    n = 3000
    f = rng.integers(0, len(mesh.F), n)
    w = rng.dirichlet(np.ones(3), n)
    p = np.einsum("qk,qkj->qj", w, mesh.V[mesh.F[f]])
    nn = mesh.interpolate_normals(f, w)
    for lam0, steps in ((np.zeros(n), 4), (rng.uniform(-0.2, 0.0, n), 12)):
        C = p + (6.0 + lam0)[:, None] * nn
        cand = _unique_per_row(gen._probe_faces(gen._nearest_samples(C)))
        got = gen._lift(p, nn, lam0, cand, steps)
        ref = _fixed_point_lift(p, nn, lam0, mesh.V[mesh.F[np.maximum(cand, 0)]], cand >= 0,
                                6.0, steps)
        assert np.array_equal(got, ref)
        assert np.count_nonzero(ref != lam0) > 100  # the steps did lift
