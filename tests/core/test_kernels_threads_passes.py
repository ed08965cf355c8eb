"""The passes stage on several worker threads (issue 21): its compiled kernels give the same
answers on 1 and 2 threads, and so does a whole plan; the tree over a mesh's samples, whose
splits are made on the vertices, answers as the plain k-d tree over the same points.

Tests comparing thread counts skip (saying why) when the extension is not built: on the numpy
backend the passes stage runs on one thread."""

from __future__ import annotations

import numpy as np
import pytest

from blisk_cam.core.geometry.axis import Axis
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.kernels import knn as compiled_knn
from blisk_cam.core.kernels import mesh_tables as compiled_tables
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.part.cones import MorphingCones
from blisk_cam.core.paths.expansion import PolylineDistance
from blisk_cam.core.paths.passes import _Generator, _unique_per_row
from blisk_cam.core.paths.probe_samples import _ProbeSamples
from blisk_cam.core.paths.slicing import MeshConeSlicer
from blisk_cam.core.process.blade_finish import PathRequest, plan_paths
from blisk_cam.core.runtime import parallel
from tests.support.blades import nasa_blade
from tests.support.kernels import needs_compiled
from tests.support.mesh_files import cylinder_sheet, flat_grid, sample_points

compiled = needs_compiled(why="the passes stage runs on one thread")


@pytest.fixture(scope="module")
def demo():
    """~25k triangles: more edges than the slicing kernel's parallel threshold and more
    vertices than the sample tree's parallel build threshold."""
    d = make_demo_blisk(resolution=0.5, fillet=True)
    return d, TriMesh.from_arrays(d.blade_vertices, d.blade_faces)


def _all_samples(d, mesh):
    """Vertices, edge midpoints, face centroids (``_ProbeSamples.all_points``: the reference
    point set of the sample tree, ids in that order)."""
    gen = _Generator(mesh, d.axis, d.hub_cone, d.tip_cone, 6.0, 0.05, 0.01)
    return _ProbeSamples(mesh, gen._vertex_face_table(), gen._probe_tree).all_points()


@compiled
def test_sample_tree_answers_as_the_plain_tree_on_any_threads(demo):
    """Ball centres on and off the surface, near the surface's own samples (exact ties at
    the k-th nearest: the flags must agree too), far away: the 8 nearest within ρ + 0.05 and
    the screens at several bounds, from the tree split on the vertices (built on 1 and 2
    threads) and from the plain tree over the same points, and brute force for a subset."""
    d, mesh = demo
    pts = _all_samples(d, mesh)
    plain = compiled_knn.point_tree(pts, 1)
    rng = np.random.default_rng(21)
    f = rng.integers(0, len(mesh.F), 3000)
    w = rng.dirichlet(np.ones(3), 3000)
    p = np.einsum("qk,qkj->qj", w, mesh.V[mesh.F[f]])
    C = np.vstack([
        p + (6.0 + rng.uniform(-0.3, 0.05, 3000))[:, None] * mesh.interpolate_normals(f, w),
        pts[rng.integers(0, len(pts), 1000)],  # on a sample: it and its neighbours
        rng.uniform(mesh.V.min(0) - 8, mesh.V.max(0) + 8, (1000, 3)),
    ])
    ref_ids, ref_tie = plain.query(C, 8, 6.05, 1)
    assert np.count_nonzero(ref_ids[:, 0] >= 0) > 3000
    for threads in (1, 2):
        tree = compiled_tables.sample_tree(mesh.V, mesh.edges, mesh.F, threads)
        for qt in (1, 2):
            ids, tie = tree.query(C, 8, 6.05, qt)
            assert np.array_equal(ids, ref_ids) and np.array_equal(tie, ref_tie)
        for bound in (6.0 - 1e-4, 6.0 - 1e-5, 1.0, 0.05):
            got = compiled_knn.points_within(tree, C, bound, threads)
            assert np.array_equal(got, compiled_knn.points_within(plain, C, bound, 1)), bound
    # brute force, (squared distance summed as scipy sums it, id), for 100 centres
    rows = np.arange(0, len(C), 50)
    d = pts[None, :, :] - C[rows][:, None, :]
    d2 = (d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1]) + d[..., 2] * d[..., 2]
    order = np.argsort(d2, axis=1, kind="stable")[:, :8]  # equal distances: lower id first
    near = np.take_along_axis(d2, order, axis=1) < 6.05 ** 2
    brute = np.where(near, order, -1)
    ok = ~ref_tie[rows]
    assert np.array_equal(ref_ids[rows][ok], brute[ok]) and np.count_nonzero(near) > 300

