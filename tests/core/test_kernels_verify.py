"""Verify's compiled kernels (the swept ball's nearest centre segments, the swept cutter's
golden-section search) against the numpy reference on the same inputs: the swept ball's
distances bit for bit, the swept cutter's within 1e-9 mm, and whole verify reports with the
same figures and verdict on both backends."""

from __future__ import annotations

import numpy as np
import pytest

from blisk_cam.core.geometry.axis import Axis
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.kernels import backend
from blisk_cam.core.part.cones import Cone
from blisk_cam.core.runtime import parallel
from blisk_cam.core.tool.cutter import Cutter
from blisk_cam.core.toolpath.types import PassCurve, ToolPath
from blisk_cam.core.verify.measure import verify_path
from blisk_cam.core.verify.sweep import SweptCutter
from blisk_cam.core.verify.sweep_ball import SweptBall
from tests.support.kernels import needs_compiled

compiled = needs_compiled("golden_pairs")


def _helices(n_pass=12, n=300, seed=0):
    """Centre polylines: wavy helical turns 2 mm apart (mm), and points around them."""
    rng = np.random.default_rng(seed)
    a, b, own = [], [], []
    for i in range(n_pass):
        t = np.linspace(0.0, 5.0, n)
        c = np.stack([30 * np.cos(t), 30 * np.sin(t), 2.0 * i + 0.2 * np.sin(7 * t)], 1)
        a.append(c[:-1])
        b.append(c[1:])
        own.append(np.full(n - 1, i))
    a, b, own = np.vstack(a), np.vstack(b), np.concatenate(own)
    P = np.vstack([a[rng.integers(0, len(a), 3000)] + rng.normal(scale=3.0, size=(3000, 3)),
                   a[::7], b[::11]])  # on the polylines: ties between neighbouring segments
    return a, b, own, P


@compiled
def test_swept_ball_distances_identical_on_both_backends():
    a, b, own, P = _helices()
    up = np.tile([0.0, 0.0, 1.0], (len(P), 1))
    with backend.numpy_only():
        ball = SweptBall(a, b, 3.0, own)
        d_ref, s_ref = ball.nearest(P)
        h_ref = ball.height_along(P, up, 4.0)
        n_ref = ball.near(P, 0.5).distance(P + 0.2)
    for threads in (1, 2):
        with parallel(threads):
            ball = SweptBall(a, b, 3.0, own)
            d, s = ball.nearest(P)
            np.testing.assert_array_equal(d, d_ref)
            # a point equally near two segments may name either; both are that near
            np.testing.assert_array_equal(own[s], own[s_ref])
            e = P - (a[s] + np.clip(np.einsum("ij,ij->i", P - a[s], b[s] - a[s])
                                    / np.einsum("ij,ij->i", b[s] - a[s], b[s] - a[s]),
                                    0, 1)[:, None] * (b[s] - a[s]))
            np.testing.assert_allclose(np.linalg.norm(e, axis=1) - 3.0, d, atol=1e-12)
            np.testing.assert_array_equal(ball.height_along(P, up, 4.0), h_ref)
            np.testing.assert_array_equal(ball.near(P, 0.5).distance(P + 0.2), n_ref)
    assert np.isfinite(h_ref).any() and np.isinf(h_ref).any()


@compiled
def test_swept_ball_grouped_queries_identical_on_both_backends():
    """Points in grid order 3 mm off the helices (neighbours consecutive, as verify's samples
    come: the compiled kernel searches them by groups sharing one tree walk), a row exactly
    between two passes: the distances and segments are numpy's."""
    a, b, own, _ = _helices()
    t = np.linspace(0.0, 5.0, 400)
    z = np.linspace(-1.0, 23.0, 97)  # every 0.25 mm: rows at z = 2i + 1 sit between passes
    T, Z = np.meshgrid(t, z, indexing="ij")
    P = np.stack([33 * np.cos(T), 33 * np.sin(T), Z], -1).reshape(-1, 3)
    with backend.numpy_only():
        d_ref, s_ref = SweptBall(a, b, 3.0, own).nearest(P)
    for threads in (1, 2):
        with parallel(threads):
            d, s = SweptBall(a, b, 3.0, own).nearest(P)
        np.testing.assert_array_equal(d, d_ref)
        # a point equally near two segments (their shared end) may name either: the same pass
        np.testing.assert_array_equal(own[s], own[s_ref])
        assert np.mean(s == s_ref) > 0.9



