"""The distance to ball-centre polylines and the column neighbours of a scallop's levels
walked in packets of consecutive queries (``knn::packet`` on a plain k-d tree): the
distances are the numpy reference's bit for bit, and the rows left to scipy (a tie at the
k-th nearest sample, fewer than k found) are exactly those the tree flags one query at a
time and brute force flags — for hints in path order (each packet seeded by the answer
before), shuffled (seeds far from the answer), on a lattice (exact ties), for calls of 1 to
19 hints and one of 300, and with k above the number of samples."""

from __future__ import annotations

import numpy as np
import pytest

from blisk_cam.core.kernels import knn as compiled_knn
from blisk_cam.core.kernels import polyline as compiled_polyline
from blisk_cam.core.paths.expansion import PolylineDistance, _nearest_index
from tests.support.kernels import needs_compiled

compiled = needs_compiled("polyline_distance", "PointTree")


def _brute_flags(samples, hint, k):
    """(q,) bool: the k-th and (k + 1)-th nearest samples of each hint (squared distances
    summed as the tree sums them) are at the same distance, or there are fewer than k."""
    d = samples[None, :, :] - hint[:, None, :]
    d2 = np.sort((d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1]) + d[..., 2] * d[..., 2], 1)
    if k > samples.shape[0]:
        return np.ones(len(hint), bool)
    if k == samples.shape[0]:
        return np.zeros(len(hint), bool)
    return d2[:, k - 1] == d2[:, k]


def _pass_and_hints(rng, order):
    """A pass's ball-centre polylines (a wavy open one, a closed loop, a lattice one with
    integer corners) and hints in the given order: ``path``, points 0.6 mm off the wavy
    polyline walking along it 0.19 mm a step (the plan's case) and around the loop;
    ``shuffled``, the same permuted; ``lattice``, half-integer points next to the lattice
    polyline, in path order (several samples at one distance: ties at the k-th)."""
    t = np.linspace(0.0, 6.0, 90)
    wavy = np.stack([10 * t, 3 * np.sin(t), 0.5 * np.cos(3 * t)], 1)
    a = np.linspace(0, 2 * np.pi, 60, endpoint=False)
    loop = np.stack([20 + 8 * np.cos(a), 5 * np.sin(a), np.full(60, 4.0)], 1)
    lattice = np.array([[0, 10, 0], [4, 10, 0], [4, 14, 0], [0, 14, 0], [0, 10, 4]], float)
    polys = [(wavy, False), (loop, True), (lattice, False)]
    if order == "lattice":
        s = np.arange(0.0, 4.0, 0.25)
        hint = np.concatenate([np.stack([s, np.full_like(s, 10.5), np.full_like(s, 0.5)], 1),
                               np.stack([np.full_like(s, 4.5), 10 + s, np.zeros_like(s)], 1)])
        hint = np.tile(hint, (10, 1))[:300]
        p = hint + [0.0, 0.0, 0.25]
        return polys, p, hint
    u = np.linspace(0.2, 5.8, 240)
    on = np.stack([10 * u, 3 * np.sin(u), 0.5 * np.cos(3 * u)], 1)
    b = np.linspace(0.0, 2 * np.pi, 60)
    ring = np.stack([20 + 8.6 * np.cos(b), 5.6 * np.sin(b), np.full(60, 4.3)], 1)
    hint = np.concatenate([on + [0.0, 0.0, 0.6], ring]) + rng.normal(0, 0.01, (300, 3))
    p = hint + rng.normal(0, 0.3, hint.shape)
    if order == "shuffled":
        perm = rng.permutation(len(p))
        p, hint = p[perm], hint[perm]
    return polys, p, hint


