"""The generator's fast searches give the answers of the plain ones they replace (issue 13).

* ``_ProbeSamples.any_within`` (vertex k-d tree + exact candidates) against a k-d tree over
  every vertex, edge midpoint and face centroid, from ball centres tangent to the surface —
  where the two disagree if the candidates miss a sample — and from points right at a
  sample's distance (the tie band, answered by the full tree).
* ``_fixed_point_lift`` (exact distances only to triangles whose plane is near) against the
  fixed-point steps over every candidate triangle, bit for bit.
"""

import numpy as np
import pytest
from scipy.spatial import cKDTree

from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.paths.passes import (
    _fixed_point_lift,
    _Generator,
    _point_triangle_distance,
    _unique_per_row,
)

RHO = 6.0


@pytest.fixture(scope="module")
def gen():
    d = make_demo_blisk(resolution=0.3, fillet=True)  # the 8 mm fillet: intrusions exist
    mesh = TriMesh.from_arrays(d.blade_vertices, d.blade_faces)
    return _Generator(mesh, d.axis, d.hub_cone, d.tip_cone, RHO, 0.05, 0.01)


def all_samples(mesh):
    V, F, e = mesh.V, mesh.F, mesh.edges
    return np.vstack([V, 0.5 * (V[e[:, 0]] + V[e[:, 1]]),
                      (V[F[:, 0]] + V[F[:, 1]] + V[F[:, 2]]) / 3.0])


def tangent_centres(mesh, rng, n, lift):
    """Ball centres p + (ρ + lift) n over random points p on random faces."""
    f = rng.integers(0, len(mesh.F), n)
    w = rng.dirichlet(np.ones(3), n)
    p = np.einsum("qk,qkj->qj", w, mesh.V[mesh.F[f]])
    nn = mesh.interpolate_normals(f, w)
    return p + (RHO + lift)[:, None] * nn


def test_any_within_is_the_full_trees_answer(gen):
    mesh = gen.mesh
    tree = cKDTree(all_samples(mesh))
    probes = gen._probe_samples()
    rng = np.random.default_rng(7)
    n = 4000
    C = np.vstack([
        tangent_centres(mesh, rng, n, rng.uniform(-0.01, 0.01, n)),  # tangent, some inside
        tangent_centres(mesh, rng, n, rng.uniform(-1.0, 1.0, n)),
        rng.uniform(mesh.V.min(0) - 7, mesh.V.max(0) + 7, (n, 3)),
    ])
    for bound in (RHO - 1e-5, RHO - 1e-4, RHO - 0.5, 1.0):
        d, _ = tree.query(C, k=1, distance_upper_bound=bound)
        got = probes.any_within(C, bound)
        assert np.array_equal(got, np.isfinite(d)), bound
        assert 0 < got.sum() < len(C)  # both answers occur


def test_sample_points_are_the_full_trees(gen):
    probes = gen._probe_samples()
    pts = all_samples(gen.mesh)
    assert np.array_equal(probes.all_points(), pts)
    sid = np.random.default_rng(5).permutation(len(pts))[:5000]
    assert np.array_equal(probes.sample_points(sid), pts[sid])


def test_any_within_ties_go_to_the_full_tree(gen):
    probes = gen._probe_samples()
    tree = cKDTree(probes.all_points())
    rng = np.random.default_rng(3)
    C = tangent_centres(gen.mesh, rng, 200, np.zeros(200))
    d, _ = tree.query(C, k=1)
    before = probes.fallback_rows
    for bound in (d, np.nextafter(d, np.inf)):  # the nearest sample right at the bound
        got = np.array([probes.any_within(C[i:i + 1], float(bound[i]))[0]
                        for i in range(len(C))])
        ref = np.array([np.isfinite(tree.query(C[i], k=1, distance_upper_bound=bound[i])[0])
                        for i in range(len(C))])
        assert np.array_equal(got, ref)
    assert probes.fallback_rows - before == 2 * len(C)


def plain_lift(p, n, lam, tri, valid, rho, steps):
    """The fixed-point steps over every candidate (the code before issue 13)."""
    lam = lam.copy()
    active = np.arange(len(p))
    for _ in range(steps):
        c = p[active] + (rho + lam[active])[:, None] * n[active]
        d = _point_triangle_distance(c[:, None, :], tri[active])
        short = rho - np.where(valid[active], d, np.inf).min(axis=1)
        still = short > 1e-7
        lam[active[still]] += short[still] * 1.05
        active = active[still]
        if len(active) == 0:
            break
    return lam


def test_fixed_point_lift_is_bit_for_bit_the_plain_one(gen):
    mesh = gen.mesh
    rng = np.random.default_rng(11)
    n = 3000
    f = rng.integers(0, len(mesh.F), n)
    w = rng.dirichlet(np.ones(3), n)
    p = np.einsum("qk,qkj->qj", w, mesh.V[mesh.F[f]])
    nn = mesh.interpolate_normals(f, w)
    for lam0 in (np.zeros(n), rng.uniform(-0.2, 0.0, n)):  # at the surface, and sunk in
        C = p + (RHO + lam0)[:, None] * nn
        tree = cKDTree(all_samples(mesh))
        _, near = tree.query(C, k=8, distance_upper_bound=RHO + 0.05)
        cand = _unique_per_row(gen._probe_faces(np.where(near < tree.n, near, -1)))
        tri = mesh.V[mesh.F[np.maximum(cand, 0)]]
        ref = plain_lift(p, nn, lam0, tri, cand >= 0, RHO, 12)
        got = _fixed_point_lift(p, nn, lam0, tri, cand >= 0, RHO, 12)
        assert np.array_equal(got, ref)
        assert np.count_nonzero(ref != lam0) > 100  # the steps did lift
