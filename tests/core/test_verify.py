"""Tests of blisk_cam.core.verify against analytic truths and brute force.

Every geometric figure is checked against a value derived by hand for a case built here:
ball scallops on a plane and on (convex and concave) spheres, a gouge of known depth, the
sagitta of CC and centre polylines on a cylinder, a straight move through a thin edge, and
exact point-to-mesh distances against brute force (with trimesh's independent
point-triangle routine as a cross-check).
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from blisk_cam.core.geometry.axis import Axis, meridional
from blisk_cam.core.geometry.closest import closest_on_segments, closest_on_triangles
from blisk_cam.core.geometry.distance import MeshDistance
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.part.cones import Cone, MorphingCones
from blisk_cam.core.tool.cutter import Cutter
from blisk_cam.core.toolpath.types import BallTool, PassCurve, ToolPath
from blisk_cam.core.verify.measure import verify_path
from blisk_cam.core.verify.samples import default_spacing, surface_samples
from blisk_cam.core.verify.sweep import SweptCutter
from blisk_cam.core.verify.sweep_ball import SweptBall
from tests.support.mesh_files import icosphere

try:  # an independent point-triangle routine for the brute-force cross-checks
    import trimesh
except ImportError:  # pragma: no cover
    trimesh = None

needs_trimesh = pytest.mark.skipif(trimesh is None, reason="trimesh not installed")
RHO = 6.0


# ----------------------------------------------------------------------------- builders
def grid_faces(nu, nv, wrap_u=False):
    """Two triangles per cell of an (nu, nv) vertex grid (u index major)."""
    idx = np.arange(nu * nv).reshape(nu, nv)
    if wrap_u:
        idx = np.vstack([idx, idx[:1]])
    a, b = idx[:-1, :-1], idx[1:, :-1]
    c, d = idx[1:, 1:], idx[:-1, 1:]
    return np.vstack([np.stack([a, b, c], -1).reshape(-1, 3),
                      np.stack([a, c, d], -1).reshape(-1, 3)])


def oriented(V, F, want, probe=0):
    """TriMesh (no automatic orientation) whose face ``probe`` has its normal along ``want``."""
    m = TriMesh.from_arrays(V, F, orient=False)
    if m.face_normals[probe] @ np.asarray(want, float) < 0:
        m = TriMesh.from_arrays(V, F[:, ::-1], orient=False)
    return m


def make_pass(s, cc, normal, closed=False, push=0.0):
    """A ball pass with the axis along the normal; ``push`` moves the tool into the surface."""
    cc = np.asarray(cc, float)
    n = np.asarray(normal, float)
    tip = cc - push * n
    return PassCurve(s=float(s), closed=closed, cc=cc, normal=n, tip=tip, axis=n.copy(),
                     face=np.full(len(cc), -1))


R1, R2 = 100.0, 130.0  # plane case: cylinders r = R1 and r = R2 about z


def plane_case(xs, *, push=0.0, jitter=0.15, seed=1, nz=11, dent=None):
    """The half-plane y = 0 (normal +y) between the cylinders r = R1 and r = R2 about z, a
    jittered grid mesh, and straight passes x = xs (z from 0 to 30) of a ball of radius RHO."""
    rng = np.random.default_rng(seed)
    nx, nzm = 81, 61
    x = np.linspace(95.0, 135.0, nx)
    z = np.linspace(0.0, 30.0, nzm)
    X, Z = np.meshgrid(x, z, indexing="ij")
    inner_x = (np.arange(nx)[:, None] % (nx - 1)) > 0
    inner_z = (np.arange(nzm)[None, :] % (nzm - 1)) > 0
    X = X + rng.uniform(-jitter, jitter, X.shape) * inner_x
    Z = Z + rng.uniform(-jitter, jitter, Z.shape) * inner_z
    V = np.stack([X.ravel(), np.zeros(X.size), Z.ravel()], 1)
    if dent is not None:
        V[dent[0], 1] = dent[1]
    mesh = oriented(V, grid_faces(nx, nzm), [0, 1, 0])
    curves = []
    for xi in xs:
        zz = np.linspace(0.0, 30.0, nz)
        cc = np.stack([np.full_like(zz, xi), np.zeros_like(zz), zz], 1)
        curves.append(make_pass((xi - R1) / (R2 - R1), cc, np.tile([0.0, 1.0, 0.0], (nz, 1)),
                                push=push))
    path = ToolPath(Axis(), Cone(R1, 0, R1, 30), Cone(R2, 0, R2, 30), BallTool(RHO), 0.05, 0.05,
                    curves)
    return mesh, path


RS = 20.0  # sphere case


def sphere_cones():
    u0 = np.array([np.sin(np.radians(55)), np.cos(np.radians(55))])
    u1 = np.array([np.sin(np.radians(75)), np.cos(np.radians(75))])
    c1 = Cone(*(0.5 * RS * u0), *(1.5 * RS * u0))
    c2 = Cone(*(0.5 * RS * u1), *(1.5 * RS * u1))
    return c1, c2


def sphere_case(thetas_deg, *, concave=False, dphi=0.25):
    """A patch of the sphere |x| = RS (polar angle 45°..85°, azimuth 0..60°), outside
    (convex) or inside (concave), with latitude passes at ``thetas_deg`` of a ball."""
    th = np.radians(np.linspace(45, 85, 81))
    ph = np.radians(np.linspace(0, 60, 121))
    T, P = np.meshgrid(th, ph, indexing="ij")
    V = RS * np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], -1).reshape(-1, 3)
    F = grid_faces(len(th), len(ph))
    sgn = -1.0 if concave else 1.0
    mesh = oriented(V, F, sgn * V[F[0]].mean(0))
    c1, c2 = sphere_cones()
    mc = MorphingCones(c1, c2)
    curves = []
    phi = np.radians(np.arange(0.0, 60.0 + 1e-9, dphi))
    for t in np.radians(thetas_deg):
        u = np.stack([np.sin(t) * np.cos(phi), np.sin(t) * np.sin(phi),
                      np.full_like(phi, np.cos(t))], 1)
        r, z = meridional(RS * u[:1], Axis())
        curves.append(make_pass(mc.ratio(r, z)[0], RS * u, sgn * u))
    path = ToolPath(Axis(), c1, c2, BallTool(RHO), 0.05, 0.05, curves)
    return mesh, path


def brute_distance(mesh, P):
    """Unsigned point-mesh distances by trimesh's point-triangle routine on every pair."""
    tri = mesh.V[mesh.F]
    out = np.empty(len(P))
    for i, p in enumerate(P):
        q = trimesh.triangles.closest_point(tri, np.tile(p, (len(tri), 1)))
        out[i] = np.sqrt(((q - p) ** 2).sum(1)).min()
    return out


def winding_number(P, tri):
    """Generalised winding number of points w.r.t. a closed triangle mesh (1 inside)."""
    out = np.empty(len(P))
    for i, p in enumerate(P):
        a, b, c = tri[:, 0] - p, tri[:, 1] - p, tri[:, 2] - p
        la, lb, lc = (np.linalg.norm(x, axis=1) for x in (a, b, c))
        num = np.einsum("ij,ij->i", a, np.cross(b, c))
        den = (la * lb * lc + np.einsum("ij,ij->i", a, b) * lc + np.einsum("ij,ij->i", b, c) * la
               + np.einsum("ij,ij->i", c, a) * lb)
        out[i] = np.arctan2(num, den).sum() / (2 * np.pi)
    return out