@compiled
def test_passes_kernels_same_on_one_and_two_threads(demo):
    """Slicing roots of every edge, the lift's fixed-point steps on hundreds of centres, the
    distances to ball-centre polylines: bit for bit on 1 and 2 threads."""
    d, mesh = demo
    slicer = MeshConeSlicer(mesh, d.axis, MorphingCones(d.hub_cone, d.tip_cone))
    edges = np.arange(len(mesh.edges))
    assert len(edges) > 16_384  # the kernel's parallel threshold
    gen = _Generator(mesh, d.axis, d.hub_cone, d.tip_cone, 6.0, 0.05, 0.01)
    rng = np.random.default_rng(5)
    n = 2000
    f = rng.integers(0, len(mesh.F), n)
    w = rng.dirichlet(np.ones(3), n)
    p = np.einsum("qk,qkj->qj", w, mesh.V[mesh.F[f]])
    nn = mesh.interpolate_normals(f, w)
    lam0 = rng.uniform(-0.2, 0.0, n)
    C = p + (6.0 + lam0)[:, None] * nn
    cand = _unique_per_row(gen._probe_faces(gen._nearest_samples(C)))
    level = slicer.slice(0.5)
    polys = [(c.points + 6.0 * c.normals, c.closed) for c in level]
    q = slicer.slice(0.53)[0]
    runs = []
    for threads in (1, 2):
        with parallel(threads):
            roots = slicer._edge_roots(0.37, edges)
            lam = gen._lift(p, nn, lam0, cand, 12)
            dist = PolylineDistance(polys, resample=0.2)(q.points, near=q.points + 6.0 * q.normals)
        runs.append((roots, lam, dist))
    (r1, l1, d1), (r2, l2, d2) = runs
    for a, b in zip(r1, r2, strict=True):
        assert np.array_equal(a, b, equal_nan=True)
    assert np.array_equal(l1, l2) and np.count_nonzero(l1 != lam0) > 100
    assert np.array_equal(d1, d2) and len(d1) > 64 and np.all(np.isfinite(d1))


@compiled
def test_plan_same_on_one_and_two_threads():
    """Rotor 37 as stored (what the panel plans), ball Ø12, chord 0.05: the same passes, poses
    and measured scallops on 1 and 2 worker threads."""
    V, F, c1, c2 = nasa_blade("rotor37")
    req = PathRequest(axis=Axis(), cone1=c1, cone2=c2, tool_type="ball", tool_radius=6.0,
                      cusp=0.05, chord=0.05)
    paths = []
    for threads in (1, 2):
        with parallel(threads):
            paths.append(plan_paths(TriMesh.from_arrays(V, F), req).path)
    a, b = paths
    assert a.stats["measured_cusp"] == b.stats["measured_cusp"]
    assert len(a.curves) == len(b.curves) > 20
    for ca, cb in zip(a.curves, b.curves, strict=True):
        assert ca.s == cb.s
        for k in ("cc", "normal", "tip", "axis", "face", "move", "flags"):
            assert np.array_equal(getattr(ca, k), getattr(cb, k)), k