@compiled
def test_swept_ball_group_list_stops_only_beyond_reach():
    """The grouped search walks its candidate leaves by their capsules' distance from the
    group's centre c and stops where that, less |p - c|, is beyond the point's reach. The
    bound is tight for a point on the line from c to a straight pass: groups of points near
    one pass with one point among them on that line, nearly midway to a second pass and
    nearer to it (by 0.2 % to 2.8 %) — its segment comes from the second pass, as numpy's."""
    from blisk_cam.core.verify.forest import SweptForest

    x = np.linspace(0.0, 60.0, 121)  # two straight passes 10 mm apart, 0.5 mm moves
    a = np.vstack([np.stack([x[:-1], 0 * x[:-1], 0 * x[:-1]], 1),
                   np.stack([x[:-1], 0 * x[:-1], 10.0 + 0 * x[:-1]], 1)])
    b = np.vstack([np.stack([x[1:], 0 * x[1:], 0 * x[1:]], 1),
                   np.stack([x[1:], 0 * x[1:], 10.0 + 0 * x[1:]], 1)])
    own = np.repeat([0, 1], 120)
    groups = []
    for x0, eps in zip(np.linspace(3.0, 57.0, 24), np.linspace(0.005, 0.07, 24),
                       strict=True):
        g = np.stack([x0 + np.linspace(-0.3, 0.3, 32), np.zeros(32), np.full(32, 0.2)], 1)
        g[16] = [x0, 0.0, 5.0 + eps]  # on the line from the group's centre to pass 1
        groups.append(g)
    P = np.vstack(groups)  # 32 points a group, as a forest's query groups them
    with backend.numpy_only():
        d_ref, s_ref = SweptBall(a, b, 3.0, own).nearest(P)
    assert np.all(own[s_ref[16::32]] == 1)  # the midway points are nearer to pass 1
    for threads in (1, 2):
        with parallel(threads):
            # (a whole ball's query groups the points in its own space-filling order)
            d, s = SweptBall(a, b, 3.0, own).nearest(P)
            df, sf = SweptForest([SweptBall(a, b, 3.0, own)]).nearest(P, np.zeros(len(P)))
        np.testing.assert_array_equal(d, d_ref)
        np.testing.assert_array_equal(own[s], own[s_ref])
        np.testing.assert_array_equal(df, d_ref)
        np.testing.assert_array_equal(own[sf], own[s_ref])



@compiled
def test_swept_ball_grouped_first_hits_stop_only_beyond_reach():
    """The grouped first hits walk the candidate leaves by their capsules' distance from the
    group's centre c and stop where that, less |o - c|, is beyond the point's reach (ball
    radius + max height). The bound is tight for a point on the line from c to a straight
    pass, shooting along it: groups of points inside one pass's capsule, with one point
    among them below a second pass whose capsule it reaches just within its max height
    (by 0.2 % to 2.8 % of its reach) — its hit is numpy's, and so are the others' (none)."""
    from blisk_cam.core.verify.forest import SweptForest

    x = np.linspace(0.0, 60.0, 121)  # two straight passes 10 mm apart, 0.5 mm moves
    a = np.vstack([np.stack([x[:-1], 0 * x[:-1], 0 * x[:-1]], 1),
                   np.stack([x[:-1], 0 * x[:-1], 10.0 + 0 * x[:-1]], 1)])
    b = np.vstack([np.stack([x[1:], 0 * x[1:], 0 * x[1:]], 1),
                   np.stack([x[1:], 0 * x[1:], 10.0 + 0 * x[1:]], 1)])
    groups, hmax = [], []
    for x0, slack in zip(np.linspace(3.0, 57.0, 24), np.linspace(0.002, 0.028, 24),
                         strict=True):
        g = np.stack([x0 + np.linspace(-0.3, 0.3, 32), np.zeros(32), np.full(32, 0.5)], 1)
        g[16] = [x0, 0.0, 10.0 - 7.0 * (1.0 - slack)]  # 7 mm reach: radius 3 + height 4
        groups.append(g)
        hmax.append(np.full(32, 4.0))
    P, hmax = np.vstack(groups), np.concatenate(hmax)  # 32 points a group, as grouped
    up = np.tile([0.0, 0.0, 1.0], (len(P), 1))
    which = np.zeros(len(P), dtype=np.int64)

    def members():
        return [SweptBall(a, b, 3.0), SweptBall(a[:4], b[:4], 3.0)]

    with backend.numpy_only():
        h_ref = SweptForest(members()).height_along(P, up, hmax, which)
    assert np.isfinite(h_ref[16::32]).all() and np.isinf(np.delete(h_ref, np.s_[16::32])).all()
    for threads in (1, 2):
        with parallel(threads):
            h = SweptForest(members()).height_along(P, up, hmax, which)
        np.testing.assert_array_equal(h, h_ref)