def noisy_sphere(seed, subdiv=2):
    V, F = icosphere(subdiv)
    rng = np.random.default_rng(seed)
    V = 10.0 * V * (1 + 0.08 * rng.standard_normal((len(V), 1)))
    return TriMesh.from_arrays(V, F)


# ----------------------------------------------------------------------------- point → mesh
@needs_trimesh
@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 10_000), spread=st.floats(0.5, 25.0))
def test_closest_points_match_brute_force(seed, spread):
    mesh = noisy_sphere(seed)
    rng = np.random.default_rng(seed + 1)
    P = rng.normal(0.0, spread, (60, 3))
    cp = MeshDistance(mesh).query(P)
    ref = brute_distance(mesh, P)
    np.testing.assert_allclose(cp.distance, ref, rtol=0, atol=1e-9)
    # the returned point is on the returned face and at the returned distance
    np.testing.assert_allclose(np.linalg.norm(P - cp.point, axis=1), cp.distance, atol=1e-9)
    tri = mesh.V[mesh.F[cp.face]]
    np.testing.assert_allclose((cp.bary[:, :, None] * tri).sum(1), cp.point, atol=1e-9)
    assert np.all(cp.bary >= -1e-12)


def sliver_mesh(seed, nrow, ncol, gap, needle):
    """A small wavy strip mesh full of thin triangles: rows of vertices ``gap`` mm apart with
    independent random x positions, zipped row to row (slivers where rows are close, long
    needles where the x positions of neighbouring rows interleave unevenly); ``needle`` of
    the x gaps shrink to 1e-4 of the rest. Faces are shuffled (the tree's leaf layout changes)."""
    rng = np.random.default_rng(seed)
    rows, V = [], []
    for i in range(nrow):
        dx = rng.uniform(0.2, 1.0, ncol - 1)
        dx[rng.random(ncol - 1) < needle] *= 1e-4
        x = np.concatenate([[0.0], np.cumsum(dx)])
        y = np.full(ncol, i * gap)
        rows.append(np.arange(i * ncol, (i + 1) * ncol))
        V.append(np.stack([x, y, 0.3 * np.sin(0.7 * x) + 0.2 * np.cos(1.3 * y)], 1))
    V = np.vstack(V)
    F = []
    for i in range(nrow - 1):  # zipper triangulation of rows i and i + 1 by their x order
        a, b = rows[i], rows[i + 1]
        j = k = 0
        while j < ncol - 1 or k < ncol - 1:
            if k == ncol - 1 or (j < ncol - 1 and V[a[j + 1], 0] <= V[b[k + 1], 0]):
                F.append([a[j], a[j + 1], b[k]])
                j += 1
            else:
                F.append([a[j], b[k + 1], b[k]])
                k += 1
    F = np.array(F)[rng.permutation(len(F))]
    return TriMesh.from_arrays(V, F, orient=False)


def brute_nearest(mesh, P):
    """(k,) distances from P to every face by the exact point-triangle routine (no tree)."""
    T = mesh.V[mesh.F]
    k, m = len(P), len(T)
    d2 = closest_on_triangles(np.repeat(P, m, 0), np.tile(T[:, 0], (k, 1)),
                              np.tile(T[:, 1], (k, 1)), np.tile(T[:, 2], (k, 1)))[1]
    return np.sqrt(d2.reshape(k, m).min(1))


def assert_leaves_contain_their_faces(md):
    """Every tree leaf's box and cylinder contain all corners of its own triangles."""
    tree, T = md.tree, md.mesh.V[md.mesh.F]
    leaf, slot = np.nonzero(tree.prims >= 0)
    node = leaf + tree.NL
    pts = T[tree.prims[leaf, slot]]  # (n, 3 corners, 3)
    lo, hi = tree.lo[node][:, None], tree.hi[node][:, None]
    assert np.all((pts >= lo - 1e-12) & (pts <= hi + 1e-12)), "a face is outside its leaf box"
    d = pts - tree.c[node][:, None]
    z = np.einsum("nci,ni->nc", d, tree.w[node])
    r = np.sqrt(np.maximum(np.einsum("nci,nci->nc", d, d) - z * z, 0.0))
    assert np.all(np.abs(z) <= tree.H[node][:, None] + 1e-9)
    assert np.all(r <= tree.R[node][:, None] + 1e-9)


def test_point_on_a_thin_face_of_the_scan_like_demo_blade():
    """Regression: on this blade the leaf holding the thin face 24123 (edges 0.042, 0.970,
    0.971 mm) had a padding slot first and was bounded by the previous leaf's triangles, so
    the midpoint of its boundary edge 12510–12511 came out 0.0211 mm from the mesh (face
    24124) instead of on it. Every edge midpoint of the mesh must be on it."""
    from blisk_cam.core.part.blisk import make_demo_blisk

    d = make_demo_blisk(resolution=0.5, fillet_radius=10, scan_like=True, seed=4)
    mesh = TriMesh.from_arrays(d.blade_vertices, d.blade_faces)
    assert list(mesh.F[24123]) == [12510, 12511, 12311]
    T = mesh.V[mesh.F[24123]]
    np.testing.assert_allclose(np.sort(np.linalg.norm(T - np.roll(T, 1, 0), axis=1)),
                               [0.0423, 0.9702, 0.9712], atol=1e-4)
    md = MeshDistance(mesh)
    p = 0.5 * (mesh.V[12510] + mesh.V[12511])
    cp = md.query(p[None])
    assert cp.distance[0] < 1e-12 and cp.face[0] == 24123
    assert_leaves_contain_their_faces(md)
    mids = 0.5 * (mesh.V[mesh.edges[:, 0]] + mesh.V[mesh.edges[:, 1]])
    assert md.query(mids).distance.max() < 1e-9


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10_000), nrow=st.integers(2, 6), ncol=st.integers(3, 30),
       gap=st.sampled_from([1e-3, 0.02, 0.3, 1.0]), needle=st.sampled_from([0.0, 0.3]))
# layouts whose partly filled leaf had a padding slot first (mis-bounded before the fix) and
# needles of 1:10⁴ (points on them came out 1e-5 mm off with the Gram-determinant solve)
@example(seed=9, nrow=6, ncol=14, gap=0.02, needle=0.3)
@example(seed=12, nrow=4, ncol=15, gap=1e-3, needle=0.3)
@example(seed=0, nrow=2, ncol=4, gap=1e-3, needle=0.3)
def test_points_on_thin_triangles_are_on_the_mesh(seed, nrow, ncol, gap, needle):
    """Slivers and needles in a small mesh (any face count, so the tree has padding): points
    on every face (inside, on edges, at corners) are at distance 0, and points off the
    surface at the brute-force distance over all faces; the leaves bound their faces."""
    mesh = sliver_mesh(seed, nrow, ncol, gap, needle)
    md = MeshDistance(mesh, leaf_size=8)
    assert_leaves_contain_their_faces(md)
    rng = np.random.default_rng(seed)
    T = mesh.V[mesh.F]
    w = np.vstack([rng.dirichlet([1.0, 1.0, 1.0], len(T)),  # interior
                   np.tile([0.5, 0.5, 0.0], (len(T), 1)), np.tile([0.0, 0.3, 0.7], (len(T), 1)),
                   np.tile([1.0, 0.0, 0.0], (len(T), 1))])  # edges and a corner
    on = np.einsum("kc,kci->ki", w, np.tile(T, (4, 1, 1)))
    cp = md.query(on)
    assert cp.distance.max() < 1e-9  # rounding of a sliver's plane: up to ~1e-11 mm
    np.testing.assert_allclose(cp.distance, brute_nearest(mesh, on), rtol=0, atol=1e-12)
    off = on[rng.choice(len(on), min(len(on), 200), replace=False)]
    off = off + rng.normal(0.0, [0.05, 0.05, 0.3], off.shape)
    np.testing.assert_allclose(md.query(off).distance, brute_nearest(mesh, off), rtol=0,
                               atol=1e-12)