@compiled
def test_sample_tree_on_a_flat_grid_with_exact_ties():
    """A flat triangulated grid (its leaves' frames lie in the plane z = 0: the bound they
    give is exactly the height of a centre above it) and a copy folded along x = 0: centres
    above nodes, edge midpoints and random spots at heights around ρ, with bounds at exactly
    the distances the samples have (a sample at the bound is not within it) and a hair above
    them (a frame's bound that rounded above its points' distances would drop them)."""
    V, F = flat_grid(10.0)
    rng = np.random.default_rng(8)
    for fold in (False, True):
        W = V.copy()
        if fold:
            W[:, 2] = 0.7 * np.abs(W[:, 0])
        mesh = TriMesh.from_arrays(W, F)
        e, pts = mesh.edges, sample_points(mesh)
        C = np.vstack([
            pts[rng.choice(len(pts), 500)] + [0.0, 0.0, 6.0],
            pts[rng.choice(len(pts), 500)] + [0.25, 0.25, 5.9],
            np.column_stack([rng.uniform(-9, 9, (500, 2)), rng.uniform(5.5, 6.5, 500)]),
        ])
        plain = compiled_knn.point_tree(pts, 1)
        tree = compiled_tables.sample_tree(mesh.V, e, mesh.F, 2)
        for bound in (6.05, 6.0, 6.0 + 1e-9, np.nextafter(6.0, 7.0), 5.9,
                      np.sqrt(2 * 0.25 ** 2 + 5.9 ** 2)):
            ids, tie = tree.query(C, 8, float(bound), 2)
            ref_ids, ref_tie = plain.query(C, 8, float(bound), 1)
            assert np.array_equal(ids, ref_ids) and np.array_equal(tie, ref_tie), bound
            got = compiled_knn.points_within(tree, C, float(bound), 2)
            assert np.array_equal(got, compiled_knn.points_within(plain, C, float(bound), 1))
        assert np.count_nonzero(ref_tie) > 50  # the ties are there


@compiled
def test_sample_tree_around_a_cylinder_from_both_sides():
    """A cylinder of radius 20 mm (its split frames bound curved patches, built from their
    children's boxes) with ball centres ρ = 6 mm off it outside and inside (the ball touches
    the convex side and the concave side: the samples around the contact lie a hair beyond
    ρ) and ±0.2 mm about that: the 8 nearest within ρ + 0.05 and the screens just below ρ
    from the tree split on the vertices are those of the plain tree and of brute force."""
    mesh = TriMesh.from_arrays(*cylinder_sheet(20.0, 2.0, 81, 8.0, 65))
    e, pts = mesh.edges, sample_points(mesh)
    rng = np.random.default_rng(37)
    t, h = rng.uniform(0.2, 1.8, 2000), rng.uniform(-6.0, 6.0, 2000)
    r = np.concatenate([np.full(800, 26.0), np.full(800, 14.0), 20.0 + rng.choice([-1, 1], 400)
                        * (6.0 + rng.uniform(-0.2, 0.2, 400))])
    C = np.column_stack([r * np.cos(t), r * np.sin(t), h])
    plain = compiled_knn.point_tree(pts, 1)
    tree = compiled_tables.sample_tree(mesh.V, e, mesh.F, 2)
    d = pts[None, :, :] - C[:, None, :]
    d2 = (d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1]) + d[..., 2] * d[..., 2]
    ids, tie = tree.query(C, 8, 6.05, 2)
    ref_ids, ref_tie = plain.query(C, 8, 6.05, 1)
    assert np.array_equal(ids, ref_ids) and np.array_equal(tie, ref_tie)
    order = np.argsort(d2, axis=1, kind="stable")[:, :8]  # equal distances: lower id first
    brute = np.where(np.take_along_axis(d2, order, axis=1) < 6.05 ** 2, order, -1)
    assert np.array_equal(ids[~tie], brute[~tie])
    for bound in (6.0 - 1e-4, 6.0 - 1e-5, 6.0, 6.0 + 1e-5, 6.05):
        got = compiled_knn.points_within(tree, C, bound, 2)
        assert np.array_equal(got, compiled_knn.points_within(plain, C, bound, 1)), bound
        assert np.array_equal(got, d2.min(axis=1) < bound * bound), bound
    # the balls outside touch: no sample within ρ − 1e-5, some within ρ + 0.01 (the
    # vertices lie on the cylinder, the midpoints and centroids inside it)
    out = slice(0, 800)
    assert not compiled_knn.points_within(tree, C[out], 6.0 - 1e-5, 2).any()
    assert compiled_knn.points_within(tree, C[out], 6.0 + 1e-2, 2).all()
