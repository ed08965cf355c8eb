"""The compiled glue of a pass (issue 21: the Python/numpy the main thread ran between the
kernels while it made each pass) against the numpy reference on the same inputs, bit for bit:
the facet lift with its candidate faces, the probe samples' candidate faces, the pose
shortfall on them, the intrusion probes along the centre path, and the per-face gradient and
curvature of the side-step prediction.

Tests comparing the two backends skip (saying why) when the extension is not built."""

from __future__ import annotations

import numpy as np
import pytest

from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.kernels import backend
from blisk_cam.core.kernels import lift as compiled_lift
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.paths.expansion import face_gradient_and_curvature
from blisk_cam.core.paths.passes import (
    INTRUSION_PROBE_SPACING,
    LIFT_GAIN,
    LIFT_TOLERANCE,
    PLANE_BOUND_SLACK,
    _Generator,
    _in_windows,
    _unique_per_row,
)
from tests.support.kernels import needs_compiled

compiled = needs_compiled("facet_lift", "probe_candidates", "candidate_shortfall",
                          "intrusion_probes", "face_gradient_curvature")


@pytest.fixture(scope="module")
def gen():
    d = make_demo_blisk(resolution=0.3, fillet=True)
    mesh = TriMesh.from_arrays(d.blade_vertices, d.blade_faces)
    return _Generator(mesh, d.axis, d.hub_cone, d.tip_cone, 6.0, 0.05, 0.01)


def _on_level(curve, closed, rng, n, tilt):
    """n points on the segments of a level curve taken as ``closed`` or open (then its last
    point too), their normals interpolated and tilted by about ``tilt`` (then normalised):
    (D, DN, seg)."""
    k = len(curve.points)
    seg = np.sort(rng.integers(0, k, n))
    nxt = (seg + 1) % k if closed else np.minimum(seg + 1, k - 1)
    t = rng.uniform(0.0, 1.0, n)[:, None]
    D = curve.points[seg] + t * (curve.points[nxt] - curve.points[seg])
    N = curve.normals[seg] + t * (curve.normals[nxt] - curve.normals[seg])
    N = N + rng.normal(0.0, tilt, N.shape)
    return D, N / np.linalg.norm(N, axis=1)[:, None], seg


@compiled
def test_facet_lift_compiled_bit_for_bit(gen):
    """Closed levels (also taken as open: the last point's segment), normals tilted off the
    smooth ones (many facet planes then penetrated): the same λ as the numpy steps on the
    padded candidate tables."""
    rng = np.random.default_rng(5)
    lifted = kinds = 0
    for s in (0.0, 0.3, 0.77, 1.0):
        for c in gen.level(s):
            for closed, tilt in ((c.closed, 0.0), (c.closed, 0.02), (False, 0.2)):
                kinds |= 1 << int(closed)
                D, DN, seg = _on_level(c, closed, rng, 1500, tilt)
                got = gen.facet_lift(D, DN, seg, c.edge, closed)
                with backend.numpy_only():
                    ref = gen.facet_lift(D, DN, seg, c.edge, closed)
                assert np.array_equal(got, ref), (s, tilt)
                lifted += np.count_nonzero(ref > 0)
    assert kinds == 3  # closed levels, and taken as open
    assert lifted > 1000  # the lift did act


def _facet_lift_compiled(gen, D, DN, seg, edge, closed, threads):
    """The compiled facet lift of ``gen`` on ``threads`` threads (the generator's call, its
    thread count chosen)."""
    m = gen.mesh
    return compiled_lift.facet_lift(
        (m.V, m.F, m.edges, m.edge_faces, m.face_normals), gen._vertex_face_table(), D, DN,
        edge, seg, closed,
        (gen.radius, gen.facet_tolerance, LIFT_TOLERANCE, LIFT_GAIN, PLANE_BOUND_SLACK), 4,
        threads)