def test_sign_is_the_inside_outside_test_near_edges_and_vertices():
    mesh = noisy_sphere(3)
    rng = np.random.default_rng(5)
    # points close to the surface, many of them nearest to an edge or a vertex
    P = mesh.V[rng.integers(0, mesh.n_vertices, 150)] + rng.normal(0, 0.4, (150, 3))
    e = mesh.edges[rng.integers(0, len(mesh.edges), 150)]
    P = np.vstack([P, mesh.V[e].mean(1) + rng.normal(0, 0.3, (150, 3))])
    cp = MeshDistance(mesh).query(P)
    inside = winding_number(P, mesh.V[mesh.F]) > 0.5
    assert np.any(cp.feature >= 4) and np.any((cp.feature >= 1) & (cp.feature <= 3))
    np.testing.assert_array_equal(cp.sign < 0, inside)


def test_closest_on_triangles_degenerate_and_regions():
    a = np.array([[0.0, 0, 0]])
    b = np.array([[2.0, 0, 0]])
    c = np.array([[4.0, 0, 0]])  # collinear: the triangle is the segment a-c
    p = np.array([[1.0, 3.0, 4.0]])
    q, d2, feat, bary = closest_on_triangles(p, a, b, c)
    np.testing.assert_allclose(q, [[1.0, 0, 0]], atol=1e-12)
    assert d2[0] == pytest.approx(25.0)
    # a proper triangle: one query per region (face, 3 edges, 3 vertices)
    A, B, C = np.array([0.0, 0, 0]), np.array([3.0, 0, 0]), np.array([0.0, 3.0, 0])
    P = np.array([[1, 1, 2], [1.5, -1, 1], [2, 2, -1], [-1, 1.5, 0], [-1, -1, 1], [4, -1, 0],
                  [-1, 4, 2]], float)
    k = len(P)
    q, d2, feat, bary = closest_on_triangles(P, np.tile(A, (k, 1)), np.tile(B, (k, 1)),
                                             np.tile(C, (k, 1)))
    np.testing.assert_array_equal(feat, [0, 1, 2, 3, 4, 5, 6])
    ref = [[1, 1, 0], [1.5, 0, 0], [1.5, 1.5, 0], [0, 1.5, 0], [0, 0, 0], [3, 0, 0], [0, 3, 0]]
    np.testing.assert_allclose(q, ref, atol=1e-12)
    if trimesh is not None:
        ref = trimesh.triangles.closest_point(np.tile([A, B, C], (k, 1, 1)), P)
        np.testing.assert_allclose(q, ref, atol=1e-12)


# ----------------------------------------------------------------------------- samples
def test_surface_samples_cover_the_region_only_and_are_deterministic():
    mesh, path = plane_case([100.0, 130.0])
    mc = MorphingCones(path.cone1, path.cone2)
    sp = 0.4
    smp = surface_samples(mesh, mc, path.axis, sp)
    again = surface_samples(mesh, mc, path.axis, sp)
    np.testing.assert_array_equal(smp.points, again.points)
    assert np.all((smp.s >= -1e-9) & (smp.s <= 1 + 1e-9))
    # the boundary samples lie on the cones r = R1, R2 (here the plane y = 0: x = R1, R2)
    xb = smp.points[len(smp) - smp.n_boundary :, 0]
    assert smp.n_boundary > 0
    assert np.all(np.minimum(np.abs(xb - R1), np.abs(xb - R2)) < 1e-9)
    # grid edges no longer than the spacing, all on the mesh (y = 0)
    e = smp.edges
    assert np.linalg.norm(smp.points[e[:, 0]] - smp.points[e[:, 1]], axis=1).max() <= sp + 1e-12
    assert np.abs(smp.points[:, 1]).max() < 1e-12
    np.testing.assert_allclose(smp.normals, np.tile([0, 1.0, 0], (len(smp), 1)), atol=1e-12)
    # every point of the region is within the spacing of a sample
    rng = np.random.default_rng(0)
    q = np.stack([rng.uniform(R1, R2, 2000), np.zeros(2000), rng.uniform(0, 30, 2000)], 1)
    from scipy.spatial import cKDTree

    d, _ = cKDTree(smp.points).query(q)
    assert d.max() <= sp
    # vertex samples are the mesh vertices of the region
    v = smp.vertex[smp.vertex >= 0]
    np.testing.assert_array_equal(smp.points[smp.vertex >= 0], mesh.V[v])
    inside_v = (mesh.V[:, 0] >= R1) & (mesh.V[:, 0] <= R2)
    assert set(v.tolist()) == set(np.nonzero(inside_v)[0].tolist())


def test_sample_grid_of_one_triangle():
    V = np.array([[100.0, 0, 0], [103.0, 0, 0], [100.0, 0, 3.0]])
    mesh = TriMesh.from_arrays(V, [[0, 1, 2]], orient=False)
    mc = MorphingCones(Cone(R1, 0, R1, 30), Cone(R2, 0, R2, 30))
    smp = surface_samples(mesh, mc, Axis(), 1.5)  # longest edge 4.24: 3 segments per side
    assert len(smp) == 10 and smp.n_boundary == 0
    assert len(smp.edges) == 18  # 9 small triangles, 3 n (n + 1) / 2 edges
    lengths = np.linalg.norm(np.diff(smp.points[smp.edges], axis=1)[:, 0], axis=1)
    expected = np.r_[np.full(12, 1.0), np.full(6, np.sqrt(2))]
    np.testing.assert_allclose(np.sort(lengths), np.sort(expected))
    np.testing.assert_allclose((smp.bary[:, :, None] * V[None]).sum(1), smp.points, atol=1e-12)


def test_default_spacing_is_a_third_of_the_flat_pass_spacing():
    w = 2 * np.sqrt(2 * 6.0 * 0.05 - 0.05**2)
    assert default_spacing(6.0, 0.05) == pytest.approx(w / 3)
    assert default_spacing(6.0, 0.0) == pytest.approx(6.0 / 8)