def _turning_moves(seed=1):
    """Bull-nose poses along helical passes whose axis leans and turns along the pass."""
    rng = np.random.default_rng(seed)
    tips, axes = [], []
    for i in range(6):
        t = np.linspace(0.0, 2.0, 120)
        tips.append(np.stack([40 * np.cos(t), 40 * np.sin(t), 3.0 * i + 0.3 * np.sin(3 * t)],
                             1))
        ax = np.stack([np.cos(t), np.sin(t), 0.3 + 0.2 * np.sin(2 * t + i)], 1)
        axes.append(ax / np.linalg.norm(ax, axis=1)[:, None])
    ta = np.vstack([x[:-1] for x in tips])
    tb = np.vstack([x[1:] for x in tips])
    aa = np.vstack([x[:-1] for x in axes])
    ab = np.vstack([x[1:] for x in axes])
    own = np.repeat(np.arange(6), 119)
    k = rng.integers(0, len(ta), 2500)
    P = ta[k] + rng.normal(scale=4.0, size=(2500, 3)) - 2.0 * aa[k]
    return ta, aa, tb, ab, own, P


@compiled
def test_swept_bull_nose_distances_within_1e9_on_both_backends():
    ta, aa, tb, ab, own, P = _turning_moves()
    cut = Cutter.bull(6.0, 2.0)
    with backend.numpy_only():
        d_ref, s_ref = SweptCutter(cut, ta, aa, tb, ab, own).nearest(P)
    for threads in (1, 2):
        with parallel(threads):
            d, s = SweptCutter(cut, ta, aa, tb, ab, own).nearest(P)
        np.testing.assert_allclose(d, d_ref, rtol=0, atol=1e-9)
        assert np.mean(s == s_ref) > 0.99
        assert np.array_equal(np.sign(d), np.sign(d_ref))
    assert (d_ref < 0).any() and (d_ref > 0).any()  # points inside and outside the volume


