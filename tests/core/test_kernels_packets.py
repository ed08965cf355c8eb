"""The sample tree's searches in packets of consecutive queries (``knn::packet``): the 8
nearest within a bound and the screens of ball centres in path order (each packet seeded by
the answers of the one before) are those of the plain tree, query by query, and of brute
force — also when the seeds are far from the answer (a packet's queries and the next's
scattered over the part), for calls of every length around the packet's 8, for repeated
centres, and at exact ties."""

from __future__ import annotations

import numpy as np
import pytest

from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.kernels import knn as compiled_knn
from blisk_cam.core.kernels import mesh_tables as compiled_tables
from tests.support.kernels import needs_compiled
from tests.support.mesh_files import cylinder_sheet, flat_grid, sample_points

compiled = needs_compiled(why="the packet searches are compiled only")


def _brute(pts, C, k, bound):
    """(ids (q, k) by (squared distance summed as the trees sum it, id), −1 padded; the
    squared distance to the nearest (q,))."""
    d = pts[None, :, :] - C[:, None, :]
    d2 = (d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1]) + d[..., 2] * d[..., 2]
    order = np.argsort(d2, axis=1, kind="stable")[:, :k]  # equal distances: lower id first
    ids = np.where(np.take_along_axis(d2, order, axis=1) < bound * bound, order, -1)
    return ids, d2.min(axis=1)


@pytest.fixture(scope="module")
def cylinder():
    """A cylinder of radius 20 mm, 0.4 mm triangles: (mesh, samples, the sample tree, the
    plain tree over the same samples)."""
    mesh = TriMesh.from_arrays(*cylinder_sheet(20.0, 2.0, 101, 8.0, 41))
    pts = sample_points(mesh)
    return (mesh, pts, compiled_tables.sample_tree(mesh.V, mesh.edges, mesh.F, 2),
            compiled_knn.point_tree(pts, 1))


def _path(rng, q, lift):
    """q ball centres in path order ρ = 6 mm (+ ``lift`` (q,)) outside the cylinder: a
    helix-like walk, 0.02–0.3 mm a step."""
    t = 0.3 + np.cumsum(rng.uniform(0.001, 0.015, q))
    h = -5.0 + np.cumsum(rng.uniform(0.0, 0.02, q))
    r = 26.0 + lift
    return np.column_stack([r * np.cos(t), r * np.sin(t), h])


@compiled
@pytest.mark.parametrize("order", ["path", "scattered", "alternating", "repeated"])
def test_packets_answer_as_the_plain_tree_and_brute_force(cylinder, order):
    """Centres along a path (seeds near the answer), shuffled (every packet's seeds from far
    away), alternating between two paths 10 mm apart (each query's neighbours in the packet
    far from it), and each centre four times in a row (seeds that are the answer): ids, tie
    flags and screens at bounds around ρ equal the plain tree's and brute force's, for
    calls of 1 to 19 centres and one of 300."""
    mesh, pts, tree, plain = cylinder
    rng = np.random.default_rng(24)
    C = _path(rng, 300, rng.uniform(-0.2, 0.05, 300))
    if order == "scattered":
        C = C[rng.permutation(len(C))]
    elif order == "alternating":
        D = C + [0.0, 0.0, 10.0]
        C = np.stack([C, D], axis=1).reshape(-1, 3)[:300]
    elif order == "repeated":
        C = np.repeat(C[::4], 4, axis=0)
    ref_ids, ref_d2 = _brute(pts, C, 8, 6.05)
    calls = [C[:m] for m in range(1, 20)] + [C]
    for Q in calls:
        ids, tie = tree.query(Q, 8, 6.05, 1)
        pids, ptie = plain.query(Q, 8, 6.05, 1)
        assert np.array_equal(ids, pids) and np.array_equal(tie, ptie)
        assert np.array_equal(ids[~tie], ref_ids[: len(Q)][~tie])
    for bound in (6.0 - 1e-4, 6.0 - 1e-5, 6.0, 6.02):
        got = compiled_knn.points_within(tree, C, bound, 1)
        assert np.array_equal(got, compiled_knn.points_within(plain, C, bound, 1)), bound
        assert np.array_equal(got, ref_d2 < bound * bound), bound
        for m in (1, 7, 8, 9, 17):
            assert np.array_equal(compiled_knn.points_within(tree, C[:m], bound, 1), got[:m])
    # the screens below ρ are mixed: some balls reach in (lifted below ρ), some do not
    hit = ref_d2 < (6.0 - 1e-5) ** 2
    assert 20 < np.count_nonzero(hit) < len(C) - 20


@compiled
def test_packets_on_a_flat_grid_with_exact_ties_in_path_order():
    """A flat grid of 0.5 mm squares and centres walking over it in path order, each ρ above
    a vertex or an edge midpoint (several samples at the very same distance: the k-th and
    the next tie), with bounds at exactly a sample's distance: the sample tree's packets
    give the plain tree's ids and tie flags, and brute force's on the untied rows."""
    V, F = flat_grid(6.0)
    mesh = TriMesh.from_arrays(V, F)
    pts = sample_points(mesh)
    tree = compiled_tables.sample_tree(mesh.V, mesh.edges, mesh.F, 2)
    plain = compiled_knn.point_tree(pts, 1)
    s = np.arange(-4.0, 4.0, 0.25)
    C = np.column_stack([s, 0.5 * s, np.full(len(s), 6.0)])
    C = np.vstack([C, C + [0.0, 0.25, 0.0], C[::-1]])
    for bound in (6.05, 6.0, np.nextafter(6.0, 7.0), np.sqrt(0.25 ** 2 + 36.0)):
        ids, tie = tree.query(C, 8, float(bound), 1)
        pids, ptie = plain.query(C, 8, float(bound), 1)
        assert np.array_equal(ids, pids) and np.array_equal(tie, ptie), bound
        ref, d2 = _brute(pts, C, 8, bound)
        assert np.array_equal(ids[~tie], ref[~tie]), bound
        got = compiled_knn.points_within(tree, C, float(bound), 1)
        assert np.array_equal(got, d2 < bound * bound), bound
    ids, tie = tree.query(C, 8, 6.05, 1)
    assert np.count_nonzero(tie) > 10  # the ties are there