# ----------------------------------------------------------------------------- swept ball
@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 10_000), n=st.integers(1, 60))
def test_swept_ball_distance_matches_brute_force(seed, n):
    rng = np.random.default_rng(seed)
    pts = np.cumsum(rng.normal(0, 1.5, (n + 1, 3)), axis=0)
    a, b = pts[:-1], pts[1:]
    if n > 3:
        b[n // 2] = a[n // 2]  # a zero-length segment (a ball)
    sb = SweptBall(a, b, 2.0)
    P = rng.normal(pts.mean(0), 6.0, (300, 3))
    d, seg = sb.nearest(P)
    k, m = len(P), len(a)
    _, d2 = closest_on_segments(np.repeat(P, m, 0), np.tile(a, (k, 1)), np.tile(b, (k, 1)))
    ref = np.sqrt(d2.reshape(k, m).min(1)) - 2.0
    np.testing.assert_allclose(d, ref, atol=1e-12)
    _, d2s = closest_on_segments(P, a[seg], b[seg])
    np.testing.assert_allclose(np.sqrt(d2s) - 2.0, ref, atol=1e-12)


def test_ray_height_of_a_ball():
    sb = SweptBall(np.array([[0.0, 0, 5]]), np.array([[0.0, 0, 5]]), 3.0)
    h = sb.height_along(np.array([[0.0, 0, 0], [1.0, 0, 0], [5.0, 0, 0]]),
                        np.tile([0, 0, 1.0], (3, 1)), np.array([10.0, 10.0, 10.0]))
    np.testing.assert_allclose(h[:2], [2.0, 5 - np.sqrt(8.0)], atol=1e-12)
    assert h[2] == np.inf


# ----------------------------------------------------------------------------- scallops
@pytest.mark.parametrize("widths", [[1.5] * 20, [1.0, 2.0, 0.7, 1.55, 2.5, 1.2]])
def test_plane_scallops_are_the_analytic_ones(widths):
    xs = R1 + np.concatenate([[0.0], np.cumsum(widths)])
    assert xs[-1] <= R2 + 1e-9
    mesh, path = plane_case(xs)
    rep = verify_path(mesh, path)
    w = np.diff(xs)
    euclid = np.sqrt(RHO**2 + w**2 / 4) - RHO  # surface point to the envelope
    normal = RHO - np.sqrt(RHO**2 - w**2 / 4)  # the textbook scallop height
    np.testing.assert_allclose(rep.pair_cusp, euclid, rtol=0, atol=1e-9)
    np.testing.assert_allclose(rep.pair_cusp_normal, normal, rtol=0, atol=1e-9)
    np.testing.assert_allclose(rep.pair_where[:, 0], 0.5 * (xs[:-1] + xs[1:]), atol=1e-6)
    np.testing.assert_allclose(rep.pair_s, (np.stack([xs[:-1], xs[1:]], 1) - R1) / (R2 - R1),
                               atol=1e-12)
    assert rep.pair_gouge.max() < 1e-12 and rep.max_gouge < 1e-12
    assert rep.cc_on_mesh < 1e-9 and rep.cc_on_cone < 1e-9 and rep.cc_chord < 1e-9
    assert rep.path_overcut < 1e-9 and rep.path_undercut < 1e-9
    assert rep.normal_error_deg < 1e-6 and rep.pose_mismatch == 0.0
    # the region beyond the last pass (if any) is uncut: more material than any scallop
    assert rep.max_material_left >= euclid.max() - 1e-9
    if xs[-1] < R2 - 1e-9:
        assert rep.max_material_left == pytest.approx(np.sqrt(RHO**2 + (R2 - xs[-1]) ** 2) - RHO,
                                                      abs=1e-9)
    json.dumps(rep.summary())


def test_scallop_figure_does_not_depend_on_the_sample_spacing():
    mesh, path = plane_case(R1 + np.arange(0, 30.01, 1.7))
    a = verify_path(mesh, path, spacing=0.2)
    b = verify_path(mesh, path, spacing=0.55)
    np.testing.assert_allclose(a.pair_cusp, b.pair_cusp, atol=1e-9)
    assert a.n_samples > 2 * b.n_samples


def test_gouge_depth_is_measured():
    delta = 0.03
    mesh, path = plane_case(R1 + np.arange(0, 30.01, 1.5), push=delta)
    rep = verify_path(mesh, path)
    assert rep.max_gouge == pytest.approx(delta, abs=1e-9)
    assert rep.path_overcut == pytest.approx(delta, abs=1e-9)
    np.testing.assert_allclose(rep.pair_gouge, delta, atol=1e-9)
    # the centres are δ lower: the scallop shrinks to sqrt((ρ−δ)² + w²/4) − ρ
    shrunk = np.sqrt((RHO - delta) ** 2 + 0.75**2) - RHO
    np.testing.assert_allclose(rep.pair_cusp, shrunk, atol=1e-9)
    assert abs(rep.max_gouge_at[1]) < 1e-12  # on the surface


def test_vertex_values_measure_a_dent_and_are_nan_outside():
    xs = R1 + np.arange(0, 30.01, 1.5)
    mesh0, _ = plane_case(xs, jitter=0.0)
    # the grid vertex nearest to the middle of a strip, pushed 0.2 mm into the material
    # (TriMesh.from_arrays may renumber the vertices: find it again by its position)
    target = np.array([R1 + 6.75, 0.0, 15.0])
    vid0 = int(np.argmin(np.linalg.norm(mesh0.V - target, axis=1)))
    pos = mesh0.V[vid0]
    V = np.stack(np.meshgrid(np.linspace(95.0, 135.0, 81), np.linspace(0.0, 30.0, 61),
                             indexing="ij"), -1).reshape(-1, 2)
    raw = int(np.argmin(np.linalg.norm(V - pos[[0, 2]], axis=1)))
    mesh, path = plane_case(xs, jitter=0.0, dent=(raw, -0.2))
    vid = int(np.argmin(mesh.V[:, 1]))
    p = mesh.V[vid]
    assert p[1] == -0.2 and np.allclose(p[[0, 2]], pos[[0, 2]])
    rep = verify_path(mesh, path)
    dx = np.min(np.abs(xs - p[0]))
    assert rep.vertex_values[vid] == pytest.approx(np.hypot(RHO + 0.2, dx) - RHO, abs=1e-9)
    outside = (mesh.V[:, 0] < R1 - 1e-9) | (mesh.V[:, 0] > R2 + 1e-9)
    assert np.all(np.isnan(rep.vertex_values[outside]))
    assert np.all(np.isfinite(rep.vertex_values[~outside]))
    assert rep.max_material_left >= rep.vertex_values[vid] - 1e-12


@pytest.mark.parametrize("concave", [False, True])
def test_sphere_scallops_are_the_analytic_ones(concave):
    thetas = np.array([55.0, 59.0, 62.5, 67.0, 70.0, 75.0])
    mesh, path = sphere_case(thetas, concave=concave)
    rep = verify_path(mesh, path)
    alpha = np.radians(np.diff(thetas)) / 2
    rc = RS - RHO if concave else RS + RHO
    euclid = np.sqrt(RS**2 + rc**2 - 2 * RS * rc * np.cos(alpha)) - RHO
    root = np.sqrt(RHO**2 - (rc * np.sin(alpha)) ** 2)
    normal = RS - (rc * np.cos(alpha) + root) if concave else rc * np.cos(alpha) - root - RS
    # mesh facets (sagitta ≈ 2.4e-4 mm) and the centre chords (≈ 6e-5 mm) bound the error
    np.testing.assert_allclose(rep.pair_cusp, euclid, atol=6e-4)
    np.testing.assert_allclose(rep.pair_cusp_normal, normal, atol=6e-4)
    # the concave sphere leaves less material than the plane, the convex one more
    flat = np.sqrt(RHO**2 + (RS * 2 * alpha) ** 2 / 4) - RHO
    assert np.all(rep.pair_cusp < flat) if concave else np.all(rep.pair_cusp > flat)
    assert rep.cc_on_cone < 1e-9
    assert rep.cc_on_mesh < 3e-4


def test_two_passes_cusp_binding_check_style():
    """The check the path generator's tests will make: every binding pair ≥ 0.8 h, all ≤ h."""
    h = 0.05
    w = 2 * np.sqrt(2 * RHO * h - h * h)
    xs = np.append(R1 + np.arange(0, 30, w), R2)
    mesh, path = plane_case(xs)
    rep = verify_path(mesh, path)
    binding = rep.pair_cusp_normal[:-1]
    assert np.all(binding >= 0.8 * h) and np.all(rep.pair_cusp_normal <= h + 1e-9)
    assert rep.pair_cusp_normal[-1] < h


# ----------------------------------------------------------------------------- chords
RC = 20.0


def cylinder_case(n_cc, *, concave=False):
    """Cylinder r = RC about z (z 0..10), outside or inside, with one closed circular pass of
    ``n_cc`` CC points at z = 5 between the disks z = 2 and z = 8."""
    nth = 1440
    th = np.linspace(0, 2 * np.pi, nth, endpoint=False)
    z = np.linspace(0, 10, 11)
    T, Z = np.meshgrid(th, z, indexing="ij")
    V = np.stack([RC * np.cos(T), RC * np.sin(T), Z], -1).reshape(-1, 3)
    F = grid_faces(nth, len(z), wrap_u=True)
    sgn = -1.0 if concave else 1.0
    mesh = oriented(V, F, sgn * np.array([V[F[0]].mean(0)[0], V[F[0]].mean(0)[1], 0.0]))
    t = np.linspace(0, 2 * np.pi, n_cc, endpoint=False)
    u = np.stack([np.cos(t), np.sin(t), np.zeros_like(t)], 1)
    cc = RC * u + [0, 0, 5.0]
    path = ToolPath(Axis(), Cone(0, 2, 100, 2), Cone(0, 8, 100, 8), BallTool(RHO), 0.05, 0.05,
                    [make_pass(0.5, cc, sgn * u, closed=True)])
    return mesh, path


@pytest.mark.parametrize("concave", [False, True])
def test_chord_errors_on_a_cylinder_are_the_sagittas(concave):
    n = 36
    mesh, path = cylinder_case(n, concave=concave)
    rep = verify_path(mesh, path)
    half = np.pi / n
    sag_cc = RC * (1 - np.cos(half))
    mesh_sag = RC * (1 - np.cos(np.pi / 1440))
    assert rep.cc_chord == pytest.approx(sag_cc, abs=mesh_sag + 1e-9)
    rc = RC - RHO if concave else RC + RHO
    sag_c = rc * (1 - np.cos(half))
    if concave:  # the centre chords leave the offset surface: undercut
        assert rep.path_undercut == pytest.approx(sag_c, abs=mesh_sag + 1e-9)
        assert rep.path_overcut < mesh_sag + 1e-9
    else:  # the centre chords cut below the offset surface: overcut
        assert rep.path_overcut == pytest.approx(sag_c, abs=mesh_sag + 1e-9)
        assert rep.path_undercut < mesh_sag + 1e-9
    assert rep.cc_on_mesh < 1e-9 and rep.n_levels == 1 and len(rep.pair_cusp) == 0


def stadium(t=0.5, length=30.0):
    """Profile of a thin plate: flat sides y = ±t for x in [0, length], half-round leading
    edge at x = 0 and trailing edge at x = length (radius t); 1° steps on the edges, 0.25 mm
    on the sides. Returns (top, leading edge, bottom, trailing edge) (k, 2) pieces, in order
    around the profile."""
    side = np.arange(0.25, length, 0.25)
    le = np.radians(np.arange(90, 271, 1.0))
    te = np.radians(np.arange(-90, 91, 1.0))
    top = np.stack([side[::-1], np.full_like(side, t)], 1)  # x decreasing on y = +t
    lep = np.stack([t * np.cos(le), t * np.sin(le)], 1)  # (0, t) → (0, −t) around x < 0
    bot = np.stack([side, np.full_like(side, -t)], 1)
    tep = np.stack([length + t * np.cos(te), t * np.sin(te)], 1)
    return top, lep, bot, tep


def thin_edge_case(with_edge_poses):
    t = 0.5
    top, lep, bot, tep = stadium(t)
    prof = np.vstack([top, lep, bot, tep[:-1]])
    prof = prof[np.r_[True, np.linalg.norm(np.diff(prof, axis=0), axis=1) > 1e-9]]
    z = np.linspace(0, 10, 21)
    n = len(prof)
    V = np.stack([np.repeat(prof[:, :1], len(z), 1), np.repeat(prof[:, 1:], len(z), 1),
                  np.tile(z, (n, 1))], -1).reshape(-1, 3)
    mesh = TriMesh.from_arrays(V, grid_faces(n, len(z), wrap_u=True))  # oriented outward
    # pass at z = 5: top side every 1 mm, the leading edge every 5° (or skipped), bottom side
    xs = np.arange(29.0, 0.0 - 1e-9, -1.0)
    cc = [np.stack([xs, np.full_like(xs, t)], 1)]
    nn = [np.tile([0.0, 1.0], (len(xs), 1))]
    if with_edge_poses:
        a = np.radians(np.arange(95.0, 270.0, 5.0))
        cc.append(np.stack([t * np.cos(a), t * np.sin(a)], 1))
        nn.append(np.stack([np.cos(a), np.sin(a)], 1))
    cc.append(np.stack([xs[::-1], np.full_like(xs, -t)], 1))
    nn.append(np.tile([0.0, -1.0], (len(xs), 1)))
    cc2, n2 = np.vstack(cc), np.vstack(nn)
    cc3 = np.column_stack([cc2, np.full(len(cc2), 5.0)])
    n3 = np.column_stack([n2, np.zeros(len(n2))])
    path = ToolPath(Axis(), Cone(0, 2, 100, 2), Cone(0, 8, 100, 8), BallTool(RHO), 0.05, 0.05,
                    [make_pass(0.5, cc3, n3, closed=False)])
    return mesh, path, t


def test_straight_move_across_a_thin_edge_is_a_large_overcut():
    mesh, path, t = thin_edge_case(with_edge_poses=False)
    assert mesh.face_normals[np.argmax(mesh.V[mesh.F].mean(1)[:, 1])][1] > 0  # outward
    bad = verify_path(mesh, path)
    # the centre moves straight from (0, t + ρ) to (0, −t − ρ): through the edge's centre,
    # which is t inside the material, so the ball cuts ρ + t below the surface
    assert bad.path_overcut == pytest.approx(RHO + t, abs=1e-3)
    np.testing.assert_allclose(bad.path_overcut_at, [0.0, 0.0, 5.0], atol=1e-9)
    assert bad.max_gouge > 1.0  # the swept ball also gouges the region's surface
    # the CC chord across the edge passes through the edge's centre too, only t from the
    # surface: the CC check alone would call this a 0.5 mm chord error
    assert bad.cc_chord == pytest.approx(t, abs=1e-3)
    mesh, path, t = thin_edge_case(with_edge_poses=True)
    good = verify_path(mesh, path)
    # around the edge the centres are on a circle of radius t + ρ, 5° apart
    sag = (t + RHO) * (1 - np.cos(np.radians(2.5)))
    assert good.path_overcut == pytest.approx(sag, abs=2e-4)
    assert good.max_gouge < sag + 2e-4


# ----------------------------------------------------------------------------- on mesh / cone
def test_points_off_their_cone_and_off_the_mesh_are_reported():
    xs = R1 + np.arange(0, 30.01, 1.5)
    mesh, path = plane_case(xs)
    c = path.curves[3]
    path.curves[3] = PassCurve(c.s + 0.01, c.closed, c.cc, c.normal, c.tip, c.axis, c.face)
    c = path.curves[5]
    lifted = c.cc + [0, 0.02, 0]
    path.curves[5] = PassCurve(c.s, c.closed, lifted, c.normal, lifted.copy(), c.axis, c.face)
    rep = verify_path(mesh, path)
    # the LMC at s + 0.01 is the cylinder r = R1 + (s + 0.01)(R2 − R1): 0.3 mm away
    assert rep.cc_on_cone == pytest.approx(0.01 * (R2 - R1), abs=1e-9)
    assert rep.curve_on_cone[3] == pytest.approx(0.3, abs=1e-9)
    assert rep.cc_on_mesh == pytest.approx(0.02, abs=1e-9)
    assert rep.curve_on_mesh[5] == pytest.approx(0.02, abs=1e-9)
    assert rep.path_undercut == pytest.approx(0.02, abs=1e-9)


def test_pose_mismatch_between_cl_and_cc_data():
    mesh, path = plane_case(R1 + np.arange(0, 30.01, 1.5))
    c = path.curves[0]
    tilted = np.tile([np.sin(0.1), np.cos(0.1), 0.0], (len(c.cc), 1))
    path.curves[0] = PassCurve(c.s, c.closed, c.cc, c.normal, c.tip, tilted, c.face)
    rep = verify_path(mesh, path)
    expected = RHO * np.linalg.norm(tilted[0] - [0, 1, 0])
    assert rep.pose_mismatch == pytest.approx(expected, abs=1e-12)


def test_closing_move_of_a_closed_pass_is_checked():
    mesh, path = cylinder_case(36)
    c = path.curves[0]
    keep = np.arange(35)  # drop the point at 350°: the closing move spans 20°
    path.curves[0] = PassCurve(c.s, True, c.cc[keep], c.normal[keep], c.tip[keep], c.axis[keep],
                               c.face[keep])
    rep = verify_path(mesh, path)
    assert rep.cc_chord == pytest.approx(RC * (1 - np.cos(np.radians(10))), abs=1e-4)
    assert rep.path_overcut == pytest.approx((RC + RHO) * (1 - np.cos(np.radians(10))), abs=1e-4)


def test_several_curves_on_one_level_make_one_pass():
    xs = R1 + np.arange(0, 30.01, 1.5)
    mesh, path = plane_case(xs)
    split = []
    for c in path.curves:  # each pass as two curves, z 0..15 and 15..30, same s
        for sl in (slice(0, 6), slice(5, 11)):
            split.append(PassCurve(c.s, False, c.cc[sl], c.normal[sl], c.tip[sl], c.axis[sl],
                                   c.face[sl]))
    path.curves = split
    rep = verify_path(mesh, path)
    assert rep.n_levels == len(xs) and rep.n_curves == 2 * len(xs)
    np.testing.assert_allclose(rep.pair_cusp, np.sqrt(RHO**2 + 0.75**2) - RHO, atol=1e-9)


# ----------------------------------------------------------------------------- other cutters
def reposed(path, cutter, lead, tilt=0.0, push=0.0):
    """The plane case's passes (feed +z, normal +y) for ``cutter``: axis tilted by
    ``lead`` toward the feed and ``tilt`` toward the side (−x), tip from the cutter touching
    the CC point, then pushed ``push`` mm along −n into the surface."""
    curves = []
    a = np.array([-np.sin(tilt) * np.cos(lead), np.cos(lead) * np.cos(tilt), np.sin(lead)])
    a /= np.linalg.norm(a)
    for c in path.curves:
        # the passes run on beyond the mesh (z 0 … 30) so that their ends, where a tilted
        # cutter leaves more, are outside the measured region
        zz = np.linspace(-12.0, 42.0, 28)
        cc = np.stack([np.full_like(zz, c.cc[0, 0]), np.zeros_like(zz), zz], 1)
        nrm = np.tile(c.normal[0], (len(zz), 1))
        ax = np.tile(a, (len(zz), 1))
        tip = cutter.cl_points(cc, nrm, ax) - push * nrm
        curves.append(PassCurve(c.s, c.closed, cc, nrm, tip, ax, np.full(len(zz), -1)))
    return ToolPath(path.axis, path.cone1, path.cone2, cutter, path.cusp, path.chord, curves)


def swept_section_height(cutter, tip, axis, x):
    """Height above the plane y = 0 of the cutter swept along the infinite line z at x (mm):
    bisection on y, Brent along z on the exact signed distance (convex along a line)."""
    from scipy.optimize import minimize_scalar

    def inside(y):
        f = lambda z: float(cutter.signed_distance(np.array([x, y, z]), tip, axis))  # noqa: E731
        return minimize_scalar(f, bounds=(tip[2] - 40, tip[2] + 40), method="bounded",
                               options={"xatol": 1e-11}).fun < 0

    lo, hi = -1.0, 2.0
    for _ in range(55):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if inside(mid) else (mid, hi)
    return 0.5 * (lo + hi)


@pytest.mark.parametrize("cutter, lead", [(Cutter.bull(6.0, 2.0), 0.1), (Cutter.flat(5.0), 0.12)])
def test_plane_scallops_of_bull_and_flat_with_lead(cutter, lead):
    """Straight passes 2 mm apart with a lead along the feed: each pair's scallop (height
    along the normal) is the swept section's height half-way, measured here by line searches
    on the cutter's exact distance; nothing gouges; every CC point is on its posed cutter."""
    xs = R1 + np.arange(0, 8.01, 2.0)
    mesh, path = plane_case(xs)
    path = reposed(path, cutter, lead)
    rep = verify_path(mesh, path)
    c = path.curves[0]
    h = swept_section_height(cutter, c.tip[5], c.axis[5], xs[0] + 1.0)
    assert h > 1e-3  # a real scallop, not a flat bottom
    np.testing.assert_allclose(rep.pair_cusp_normal, h, rtol=1e-4, atol=1e-8)
    # the closed form from the effective radius agrees to its O(w²) accuracy
    reff = cutter.effective_radius([0, 1, 0], c.axis[0], [1, 0, 0])[0]
    assert h == pytest.approx(reff - np.sqrt(reff**2 - 1.0), rel=0.02)
    assert rep.max_gouge < 1e-9 and rep.cc_contact < 1e-9 and rep.pose_mismatch < 1e-9
    assert rep.path_overcut < 1e-9 and rep.tool["type"] == cutter.type
    assert rep.max_material_left <= h + 1e-9 or xs[-1] < R2  # beyond the last pass: uncut


def test_bull_with_tilt_leaves_the_corner_radius_scallop():
    """Tilted toward the side the bull-nose cuts across with its corner: the scallop is the
    corner circle's, r − sqrt(r² − w²/4) for passes w apart (r = 2, w = 1)."""
    cutter = Cutter.bull(6.0, 2.0)
    xs = R1 + np.arange(0, 4.01, 1.0)
    mesh, path = plane_case(xs)
    path = reposed(path, cutter, 0.0, tilt=0.25)
    rep = verify_path(mesh, path)
    # the swept section is the corner circle at the contact (R_eff = r) and deviates from it
    # by O(w⁴) away from it: 7e-6 mm here
    assert cutter.effective_radius([0, 1, 0], path.curves[0].axis[0], [1, 0, 0])[0] == \
        pytest.approx(2.0, rel=1e-12)
    np.testing.assert_allclose(rep.pair_cusp_normal, 2.0 - np.sqrt(4.0 - 0.25), atol=2e-5)
    assert rep.max_gouge < 1e-9 and rep.cc_contact < 1e-9


@pytest.mark.parametrize("cutter", [Cutter.bull(6.0, 2.0), Cutter.flat(5.0),
                                    Cutter.taper(3.0, np.radians(5))])
def test_gouging_path_is_caught_for_any_cutter(cutter):
    delta = 0.04
    mesh, path = plane_case(R1 + np.arange(0, 6.01, 1.5))
    path = reposed(path, cutter, 0.1, tilt=0.05, push=delta)
    rep = verify_path(mesh, path)
    # the gouge is the depth of the surface inside the swept cutter (distance to its
    # boundary): the push where the contact is smooth; at a flat mill's sharp edge the side
    # is nearer than the bottom, so less
    if cutter.r > 0:
        assert rep.max_gouge == pytest.approx(delta, abs=1e-6)
        assert rep.path_overcut == pytest.approx(delta, abs=1e-6)
        assert rep.cc_contact == pytest.approx(delta, abs=1e-6)
    else:
        assert 0.5 * delta < rep.max_gouge <= delta + 1e-9
        assert 0.1 * delta < rep.path_overcut <= delta + 1e-9
    assert rep.pose_mismatch == pytest.approx(delta, abs=1e-9)


def test_only_cut_moves_are_measured():
    """Poses reached by non-cut moves (link, rapid...) are not machining: a pass whose middle
    poses plunge 0.5 mm but are marked as links measures no gouge; marked as cuts it does."""
    mesh, path = plane_case(R1 + np.arange(0, 6.01, 1.5))
    c = path.curves[1]
    tip = c.tip.copy()
    tip[4:7] -= [0.0, 0.5, 0.0]
    plunged = PassCurve(c.s, False, c.cc, c.normal, tip, c.axis, c.face)
    path.curves[1] = plunged
    assert verify_path(mesh, path).max_gouge == pytest.approx(0.5, abs=1e-9)
    if not hasattr(plunged, "move"):  # pragma: no cover - older PassCurve without moves
        pytest.skip("PassCurve has no move codes")
    move = np.zeros(len(c.cc), np.int8)
    move[4:8] = 1  # segments 3→4 … 7→8 are links: poses 4..6 are never cut through
    plunged.move = move
    rep = verify_path(mesh, path)
    assert rep.max_gouge < 1e-9
    assert rep.n_poses == len(path.curves[0].cc) * len(path.curves) - 3


def test_ball_given_as_cutter_dict_or_legacy_is_the_same():
    mesh, path = plane_case(R1 + np.arange(0, 9.01, 1.5))
    a = verify_path(mesh, path).summary()
    path.tool = {"type": "ball", "radius": RHO}
    b = verify_path(mesh, path).summary()
    path.tool = Cutter.ball(RHO)
    c = verify_path(mesh, path).summary()
    for k in ("max_material_left", "max_cusp", "max_cusp_normal", "max_gouge", "pose_mismatch",
              "cc_contact", "path_overcut"):
        assert a[k] == b[k] == c[k]


@pytest.mark.parametrize("method", ["fast", "exact"])
@pytest.mark.parametrize("cutter", [Cutter.bull(6.0, 2.0), Cutter.flat(5.0)])
def test_swept_cutter_distance_against_dense_poses(cutter, method):
    """The swept distance is never above the distance to densely interpolated poses (it is
    a minimum over t) and never more than the dense sampling's own error below it."""
    rng = np.random.default_rng(2)
    x = np.linspace(0, 6, 7)
    tips = np.stack([x, 0.4 * np.sin(x), 0.05 * x * x], 1)
    ax = np.stack([0.15 * np.sin(x), 0.1 + 0 * x, 1 + 0 * x], 1)
    ax /= np.linalg.norm(ax, axis=1)[:, None]
    sw = SweptCutter(cutter, tips[:-1], ax[:-1], tips[1:], ax[1:], method=method)
    P = np.stack([rng.uniform(-1, 7, 800), rng.uniform(-7, 7, 800), rng.uniform(-2, 1, 800)], 1)
    d = sw.distance(P)
    T = np.linspace(0, 1, 801)
    ref = np.full(len(P), np.inf)
    for i in range(len(x) - 1):
        tp, ap = sw.pose(np.full(len(T), i), T)
        ref = np.minimum(ref, cutter.signed_distance(P[:, None, :], tp[None], ap[None]).min(1))
    assert np.all(d <= ref + 1e-12)
    step = np.linalg.norm(tips[1] - tips[0]) / 800 * 2  # the dense sampling's resolution
    assert np.all(d >= ref - step)


# ----------------------------------------------------------------------------- fast sweep
def sphere_cutter_case(cutter, lead, tilt, push=0.0):
    """The convex sphere patch with latitude passes 3° apart, poses every 2° of azimuth (the
    axis turns by up to 2° per move), the axis led by ``lead`` along the feed and tilted by
    ``tilt`` to the side, the tip from the cutter touching the CC point, pushed ``push`` mm
    into the surface."""
    mesh, path = sphere_case(np.arange(57.0, 73.1, 3.0), dphi=2.0)
    curves = []
    for c in path.curves:
        n = c.normal
        f = np.gradient(c.cc, axis=0)
        f -= np.einsum("ij,ij->i", f, n)[:, None] * n
        f /= np.linalg.norm(f, axis=1)[:, None]
        k = np.cross(f, n)
        ax = np.cos(lead) * np.cos(tilt) * n + np.sin(lead) * f + np.cos(lead) * np.sin(tilt) * k
        ax /= np.linalg.norm(ax, axis=1)[:, None]
        tip = cutter.cl_points(c.cc, n, ax) - push * n
        curves.append(PassCurve(c.s, False, c.cc, n, tip, ax, c.face))
    return mesh, ToolPath(path.axis, path.cone1, path.cone2, cutter, 0.05, 0.05, curves)


@pytest.fixture(scope="module")
def sphere_bull():
    return sphere_cutter_case(Cutter.bull(3.0, 1.0), 0.17, 0.0, push=0.0)


@pytest.mark.parametrize("cutter, push", [(Cutter.bull(3.0, 1.0), 0.0), (Cutter.flat(2.5), 0.02),
                                          (Cutter.taper(2.0, np.radians(6)), 0.0)])
def test_fast_sweep_matches_the_exact_one_pointwise(cutter, push):
    """Points around turning moves (the axis turns 2° per move): the fast minimum over each
    move agrees with the exact method's to 1e-6 mm outside the cutter and is never above it
    by more than that (inside, where the distance has creases, it may find a lower value:
    it is a minimum); both are minima over poses, never above dense poses' values."""
    mesh, path = sphere_cutter_case(cutter, 0.17, 0.07, push=push)
    fast = SweptCutter.from_curves(cutter, path.curves)
    exact = SweptCutter.from_curves(cutter, path.curves, method="exact")
    rng = np.random.default_rng(5)
    P = mesh.V[rng.integers(0, mesh.n_vertices, 800)] + rng.normal(0, 0.3, (800, 3))
    df, sf = fast.nearest(P)
    de, _ = exact.nearest(P)
    outside = de > 1e-6
    assert outside.sum() > 300 and (~outside).sum() > 10  # both kinds are tested
    np.testing.assert_allclose(df[outside], de[outside], atol=1e-6)
    assert np.all(df <= de + 1e-6)
    # the reported segment holds the minimum: the exact search on it alone gives the value
    own = SweptCutter(cutter, fast.ta[sf], fast.aa[sf], fast.tb[sf], fast.ab[sf],
                      method="exact")
    v0 = cutter.signed_distance(P, own.ta, own.aa)
    v1 = cutter.signed_distance(P, own.tb, own.ab)
    d_own = own._segment_min(P, np.arange(len(P)), v0, v1)
    np.testing.assert_allclose(d_own[outside], df[outside], atol=1e-6)
    T = np.linspace(0, 1, 21)
    ref = np.full(len(P), np.inf)
    for s in range(len(fast.ta)):
        tp, ap = fast.pose(np.full(len(T), s), T)
        near = np.linalg.norm(P - tp[10], axis=1) < 8.0
        if np.any(near):
            ref[near] = np.minimum(ref[near], cutter.signed_distance(
                P[near][:, None, :], tp[None], ap[None]).min(1))
    assert np.all(df <= ref + 1e-12)


def test_verify_fast_and_exact_agree_on_a_turning_path(sphere_bull):
    """verify_path with the fast sweep against the exact one on the same bull-nose path:
    maxima and per-sample values agree to 1 µm (measured: ~1e-11 mm)."""
    mesh, path = sphere_bull
    fa = verify_path(mesh, path)
    ex = verify_path(mesh, path, method="exact")
    for k in ("max_material_left", "max_gouge", "max_cusp", "max_cusp_normal"):
        assert getattr(fa, k) == pytest.approx(getattr(ex, k), abs=1e-6), k
    assert fa.max_material_left > 0.01  # a real scallop is measured
    np.testing.assert_allclose(fa.sample_values, ex.sample_values, atol=1e-6)
    np.testing.assert_allclose(fa.pair_cusp, ex.pair_cusp, atol=1e-6)
    np.testing.assert_allclose(fa.pair_cusp_normal, ex.pair_cusp_normal, atol=1e-6)
    i = int(np.argmax(ex.sample_values))
    assert fa.sample_values[i] == pytest.approx(ex.sample_values[i], abs=1e-6)



@pytest.mark.parametrize("ball", [False, True])
def test_forest_answers_each_point_as_its_member(sphere_bull, ball):
    """A SweptForest of per-level sweeps (one member without passes) gives every point its
    own member's distance, segment and height along a direction, bit for bit, whichever
    members and points share its chunks (small chunks cut across the members; the fast
    joint pass for bull-nose members, member by member for balls)."""
    from blisk_cam.core.verify.forest import SweptForest
    from blisk_cam.core.verify.sweep import swept_cutter

    mesh, path = sphere_bull
    tool = Cutter.ball(3.0) if ball else path.tool
    groups = [path.curves[0::3], path.curves[1::3], [], path.curves[2::3]]
    members = [swept_cutter(tool, g) for g in groups]
    rng = np.random.default_rng(11)
    k = 1500
    P = mesh.V[rng.integers(0, mesh.n_vertices, k)] + rng.normal(0, 0.5, (k, 3))
    which = rng.integers(0, len(members), k)
    N = rng.normal(size=(k, 3))
    N /= np.linalg.norm(N, axis=1)[:, None]
    hmax = rng.uniform(0.05, 2.0, k)
    forest = SweptForest(members, chunk=97)
    assert forest.fast != ball
    d, seg = forest.nearest(P, which)
    h = forest.height_along(P, N, hmax, which)
    for j, m in enumerate(members):
        rows = which == j
        dj, sj = m.nearest(P[rows])
        np.testing.assert_array_equal(d[rows], dj)
        np.testing.assert_array_equal(seg[rows], sj)
        np.testing.assert_array_equal(h[rows], m.height_along(P[rows], N[rows], hmax[rows]))
    assert np.all(np.isinf(d[which == 2])) and np.all(seg[which == 2] == -1)
    assert np.isfinite(h).sum() > 50  # real hits are traced
    with pytest.raises(ValueError, match="members 0..3"):
        forest.nearest(P[:2], [0, 4])

def test_unknown_sweep_method_is_refused(sphere_bull):
    from blisk_cam.core.errors import ToleranceError

    mesh, path = sphere_bull
    with pytest.raises(ToleranceError, match="method"):
        verify_path(mesh, path, method="approximate")
    with pytest.raises(ToleranceError, match="method"):
        SweptCutter.from_curves(path.tool, path.curves, method="nope")
    with pytest.raises(ToleranceError, match="xtol"):
        SweptCutter.from_curves(path.tool, path.curves, xtol=0.0)


def test_unsweepable_moves_are_refused():
    from blisk_cam.core.verify.sweep import SweepError

    c = Cutter.bull(3.0, 1.0)
    tips = np.array([[0.0, 0, 0], [1.0, 0, 0]])
    up, down = np.array([[0.0, 0, 1]]), np.array([[0.0, 0, -1]])
    with pytest.raises(SweepError, match="180°"):
        SweptCutter(c, tips[:1], up, tips[1:], down)
    with pytest.raises(SweepError, match="non-finite"):
        SweptCutter(c, tips[:1], np.zeros((1, 3)), tips[1:], up)


class _Counter:
    """A cancel hook that counts its polls and says stop from poll ``stop_at`` on (None:
    never); thread-safe enough for pytest (the GIL makes the increment atomic enough for a
    count that is only compared after the run)."""

    def __init__(self, stop_at=None):
        self.calls, self.stop_at = 0, stop_at

    def __call__(self):
        self.calls += 1
        return self.stop_at is not None and self.calls >= self.stop_at


@pytest.mark.parametrize("workers", [1, 2])
def test_cancelled_verify_stops_early_and_returns_nothing(sphere_bull, workers):
    """The cancel hook is polled between the steps and before every chunk and per-level task;
    once it says stop, verify_path raises Cancelled at that poll (one thread: no further
    poll) and returns no report; an Event set beforehand stops it before any work."""
    import threading

    from blisk_cam.core.runtime import Cancelled

    mesh, path = sphere_bull
    full = _Counter()
    ref = verify_path(mesh, path, workers=workers, cancel=full)
    assert full.calls > 20  # polled all along the run
    stop = _Counter(stop_at=full.calls // 3)
    out = None
    with pytest.raises(Cancelled, match="cancelled by the caller"):
        out = verify_path(mesh, path, workers=workers, cancel=stop)
    assert out is None  # no partial report
    if workers == 1:
        assert stop.calls == full.calls // 3  # it stopped at the poll that said stop
    else:  # the other thread may poll once more before the pool ends
        assert stop.calls <= full.calls // 3 + workers
    ev = threading.Event()
    ev.set()
    with pytest.raises(Cancelled):
        verify_path(mesh, path, workers=workers, cancel=ev)
    # an unset hook changes nothing
    again = verify_path(mesh, path, workers=workers, cancel=threading.Event())
    assert again.summary() | {"timings": 0} == ref.summary() | {"timings": 0}
    np.testing.assert_array_equal(again.sample_values, ref.sample_values)


def test_cancel_hook_of_the_wrong_type_is_refused(sphere_bull):
    mesh, path = sphere_bull
    with pytest.raises(TypeError, match="threading.Event or a callable"):
        verify_path(mesh, path, cancel=3)


def test_material_left_is_handed_over_before_the_scallops(sphere_bull):
    """``on_material_left`` gets, once and before the scallops step starts, the per-vertex
    material left the report then holds (a front end's early colour map is the final one)."""
    mesh, path = sphere_bull
    events = []
    rep = verify_path(mesh, path, progress=lambda p: events.append(p.message),
                      on_material_left=lambda v: events.append(np.array(v)))
    got = [e for e in events if isinstance(e, np.ndarray)]
    assert len(got) == 1
    steps = [e if isinstance(e, str) else "values" for e in events]
    assert steps.index("material") < steps.index("values") < steps.index("scallops")
    np.testing.assert_array_equal(got[0], rep.vertex_values)
    assert np.isfinite(got[0]).any() and np.isnan(got[0]).any()  # inside and outside