@compiled
def test_swept_forest_compiled_per_member_trees_and_ring_bound():
    """A forest of members (a pass pair each, overlapping in space): each point's distance
    to its member on the compiled backend is the member's own query's bit for bit (the
    compiled candidates walk the member's tree only, the first bound comes from the compiled
    k-d tree of ring points) and within 1e-9 mm of the numpy forest's."""
    from blisk_cam.core.verify.forest import SweptForest

    ta, aa, tb, ab, own, P = _turning_moves(seed=2)
    cut = Cutter.bull(6.0, 2.0)

    def members():
        return [SweptCutter(cut, ta[m], aa[m], tb[m], ab[m], own[m])
                for m in (own // 2 == g for g in range(3))]

    which = np.random.default_rng(3).integers(0, 3, len(P))
    with backend.numpy_only():
        d_ref, _ = SweptForest(members()).nearest(P, which)
    ms = members()
    d, _ = SweptForest(ms).nearest(P, which)
    own_d = np.empty(len(P))
    for g, m in enumerate(ms):
        own_d[which == g] = m.nearest(P[which == g])[0]
    np.testing.assert_array_equal(d, own_d)
    np.testing.assert_allclose(d, d_ref, rtol=0, atol=1e-9)
    assert (d_ref < 0).any() and (d_ref > 0).any()


def _plane_case(cutter, lead_deg, tilt_deg, xs=(104.0, 110.0, 116.0, 122.0), push=0.0):
    """The half-plane y = 0 (normal +y) between the cylinders r = 100 and r = 130 about z,
    and straight passes x = xs along +z of ``cutter``, leaning ``lead`` toward the feed and
    ``tilt`` to the side (degrees); ``push`` mm into the surface."""
    nx, nz = 41, 31
    x, z = np.linspace(95.0, 135.0, nx), np.linspace(0.0, 30.0, nz)
    X, Z = np.meshgrid(x, z, indexing="ij")
    V = np.stack([X.ravel(), np.zeros(X.size), Z.ravel()], 1)
    i = np.arange(nx * nz).reshape(nx, nz)
    a, b, c, d = i[:-1, :-1], i[1:, :-1], i[1:, 1:], i[:-1, 1:]
    F = np.vstack([np.stack([a, d, b], -1).reshape(-1, 3), np.stack([b, d, c], -1).reshape(-1, 3)])
    mesh = TriMesh.from_arrays(V, F)
    assert mesh.face_normals[:, 1].min() > 0.99  # normals +y, out of the material
    lead, tilt = np.radians(lead_deg), np.radians(tilt_deg)
    ax = np.array([-np.sin(tilt) * np.cos(lead), np.cos(lead) * np.cos(tilt), np.sin(lead)])
    ax /= np.linalg.norm(ax)
    curves = []
    for xi in xs:
        zz = np.linspace(-12.0, 42.0, 28)
        cc = np.stack([np.full_like(zz, xi), np.zeros_like(zz), zz], 1)
        nrm = np.tile([0.0, 1.0, 0.0], (len(zz), 1))
        axs = np.tile(ax, (len(zz), 1))
        tip = cutter.cl_points(cc, nrm, axs) - push * nrm
        curves.append(PassCurve((xi - 100.0) / 30.0, False, cc, nrm, tip, axs,
                                np.full(len(zz), -1)))
    return mesh, ToolPath(Axis(), Cone(100.0, 0, 100.0, 30), Cone(130.0, 0, 130.0, 30), cutter,
                          0.05, 0.05, curves)


def _figures(rep):
    s = rep.summary()
    s.pop("timings")
    return s


@compiled
@pytest.mark.parametrize("tool", ["ball", "bull"])
def test_verify_reports_agree_on_both_backends(tool):
    cutter = Cutter.ball(6.0) if tool == "ball" else Cutter.bull(6.0, 2.0)
    mesh, path = _plane_case(cutter, 0.0 if tool == "ball" else 10.0,
                             0.0 if tool == "ball" else 5.0, push=0.02)
    with backend.numpy_only():
        ref = verify_path(mesh, path, workers=1)
    got = verify_path(mesh, path, workers=2)
    assert ref.max_gouge > 0.01  # the push is measured: the check can fail
    a, b = _figures(ref), _figures(got)
    assert a.keys() == b.keys()
    for k in a:
        x, y = a[k], b[k]
        if isinstance(x, float) and isinstance(y, float):
            assert x == pytest.approx(y, abs=1e-9, nan_ok=True), k
        elif isinstance(x, (list, tuple)) and x and isinstance(x[0], float):
            np.testing.assert_allclose(x, y, rtol=0, atol=1e-9, err_msg=k)
        else:
            assert x == y, k
    if tool == "ball":  # the same arithmetic: the very floats
        assert a == b


@pytest.mark.skipif(backend.extension() is None
                    or not hasattr(backend.extension(), "pose_bound"),
                    reason="the compiled kernels are not installed or predate pose_bound")
def test_swept_cutter_pose_bound_is_numpys_bit_for_bit():
    """The first bound of the fast method (each point against the poses of the segments of
    its nearest ring points: value and segment) is the same on both backends, bit for bit,
    with points inside and outside the cutters, a NaN point, and ties (a segment listed
    twice: the last listed is named)."""
    from blisk_cam.core.geometry.bvh import group_argmin
    from blisk_cam.core.kernels import swept_cutter as compiled_cutter

    ta, aa, tb, ab, own, P = _turning_moves(seed=5)
    P = np.vstack([P[:800], [[np.nan, 0.0, 0.0]]])
    cut = Cutter.bull(6.0, 2.0)
    rng = np.random.default_rng(7)
    seg = rng.integers(-len(ta), len(ta), (len(P), 4))
    seg[:50, 3] = seg[:50, 1]  # ties
    u, arg = compiled_cutter.pose_bound(cut, P, seg, ta, aa, 2)
    qi = np.repeat(np.arange(len(P)), 4)
    j = seg.reshape(-1)
    with np.errstate(invalid="ignore"):  # the NaN point
        d = cut.signed_distance(P[qi], ta[j], aa[j])
        u_ref, arg_ref = group_argmin(len(P), qi, d, j)
    np.testing.assert_array_equal(u, u_ref)
    np.testing.assert_array_equal(arg, arg_ref)
    assert (u < 0).any() and (u > 0).any() and np.isnan(u[-1]) and arg[-1] == -1


@compiled
def test_nearest_closest_points_are_numpys_bit_for_bit():
    """The compiled faces' closest points (MeshDistance.query with the compiled kernels): the
    point, squared distance, feature and barycentric coordinates of closest_on_triangles on
    each point's face, bit for bit — on a strip of needle faces, a sliver and a zero-area
    face, at points on, around, far off and exactly at the vertices, and at a NaN point."""
    from blisk_cam.core.geometry.closest import closest_on_triangles
    from blisk_cam.core.kernels.closest import face_tree, nearest_closest, nearest_faces

    rng = np.random.default_rng(5)
    x = np.linspace(0.0, 2.0, 41)
    top = np.stack([x, np.full_like(x, 4.0), 0.3 * np.sin(3 * x)], 1)
    bot = np.stack([x, np.zeros_like(x), -0.2 * np.cos(2 * x)], 1)
    V = np.vstack([bot, top, [[1.0, 2.0, 0.1], [1.0 + 1e-9, 2.0, 0.1], [1.0, 2.0, 0.1]]])
    n = len(x)
    i = np.arange(n - 1)
    F = np.vstack([np.stack([i, i + 1, n + i], 1), np.stack([i + 1, n + i + 1, n + i], 1),
                   [[2 * n, 2 * n + 1, 2 * n + 2]]])
    P = np.vstack([rng.uniform([-0.5, -1.0, -1.0], [2.5, 5.0, 1.0], (3000, 3)),
                   rng.uniform([-0.5, -1.0, 5.0], [2.5, 5.0, 7.0], (500, 3)),
                   V, [[np.nan, 0.0, 0.0]]])
    for disks in (False, True):
        tree = face_tree(V, F, disks)
        face, q, d2, feat, bary = nearest_closest(tree, P, 2)
        np.testing.assert_array_equal(face, nearest_faces(tree, P, 1))
        ref = closest_on_triangles(P, V[F[face, 0]], V[F[face, 1]], V[F[face, 2]])
        for got, want in zip((q, d2, feat, bary), ref, strict=True):
            np.testing.assert_array_equal(got, want)
            assert got.dtype == want.dtype
    assert set(np.unique(feat)) >= {0, 1, 2, 3} and face[-1] == -1


@compiled
def test_swept_ball_forest_in_one_call_identical_on_both_backends():
    """A forest of swept balls (one per pass, one without segments) asked in one compiled
    call: each point's distance, segment and height along a direction are those of its
    member alone on the numpy backend, on 1 and 2 threads."""
    from blisk_cam.core.verify.forest import SweptForest

    a, b, own, P = _helices(n_pass=5, n=120)
    rng = np.random.default_rng(7)
    which = rng.integers(0, 6, len(P))  # member 5 has no segments
    up = np.tile([0.0, 0.0, 1.0], (len(P), 1))

    def members():
        z = np.zeros((0, 3))
        return [SweptBall(a[own == i], b[own == i], 3.0) for i in range(5)] + [
            SweptBall(z, z, 3.0)]

    with backend.numpy_only():
        ref = SweptForest(members())
        assert not ref.balls
        d_ref, s_ref = ref.nearest(P, which)
        h_ref = ref.height_along(P, up, 4.0, which)
    for threads in (1, 2):
        with parallel(threads):
            got = SweptForest(members())
            assert got.balls
            d, s = got.nearest(P, which)
            h = got.height_along(P, up, 4.0, which)
        np.testing.assert_array_equal(d, d_ref)
        np.testing.assert_array_equal(h, h_ref)
        # a point equally near two segments (their shared end) may name either
        same = s == s_ref
        assert same.mean() > 0.9 and np.all(s[which == 5] == -1)
    assert np.isinf(d_ref[which == 5]).all() and np.isfinite(h_ref).any()


@compiled
def test_nearest_faces_far_off_a_curved_sheet_are_numpys():
    """The faces' bounds that let a far point skip faces (disk, prism over the face, capsule)
    drop only faces farther than the nearest: points 6 mm off a wavy sheet (ball centres, on
    both sides: convex and concave under them), straight above its vertices and the middles
    of its edges (exact ties between the faces around them, whose prism bound is then their
    exact distance) and a little aside, give numpy's faces (the least distance, then the
    lowest id) on 1 and 2 threads."""
    from blisk_cam.core.geometry.distance import NearestFaces

    u, v = np.meshgrid(np.linspace(0.0, 20.0, 31), np.linspace(0.0, 12.0, 19), indexing="ij")
    V = np.stack([u, v, 2.0 * np.sin(0.3 * u) * np.cos(0.4 * v)], -1).reshape(-1, 3)
    k = np.arange(31 * 19).reshape(31, 19)[:-1, :-1].ravel()
    F = np.vstack([np.stack([k, k + 19, k + 1], 1), np.stack([k + 1, k + 19, k + 20], 1)])
    mesh = TriMesh.from_arrays(V, F)
    rng = np.random.default_rng(7)
    e = mesh.edges  # (E, 2) vertex ids
    mid = 0.5 * (V[e[:, 0]] + V[e[:, 1]])
    nm = mesh.vertex_normals[e[:, 0]] + mesh.vertex_normals[e[:, 1]]
    nm /= np.linalg.norm(nm, axis=1)[:, None]
    P = np.vstack([V + 6.0 * mesh.vertex_normals, V - 6.0 * mesh.vertex_normals,
                   mid + 6.0 * nm, mid - 6.0 * nm,
                   mid + 6.0 * nm + rng.normal(scale=0.05, size=mid.shape)])
    with backend.numpy_only():
        ref = NearestFaces(mesh).query(P)
    for threads in (1, 2):
        with parallel(threads):
            got = NearestFaces(mesh, disks=True).query(P)
        for g, r in zip(got, ref, strict=True):
            np.testing.assert_array_equal(g, r)


@compiled
def test_swept_ball_ridge_steps_are_numpys_regula_falsi():
    """The compiled regula falsi of the scallop ridges (every step of every edge in one call:
    the first iterate searched by groups, the later ones against the segments listed near
    it, a full search where those cannot decide) gives numpy's iterates and distances bit
    for bit, on 1 and 2 threads. Levels: straight passes 0.5 mm apart (0.25 mm moves);
    edges from about one pass to past the next, 1 to 3 mm along them and 0.02 to 0.3 mm
    off their plane (sharply bent distances): some later iterates move far from the first,
    where its listed segments no longer hold the nearest."""
    from blisk_cam.core.verify.forest import SweptForest, regula_falsi

    x = np.linspace(0.0, 20.0, 81)
    passes = [(np.stack([x[:-1], 0 * x[:-1], 0 * x[:-1] + 0.5 * i], 1),
               np.stack([x[1:], 0 * x[1:], 0 * x[1:] + 0.5 * i], 1)) for i in range(5)]
    rng = np.random.default_rng(3)
    k = 4000
    lo = rng.integers(0, 4, k)
    h = rng.uniform(0.02, 0.3, k)
    xa = np.stack([rng.uniform(2.0, 15.0, k), h, 0.5 * lo + rng.uniform(-0.2, 0.15, k)], 1)
    xb = xa + np.stack([rng.uniform(1.0, 3.0, k), rng.normal(0, 0.01, k),
                        rng.uniform(0.5, 1.0, k)], 1)

    def members():
        return [SweptBall(pa, pb, 3.0) for pa, pb in passes]

    def ends(forest, p):
        return forest.distance(p, lo) - forest.distance(p, lo + 1)

    with backend.numpy_only():
        ref = SweptForest(members())
        ga, gb = ends(ref, xa), ends(ref, xb)
        ok = np.sign(ga) * np.sign(gb) < 0  # the ridge between the two passes is crossed
        xa, xb, ga, gb, lo = xa[ok], xb[ok], ga[ok], gb[ok], lo[ok]
        assert ref.ridge_steps(xa, xb, ga, gb, lo, 3) is None  # numpy: the caller steps
        x_ref, la_ref, lb_ref = regula_falsi(
            xa, xb, ga, gb, 3, lambda p, i: (ref.distance(p, lo), ref.distance(p, lo + 1)))
    assert len(xa) > 1000
    # some later iterates move beyond a tenth of the edge from the first (the listed margin)
    x1 = xa + (ga / (ga - gb))[:, None] * (xb - xa)
    move = np.linalg.norm(x_ref - x1, axis=1) / np.linalg.norm(xb - xa, axis=1)
    assert move.max() > 0.15 and np.mean(move > 0.1) > 0.002
    for threads in (1, 2):
        with parallel(threads):
            got = SweptForest(members())
            assert got.balls
            x, la, lb = got.ridge_steps(xa, xb, ga, gb, lo, 3)
        np.testing.assert_array_equal(x, x_ref)
        np.testing.assert_array_equal(la, la_ref)
        np.testing.assert_array_equal(lb, lb_ref)