@compiled
def test_facet_lift_runs_and_pieces_bit_for_bit(gen):
    """Many points per segment on runs of consecutive segments (the compiled lift keeps the
    candidate faces of one lifted point for the next: the same segment's, or a neighbour's
    shared corners), points that need the lift next to points that do not, the segments in
    order, reversed and shuffled, on 1 and 2 threads (from 16384 points on, pieces taken by
    the calling thread and a worker): numpy's λ."""
    rng = np.random.default_rng(11)
    cover = np.zeros(4, dtype=np.int64)  # same-segment lifted pairs, neighbour pairs, kinds
    for s in (0.2, 0.6):
        c = gen.level(s)[0]
        k = len(c.points)
        for closed in (c.closed, False):
            first = rng.integers(0, k - 120)
            runs = np.repeat(np.arange(first, first + 120), rng.integers(1, 40, 120))
            if closed:  # the last segment, back to the first point, and its neighbour
                runs = np.concatenate([runs, np.repeat([k - 2, k - 1], 15)])
            for order in ("sorted", "reversed", "shuffled"):
                seg = {"sorted": runs, "reversed": runs[::-1],
                       "shuffled": rng.permutation(runs)}[order]
                nxt = (seg + 1) % k if closed else np.minimum(seg + 1, k - 1)
                t = rng.uniform(0.0, 1.0, len(seg))[:, None]
                D = c.points[seg] + t * (c.points[nxt] - c.points[seg])
                N = c.normals[seg] + t * (c.normals[nxt] - c.normals[seg])
                tilt = rng.choice([0.0, 0.005, 0.05], len(seg))[:, None]
                N = N + tilt * rng.normal(0.0, 1.0, N.shape)
                DN = N / np.linalg.norm(N, axis=1)[:, None]
                with backend.numpy_only():
                    ref = gen.facet_lift(D, DN, seg, c.edge, closed)
                for threads in (1, 2):
                    got = _facet_lift_compiled(gen, D, DN, seg, c.edge, closed, threads)
                    assert np.array_equal(got, ref), (s, closed, order, threads)
                up = ref > 0
                cover[0] += np.count_nonzero(up[1:] & up[:-1] & (seg[1:] == seg[:-1]))
                cover[1] += np.count_nonzero(up[1:] & up[:-1] & (np.abs(seg[1:] - seg[:-1]) == 1))
                cover[2] += np.count_nonzero(up[1:] != up[:-1])
                cover[3] |= 1 << int(closed)
                if order == "sorted" and s == 0.2:  # the calling thread and a worker
                    big = np.tile(np.arange(len(seg)), 8)
                    assert len(big) >= 16384  # facet_lift.rs FACET_PARALLEL_MIN
                    with backend.numpy_only():
                        ref = gen.facet_lift(D[big], DN[big], seg[big], c.edge, closed)
                    for threads in (1, 2):
                        got = _facet_lift_compiled(gen, D[big], DN[big], seg[big], c.edge,
                                                   closed, threads)
                        assert np.array_equal(got, ref), (closed, threads)
    assert cover[0] > 5000 and cover[1] > 300  # lifted points in runs and across neighbours
    assert cover[2] > 500  # lifted points next to points left at λ = 0
    assert cover[3] == 3  # closed levels, and taken as open


