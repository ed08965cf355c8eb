"""The compiled distance to ball-centre polylines (``expansion.PolylineDistance``, the scallop
measurement of the passes stage, issue 21) against the numpy reference on the same inputs:
the same floats bit for bit, rows with a tie at the k-th nearest sample handed to scipy; the
column neighbours of ``measure_cusp`` are scipy's.

Tests comparing the two backends skip (saying why) when the extension is not built."""

from __future__ import annotations

import contextlib

import numpy as np
from scipy.spatial import cKDTree

from blisk_cam.core.kernels import backend
from blisk_cam.core.kernels import knn as compiled_knn
from blisk_cam.core.kernels import polyline as compiled_polyline
from blisk_cam.core.paths.expansion import PolylineDistance, _nearest_index, measure_cusp
from tests.support.kernels import needs_compiled

compiled = needs_compiled("polyline_distance", "PointTree")


def _polylines(rng):
    """A wavy open polyline, a closed loop and a lattice polyline (integer corners: samples
    and hints at equal distances, the ties of the k-th nearest)."""
    t = np.linspace(0.0, 6.0, 90)
    wavy = np.stack([10 * t, 3 * np.sin(t), 0.5 * np.cos(3 * t)], 1) + rng.normal(0, 1e-3, (90, 3))
    a = np.linspace(0, 2 * np.pi, 60, endpoint=False)
    loop = np.stack([20 + 8 * np.cos(a), 5 * np.sin(a), np.full(60, 4.0)], 1)
    lattice = np.array([[0, 10, 0], [4, 10, 0], [4, 14, 0], [0, 14, 0], [0, 10, 4]], float)
    return [(wavy, False), (loop, True), (lattice, False), (wavy[:1], False)]


def _queries(rng):
    p = np.concatenate([
        rng.uniform([-5, -8, -3], [65, 8, 8], (3000, 3)),
        np.stack(np.meshgrid(np.arange(-1, 6), np.arange(9, 16), np.arange(-1, 3)), -1)
        .reshape(-1, 3).astype(float) * np.array([1.0, 1.0, 1.0]),
    ])
    hint = p + rng.normal(0, 0.5, p.shape)
    hint[3000:] = p[3000:] + np.array([0.5, 0.0, 0.0])  # lattice hints: exact ties
    return p, hint


@compiled
def test_polyline_distance_compiled_equals_numpy_bit_for_bit():
    rng = np.random.default_rng(7)
    polys = _polylines(rng)
    p, hint = _queries(rng)
    for resample, k in ((0.25, 6), (1.0, 6), (0.5, 3)):
        dist = PolylineDistance(polys, resample=resample, k=k)
        got = dist._distance(p, hint)
        ref = dist._distance_numpy(p, hint)
        assert np.array_equal(got, ref), (resample, k)
        # the kernel itself: the tied rows are flagged (and only they hold NaN)
        tree = compiled_knn.point_tree(dist.samples)
        d, rest = compiled_polyline.polyline_distance(
            tree, p, hint, dist.k, dist.seg_of_sample, dist.a, dist.ab, dist.L2, 2)
        assert np.array_equal(d[~rest], ref[~rest]) and np.all(np.isnan(d[rest]))
        assert 0 < np.count_nonzero(rest) < len(p) // 4
        # an independent check of the reference: brute force over every segment is never
        # farther than the candidates' least distance, and equal where the nearest is found
        ap = p[:, None, :] - dist.a[None]
        tt = np.clip(np.einsum("qsj,sj->qs", ap, dist.ab) / dist.L2, 0, 1)
        brute = np.linalg.norm(ap - tt[..., None] * dist.ab, axis=2).min(axis=1)
        assert np.all(brute <= ref + 1e-12)
        assert np.mean(np.abs(brute - ref) < 1e-9) > 0.5  # noisy hints miss some
    with backend.numpy_only():
        assert np.array_equal(PolylineDistance(polys)(p, near=hint),
                              PolylineDistance(polys)._distance_numpy(p, hint))


@compiled
def test_column_neighbours_are_scipys():
    rng = np.random.default_rng(3)
    pts = np.concatenate([rng.normal(0, 5, (500, 3)), np.round(rng.normal(0, 3, (200, 3)))])
    q = np.concatenate([rng.normal(0, 5, (400, 3)), np.round(rng.normal(0, 3, (300, 3))) + 0.5])
    got = _nearest_index(pts, q)
    ref = cKDTree(pts).query(q)[1]
    assert np.array_equal(got, ref)
    with backend.numpy_only():
        assert np.array_equal(_nearest_index(pts, q), ref)