@compiled
@pytest.mark.parametrize("order", ["path", "shuffled", "lattice"])
@pytest.mark.parametrize("resample, k", [(0.25, 6), (0.5, 3), (1.0, 8)])
def test_packets_give_numpys_distances_and_the_one_by_one_flags(order, resample, k):
    """Per call of 1 to 19 hints and of 300: the kernel's distances equal the numpy
    reference's on every row it answers, its flagged rows hold NaN and are those of the
    tree asked one query at a time (its tie or a −1) and of brute force; the class's
    answer (flagged rows by scipy) equals the reference on every row."""
    rng = np.random.default_rng(25)
    polys, p, hint = _pass_and_hints(rng, order)
    dist = PolylineDistance(polys, resample=resample, k=k)
    tree = compiled_knn.point_tree(dist.samples, 1)
    ref = dist._distance_numpy(p, hint)
    ids, tie = tree.query(hint, dist.k, np.inf, 1)  # one by one (no packets)
    one_by_one = tie | (ids < 0).any(axis=1)
    assert np.array_equal(one_by_one, _brute_flags(dist.samples, hint, dist.k))
    for m in [*range(1, 20), 300]:
        d, rest = compiled_polyline.polyline_distance(
            tree, p[:m], hint[:m], dist.k, dist.seg_of_sample, dist.a, dist.ab, dist.L2, 1)
        assert np.array_equal(rest, one_by_one[:m]), m
        assert np.array_equal(d[~rest], ref[:m][~rest]) and np.all(np.isnan(d[rest])), m
    assert np.array_equal(dist._distance(p, hint), ref)
    # two threads: other runs, the same answers
    d2, rest2 = compiled_polyline.polyline_distance(
        tree, p, hint, dist.k, dist.seg_of_sample, dist.a, dist.ab, dist.L2, 2)
    assert np.array_equal(rest2, one_by_one) and np.array_equal(d2[~rest2], ref[~rest2])
    if order == "lattice":
        assert one_by_one.any() and not one_by_one.all()  # the ties are there


@compiled
def test_k_above_the_samples_flags_every_row():
    """A pass of one short segment (two samples): asked for more nearest samples than there
    are, every row is flagged (fewer than k found) and holds NaN; the class asks for all of
    them instead and answers as the reference."""
    rng = np.random.default_rng(4)
    polys = [(np.array([[0.0, 0.0, 0.0], [0.4, 0.0, 0.0]]), False)]
    p = rng.normal(0, 1, (37, 3))
    dist = PolylineDistance(polys, resample=0.25, k=6)
    assert len(dist.samples) == 2 and dist.k == 2
    tree = compiled_knn.point_tree(dist.samples, 1)
    d, rest = compiled_polyline.polyline_distance(
        tree, p, p, 6, dist.seg_of_sample, dist.a, dist.ab, dist.L2, 1)
    assert rest.all() and np.all(np.isnan(d))
    assert np.array_equal(dist._distance(p, p), dist._distance_numpy(p, p))
    assert not np.isnan(dist._distance(p, p)).any()


@compiled
@pytest.mark.parametrize("order", ["path", "shuffled", "lattice"])
def test_column_neighbours_in_packets_as_one_by_one(order):
    """The column neighbours (the nearest of a level's points to each of the previous
    level's, in path order): the tree's packets give the ids and tie flags it gives one
    query at a time and brute force's, for calls of 1 to 19 and 300 queries; and
    ``_nearest_index`` is scipy's."""
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(26)
    _, pts, q = _pass_and_hints(rng, order)
    pts = np.concatenate([pts, pts[::9]])  # repeated points: ties by id
    if order == "lattice":
        pts = np.round(pts * 2) / 2
    tree = compiled_knn.point_tree(pts, 1)
    if not getattr(tree, "PACKETS", False):
        pytest.skip("the installed compiled kernels were built before query's packets "
                    "(make kernels)")
    ref, ref_tie = tree.query(q, 1, np.inf, 1)
    dd = pts[None] - q[:, None]
    d2 = (dd[..., 0] * dd[..., 0] + dd[..., 1] * dd[..., 1]) + dd[..., 2] * dd[..., 2]
    assert np.array_equal(ref[:, 0], np.argmin(d2, axis=1))  # lowest id of the nearest
    s = np.sort(d2, axis=1)
    assert np.array_equal(ref_tie, s[:, 0] == s[:, 1])
    for m in [*range(1, 20), 300]:
        ids, tie = tree.query(q[:m], 1, np.inf, 1, packets=True)
        assert np.array_equal(ids, ref[:m]) and np.array_equal(tie, ref_tie[:m]), m
    for k in (2, 5):
        one, one_tie = tree.query(q, k, np.inf, 1)
        got, got_tie = tree.query(q, k, np.inf, 2, packets=True)
        assert np.array_equal(got, one) and np.array_equal(got_tie, one_tie), k
    assert np.array_equal(_nearest_index(pts, q), cKDTree(pts).query(q)[1])
    if order != "shuffled":
        assert ref_tie.any()