@compiled
def test_facet_lift_ids_out_of_range_raise(gen):
    """An edge id past the mesh's edges, or a vertex–face table pointing past its faces: a
    ValueError (not a read out of bounds), on 1 and 2 threads."""
    c = gen.level(0.5)[0]
    rng = np.random.default_rng(2)
    D, DN, seg = _on_level(c, c.closed, rng, 20000, 0.2)  # the pool too (FACET_PARALLEL_MIN)
    m = gen.mesh
    ptr, face = gen._vertex_face_table()[:2]
    bad_face = face.copy()
    bad_face[:] = len(m.F)
    for threads in (1, 2):
        edge = c.edge.copy()
        edge[seg[len(seg) // 2]] = len(m.edges)
        with pytest.raises(ValueError, match="out of range"):
            _facet_lift_compiled(gen, D, DN, seg, edge, c.closed, threads)
        with pytest.raises(ValueError, match="out of range"):
            compiled_lift.facet_lift(
                (m.V, m.F, m.edges, m.edge_faces, m.face_normals), (ptr, bad_face), D, DN,
                c.edge, seg, c.closed,
                (gen.radius, gen.facet_tolerance, LIFT_TOLERANCE, LIFT_GAIN,
                 PLANE_BOUND_SLACK), 4, threads)


@compiled
def test_probe_candidates_and_shortfall_bit_for_bit(gen):
    """Ball centres at, above and sunk into the surface: the candidate rows (values, order,
    width) and the shortfall on them are numpy's."""
    mesh = gen.mesh
    rng = np.random.default_rng(8)
    n = 4000
    f = rng.integers(0, len(mesh.F), n)
    w = rng.dirichlet(np.ones(3), n)
    p = np.einsum("qk,qkj->qj", w, mesh.V[mesh.F[f]])
    C = p + (6.0 + rng.uniform(-0.3, 0.05, n))[:, None] * mesh.interpolate_normals(f, w)
    ids = gen._nearest_samples(C)
    assert np.count_nonzero(ids < 0) > 0  # rows with fewer than 8 samples
    got = gen._probe_candidates(ids)
    ref = _unique_per_row(gen._probe_faces(ids))
    assert got.dtype == ref.dtype and got.shape == ref.shape
    assert np.array_equal(got, ref)
    short = gen._pose_shortfall(C)
    with backend.numpy_only():
        ref_short = gen._pose_shortfall(C)
    assert np.array_equal(short, ref_short)
    assert np.count_nonzero(ref_short > 1e-4) > 100 and np.any(np.isneginf(ref_short))


@compiled
def test_face_gradient_curvature_bit_for_bit(gen):
    """Every face of the mesh, on the morph ratio field and on a field with NaN and inf
    entries (taken as 0, as the reference takes them)."""
    mesh = gen.mesh
    faces = np.arange(len(mesh.F))
    s = gen.s_clipped
    noisy = s + np.random.default_rng(3).normal(0.0, 1e-3, len(s))
    noisy[::97], noisy[5::211] = np.nan, np.inf
    for field in (s, noisy):
        g, k = compiled_lift.face_gradient_curvature(mesh.V, mesh.F, mesh.face_normals,
                                                     mesh.face_areas, mesh.vertex_normals,
                                                     field, faces)
        with backend.numpy_only():  # the numpy reference
            rg, rk = face_gradient_and_curvature(mesh, field, faces)
        assert np.array_equal(g, rg) and np.array_equal(k, rk)
        # the function itself takes the compiled route when installed (the same floats)
        cg, ck = face_gradient_and_curvature(mesh, field, faces)
        assert np.array_equal(cg, rg) and np.array_equal(ck, rk)
        assert np.count_nonzero(rk > 0) > 100 and np.count_nonzero(rk < 0) > 100
    # a level's faces, in the prediction's own call
    pred = gen.predict_step(0.4)
    with backend.numpy_only():
        assert gen.predict_step(0.4) == pred


@compiled
def test_intrusion_lift_compiled_bit_for_bit(gen):
    """Levels' points with their facet lift and sunk by up to 0.3 mm (intrusions to find and
    lift), a single point, and points that do not move (an arc of length 0): the same probes,
    centres and extra λ as numpy's."""
    rng = np.random.default_rng(12)
    hits = 0
    for s in (0.0, 0.5, 1.0):
        c = gen.level(s)[0]
        for closed in (c.closed, False):
            D, DN, seg = _on_level(c, closed, rng, 3000, 0.02)
            lam = gen.facet_lift(D, DN, seg, c.edge, closed) - rng.uniform(0.0, 0.3, len(D))
            for D_, DN_, lam_ in ((D, DN, lam), (D[:1], DN[:1], lam[:1]),
                                  (np.repeat(D[:1], 5, 0), np.repeat(DN[:1], 5, 0), lam[:5] * 0)):
                probe, Cp = compiled_lift.intrusion_probes(D_, DN_, lam_, 6.0,
                                                           INTRUSION_PROBE_SPACING)
                C = D_ + (6.0 + lam_)[:, None] * DN_
                arc = np.concatenate([[0.0],
                                      np.cumsum(np.linalg.norm(np.diff(C, axis=0), axis=1))])
                ref = np.unique(np.append(np.searchsorted(
                    arc, np.arange(0.0, arc[-1], INTRUSION_PROBE_SPACING)), len(C) - 1))
                assert np.array_equal(probe, ref) and np.array_equal(Cp, C[ref])
                got = gen.intrusion_lift(D_, DN_, lam_)
                with backend.numpy_only():
                    want = gen.intrusion_lift(D_, DN_, lam_)
                assert np.array_equal(got, want)
                hits += np.count_nonzero(want > 0)
    assert hits > 100  # intrusions were lifted


def test_in_windows_is_the_marked_union():
    rng = np.random.default_rng(1)
    for n in (1, 7, 500):
        lo = rng.integers(0, n, 40)
        hi = np.minimum(lo + rng.integers(0, 9, 40), n - 1)
        mark = np.zeros(n + 1, dtype=np.int64)
        np.add.at(mark, lo, 1)
        np.add.at(mark, hi + 1, -1)
        want = np.nonzero(np.cumsum(mark)[:n] > 0)[0]
        assert np.array_equal(_in_windows(lo, hi, n), want)
        assert np.array_equal(want, np.unique(np.concatenate(
            [np.arange(a, b + 1) for a, b in zip(lo, hi, strict=True)])))