@compiled
def test_tree_off_a_tilted_patch_is_scipys():
    """Queries a ball radius off a dense, oblique, slightly curved patch (the lift's and the
    scallop's case, where every box near the contact is about as near as the points) get
    scipy's k nearest within the bound, by (distance, id), and its answer of 'any within'."""
    rng = np.random.default_rng(9)
    uv = rng.uniform(-3, 3, (40000, 2))
    n = np.array([1.0, 2.0, 2.0]) / 3.0
    t = np.cross(n, [0.0, 0.0, 1.0])
    t /= np.linalg.norm(t)
    b = np.cross(n, t)
    pts = 100.0 + uv[:, :1] * t + uv[:, 1:] * b + (0.02 * (uv ** 2).sum(1))[:, None] * n
    pts = np.concatenate([pts, pts[:50]])  # repeated points: ties by id
    q = 100.0 + rng.uniform(-2, 2, (500, 1)) * t + rng.uniform(-2, 2, (500, 1)) * b + 6.0 * n
    tree = compiled_knn.point_tree(pts)
    got = compiled_knn.nearest_k(tree, q, 8, 6.05, 1)
    d, i = cKDTree(pts).query(q, k=64, distance_upper_bound=6.05)
    valid = np.isfinite(d)
    diff = pts[np.where(valid, i, 0)] - q[:, None, :]
    d2 = np.where(valid, (diff[..., 0] ** 2 + diff[..., 1] ** 2) + diff[..., 2] ** 2, np.inf)
    order = np.lexsort((np.where(valid, i, len(pts)), d2), axis=1)[:, :8]
    ref = np.where(np.take_along_axis(valid, order, 1), np.take_along_axis(i, order, 1), -1)
    assert np.array_equal(got, ref) and np.count_nonzero(got >= 0) > 1000
    within = compiled_knn.points_within(tree, q, 6.0, 1)
    assert np.array_equal(within, np.isfinite(cKDTree(pts).query(q, distance_upper_bound=6.0)[0]))
    assert 0 < np.count_nonzero(within) < len(q)


def _brute_knn(pts, q, k, bound):
    """(q, k) ids of the k nearest points below ``bound`` by (squared distance summed as the
    kernel sums it, id), −1 where fewer; (q,) whether the k-th and (k + 1)-th tie."""
    diff = pts[None, :, :] - q[:, None, :]
    d2 = (diff[..., 0] ** 2 + diff[..., 1] ** 2) + diff[..., 2] ** 2
    d2 = np.where(d2 < bound * bound, d2, np.inf)
    order = np.lexsort((np.broadcast_to(np.arange(len(pts)), d2.shape), d2), axis=1)
    ids = np.where(np.isfinite(np.take_along_axis(d2, order, 1)), order, -1)
    dk = np.take_along_axis(d2, order[:, k - 1 : k + 1], 1)
    return ids[:, :k], np.isfinite(dk[:, 1]) & (dk[:, 0] == dk[:, 1])


@compiled
def test_tree_queries_along_a_path_seeded_by_the_one_before():
    """Queries along a path (each seeded by the answer of the one before it) get the k
    nearest by (distance, id) of the brute force, the same as asked one by one in any
    order; on a grid with repeated points (ties everywhere) and with a bound that leaves
    some queries fewer than k points."""
    g = np.stack(np.meshgrid(np.arange(12.0), np.arange(12.0), np.arange(4.0),
                             indexing="ij"), -1).reshape(-1, 3)
    pts = np.concatenate([g, g[::7]])  # repeated points: ties by id
    s = np.linspace(0.0, 1.0, 300)[:, None]
    q = np.concatenate([(1 - s) * [0.3, 0.2, 1.5] + s * [10.7, 11.1, 2.0],  # a path
                        [[5.5, 5.5, 1.5], [5.0, 5.0, 1.0], [30.0, 30.0, 30.0]]])
    tree = compiled_knn.point_tree(pts)
    for bound in (np.inf, 1.2):
        ids, tie = tree.query(q, 4, bound, 1)
        ref, ref_tie = _brute_knn(pts, q, 4, bound)
        assert np.array_equal(ids, ref) and np.array_equal(tie, ref_tie)
        assert tie.any() and (ids >= 0).any()
        rev = tree.query(q[::-1].copy(), 4, bound, 2)[0][::-1]  # other seeds, two threads
        assert np.array_equal(rev, ref)
    assert (tree.query(q, 4, 1.2, 1)[0] == -1).any()  # some with fewer than k within


def test_many_levels_in_one_call_as_level_by_level():
    """``PolylineDistance.many`` (the levels of a trial in one kernel call) gives each level
    the floats of its own call, on both backends, with or without hints; a level memoised
    by an earlier call is answered from the memo (not measured again), and a level whose
    array changed in place is measured anew."""
    rng = np.random.default_rng(11)
    polys = _polylines(rng)
    p, hint = _queries(rng)
    levels = [p[:700], p[700:701], p[701:2000].copy(), p[2000:]]
    nears = [hint[:700], None, hint[701:2000], hint[2000:]]
    kernels = [backend.numpy_only()]
    if compiled_polyline.available():
        kernels.append(contextlib.nullcontext())
    for ctx in kernels:
        with ctx:
            ref = [PolylineDistance(polys)(q) if h is None else PolylineDistance(polys)(q, near=h)
                   for q, h in zip(levels, nears, strict=True)]
            dist = PolylineDistance(polys)
            first = dist(levels[2], near=nears[2])  # memoised
            calls = []
            measure = dist._distance
            dist._distance = lambda a, b, c=calls, m=measure: c.append(len(a)) or m(a, b)
            got = dist.many(levels, nears)
            assert all(np.array_equal(g, r) for g, r in zip(got, ref, strict=True))
            assert np.array_equal(first, ref[2]) and calls == [700 + 1 + len(levels[3])]
            assert np.array_equal(dist.many(levels[:1])[0], PolylineDistance(polys)(levels[0]))
            levels[2][0] += 1.0  # changed in place: measured anew
            calls.clear()
            again = dist.many(levels[2:3], nears[2:3])[0]
            assert calls == [len(levels[2])] and not np.array_equal(again, ref[2])
            levels[2][0] -= 1.0
            # a step's trials: A's own level with four new ones each, the memo keeps A's level
            # (the least recently used go first)
            dist(levels[0], near=nears[0])
            calls.clear()
            for trial in range(3):
                new = [levels[3][trial::4].copy() for _ in range(4)]
                got = dist.many([levels[0], *new], [nears[0]] + [None] * 4)
                assert np.array_equal(got[0], ref[0])
            assert calls == [sum(len(levels[3][t::4]) for _ in range(4)) for t in range(3)]


def test_measure_cusp_with_any_callable_as_with_polyline_distances():
    """``measure_cusp`` measures the levels of a distance with ``many`` in one call each side,
    and any other callable level by level: the same scallop, to the float (levels with an
    empty one between, which breaks the columns)."""
    rng = np.random.default_rng(5)
    t = np.linspace(0.0, 20.0, 80)
    pass_a = [(np.stack([t, np.zeros_like(t), np.full_like(t, 6.0)], 1), False)]
    pass_b = [(np.stack([t, np.full_like(t, 1.5), np.full_like(t, 6.0)], 1), False)]
    levels, normals = [], []
    for y in (0.0, 0.4, 0.75, None, 1.1, 1.5):
        if y is None:
            levels.append(np.zeros((0, 3)))
            normals.append(np.zeros((0, 3)))
            continue
        x = np.sort(rng.uniform(0, 20, 150))
        levels.append(np.stack([x, np.full_like(x, y), 0.02 * np.sin(x)], 1))
        normals.append(np.tile([0.0, 0.0, 1.0], (150, 1)))
    for kw in ({}, {"level_normals": normals}):
        da, db = PolylineDistance(pass_a), PolylineDistance(pass_b)
        ref = measure_cusp(levels, lambda q, near=None: PolylineDistance(pass_a)(q, near=near),
                           lambda q, near=None: PolylineDistance(pass_b)(q, near=near), 6.0, **kw)
        got = measure_cusp(levels, da, db, 6.0, **kw)
        assert got == ref and 0.01 < got < 0.1
