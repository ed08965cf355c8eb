"""The compiled kernels (core/kernels, the Rust extension) against the numpy reference on the
same inputs: identical where the arithmetic is the same; and the backend selection.

Tests comparing the two backends skip (saying why) when the extension is not built; the
selection tests run everywhere."""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from blisk_cam.core.geometry import weld
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.kernels import backend
from blisk_cam.core.paths.sampling import forward_step_indices
from tests.support.kernels import needs_compiled

ROOT = Path(__file__).resolve().parents[2]

compiled = needs_compiled()


def _backend_in_subprocess(env_value):
    env = {k: v for k, v in os.environ.items() if k != backend.ENV}
    if env_value is not None:
        env[backend.ENV] = env_value
    done = subprocess.run(
        [sys.executable, "-c",
         "from blisk_cam.core.kernels.backend import backend_name; print(backend_name())"],
        cwd=ROOT, env=env, capture_output=True, text=True, check=True)
    return done.stdout.strip(), done.stderr


def test_env_forces_numpy_without_a_warning():
    name, err = _backend_in_subprocess("numpy")
    assert name == "numpy"
    assert err == ""  # the user's choice: nothing to warn about


def test_backend_without_env_is_the_installed_one():
    name, err = _backend_in_subprocess(None)
    try:
        import blisk_cam_kernels as ext  # noqa: F401 (is it installed here?)
    except ImportError:
        assert name == "numpy"
        assert len(err.strip().splitlines()) == 1 and "numpy" in err  # one warning line
    else:
        assert name == f"compiled {ext.VERSION}"
        assert err == ""


def test_numpy_only_block_selects_numpy():
    with backend.numpy_only():
        assert backend.extension() is None
        assert backend.backend_name() == "numpy"


def test_version_flag_names_the_backend():
    done = subprocess.run([sys.executable, "-m", "blisk_cam", "--version"], cwd=ROOT,
                          capture_output=True, text=True, check=True)
    assert f"(kernels: {backend.backend_name()})" in done.stdout


def _wavy_polylines(k, seed):
    """A CC polyline (a helix with noise and a sharp turn) and ball centres 6 mm off it
    along rough normals, mm."""
    rng = np.random.default_rng(seed)
    s = np.linspace(0.0, 40.0, k)
    P = np.stack([20 * np.cos(s / 20), 20 * np.sin(s / 20), 0.3 * s], axis=1)
    P += rng.normal(scale=0.002, size=P.shape)
    P[k // 2 :, 0] += np.linspace(0.0, 3.0, k - k // 2) ** 2  # a bend
    N = P - P.mean(axis=0)
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    return P, P + 6.0 * N


def _deviation(X, i, j):
    """Independent measure: largest distance of the points between i and j to the chord."""
    if j - i < 2:
        return 0.0
    a, b = X[i], X[j]
    q = X[i + 1 : j]
    t = np.clip((q - a) @ (b - a) / max((b - a) @ (b - a), 1e-300), 0, 1)
    return float(np.linalg.norm(q - a - t[:, None] * (b - a), axis=1).max())


@compiled
@pytest.mark.parametrize("chord", [0.001, 0.01, 0.05])
def test_forward_step_identical_on_both_backends(chord):
    P, C = _wavy_polylines(3000, seed=int(chord * 1000))
    got = forward_step_indices(P, C, chord, centre_chord=0.6 * chord)
    with backend.numpy_only():
        ref = forward_step_indices(P, C, chord, centre_chord=0.6 * chord)
    np.testing.assert_array_equal(got, ref)
    assert got[0] == 0 and got[-1] == len(P) - 1 and len(got) > 3
    for i, j in zip(got[:-1], got[1:], strict=True):  # the tolerance holds (measured apart)
        assert _deviation(P, i, j) <= chord and _deviation(C, i, j) <= 0.6 * chord


@compiled
def test_forward_step_memo_gives_the_same_as_without_on_both_backends():
    P, C = _wavy_polylines(2000, seed=3)
    C2 = C.copy()
    C2[700:720] += 0.004  # a few centres lifted, as the generator does between calls
    out = {}
    for name in ("compiled", "numpy"):
        with backend.numpy_only() if name == "numpy" else contextlib.nullcontext():
            memo = {}
            forward_step_indices(P, C, 0.01, memo=memo)
            out[name] = (forward_step_indices(P, C2, 0.01, memo=memo),
                         forward_step_indices(P, C2, 0.01))
    np.testing.assert_array_equal(out["compiled"][0], out["compiled"][1])
    np.testing.assert_array_equal(out["compiled"][0], out["numpy"][0])
    np.testing.assert_array_equal(out["numpy"][0], out["numpy"][1])


@compiled
def test_forward_step_edge_cases_identical():
    rng = np.random.default_rng(7)
    cases = [np.zeros((1, 3)), np.zeros((2, 3)), np.zeros((5, 3)),  # one point, repeats
             rng.normal(size=(3, 3)), np.cumsum(rng.normal(size=(400, 3)), axis=0)]
    for P in cases:
        got = forward_step_indices(P, P + 1.0, 0.1)
        with backend.numpy_only():
            ref = forward_step_indices(P, P + 1.0, 0.1)
        np.testing.assert_array_equal(got, ref)


@compiled
def test_weld_first_equal_point_identical():
    rng = np.random.default_rng(11)
    base = np.round(rng.normal(size=(5000, 3)), 2)  # many exact duplicates after rounding
    pts = base[rng.integers(0, len(base), size=40_000)] + 0.0
    cols = [np.ascontiguousarray(pts[:, j]) for j in range(3)]
    got = weld._first_equal_point(cols)
    with backend.numpy_only():
        ref = weld._first_equal_point(cols)
    np.testing.assert_array_equal(got, ref)
    # measured truth: the first point equal to each point
    _, first_of_row, inverse = np.unique(pts, axis=0, return_index=True, return_inverse=True)
    np.testing.assert_array_equal(got, first_of_row[inverse.ravel()])


@compiled
def test_mesh_from_arrays_identical_on_both_backends():
    from blisk_cam.core.part.blisk import make_demo_blisk

    d = make_demo_blisk(resolution=0.3)
    V, F = d.blade_vertices, d.blade_faces
    soup = V[F.ravel()]  # a triangle soup, as an STL reads
    Fs = np.arange(len(soup)).reshape(-1, 3)
    got = TriMesh.from_arrays(soup, Fs)
    with backend.numpy_only():
        ref = TriMesh.from_arrays(soup, Fs)
    np.testing.assert_array_equal(got.V, ref.V)
    np.testing.assert_array_equal(got.F, ref.F)


@compiled
def test_triangle_distance_port_is_bit_identical():
    """The compiled nearest-face search decides with its port of closest_on_triangles' d2:
    the same bits on general, degenerate, needle and sliver triangles."""
    from blisk_cam.core.geometry.closest import closest_on_triangles
    from blisk_cam.core.kernels.closest import triangle_d2

    rng = np.random.default_rng(1)
    n = 20_000
    p = rng.normal(size=(n, 3)) * 10
    a = rng.normal(size=(n, 3)) * 5
    b = a + rng.normal(size=(n, 3))
    c = a + rng.normal(size=(n, 3)) * np.array([1.0, 1e-4, 1.0])
    c[:500] = a[:500]  # zero area
    c[500:1000] = a[500:1000] + 1e-7 * (b[500:1000] - a[500:1000])  # needles
    p[1000:1500] = a[1000:1500]  # on a vertex
    np.testing.assert_array_equal(triangle_d2(p, a, b, c), closest_on_triangles(p, a, b, c)[1])


@compiled
@pytest.mark.parametrize("disks", [False, True])
def test_nearest_faces_identical_on_both_backends(disks):
    from blisk_cam.core.geometry.distance import NearestFaces
    from blisk_cam.core.part.blisk import make_demo_blisk
    from blisk_cam.core.runtime import parallel

    d = make_demo_blisk(resolution=0.3)
    mesh = TriMesh.from_arrays(d.blade_vertices, d.blade_faces)
    rng = np.random.default_rng(2)
    idx = rng.integers(0, len(mesh.V), 2000)
    P = np.vstack([mesh.V[idx],  # vertices: ties among the faces around them
                   mesh.V[idx] + rng.normal(scale=0.05, size=(2000, 3)),
                   mesh.V[idx[:500]] + 6.0 * mesh.vertex_normals[idx[:500]]])
    with backend.numpy_only():
        ref = NearestFaces(mesh).query(P)
    for threads in (1, 2):
        with parallel(threads):
            got = NearestFaces(mesh, disks=disks).query(P)
        for g, r in zip(got, ref, strict=True):
            np.testing.assert_array_equal(g, r)


@compiled
def test_nearest_faces_with_disks_on_needles_and_slivers():
    """The per-face bounds (disk and longest-edge capsule) skip only faces that cannot be
    nearest: a strip of long needle faces (4 mm by 0.02 mm, like a scanned blade's leading
    edge), slivers and a zero-area face, queried on the strip, around it and 6 mm off it,
    give numpy's faces (the least distance, then the lowest id)."""
    from blisk_cam.core.geometry.distance import NearestFaces

    rng = np.random.default_rng(4)
    x = np.linspace(0.0, 2.0, 101)  # 0.02 mm apart along x, 4 mm long along y
    top = np.stack([x, np.full_like(x, 4.0), 0.3 * np.sin(3 * x)], 1)
    bot = np.stack([x, np.zeros_like(x), 0.3 * np.sin(3 * x)], 1)
    V = np.vstack([bot, top, [[1.0, 2.0, 0.1], [1.0 + 1e-9, 2.0, 0.1], [1.0, 2.0, 0.1]]])
    n = len(x)
    i = np.arange(n - 1)
    F = np.vstack([np.stack([i, i + 1, n + i], 1), np.stack([i + 1, n + i + 1, n + i], 1),
                   [[2 * n, 2 * n + 1, 2 * n + 2]]])
    mesh = TriMesh(V, F)
    f = rng.integers(0, len(F) - 1, 1500)
    w = rng.dirichlet([1.0, 1.0, 1.0], 1500)
    on = np.einsum("ij,ijk->ik", w, V[F[f]])  # on the faces, then a few µm off them
    P = np.vstack([on + rng.normal(scale=0.005, size=(1500, 3)),
                   rng.uniform([-0.5, -1.0, -1.0], [2.5, 5.0, 1.0], (1500, 3)),
                   rng.uniform([-0.5, -1.0, 5.0], [2.5, 5.0, 7.0], (1500, 3)),
                   V[:2 * n]])  # vertices: ties among their faces
    with backend.numpy_only():
        ref = NearestFaces(mesh).query(P)
    got = NearestFaces(mesh, disks=True).query(P)
    for g, r in zip(got, ref, strict=True):
        np.testing.assert_array_equal(g, r)


@compiled
def test_nearest_k_gives_scipys_sets():
    """The compiled k nearest within a bound: scipy's set of k on every row (the rows with
    equal k-th and (k + 1)-th distances flagged and answered by scipy, as the lift does)."""
    from scipy.spatial import cKDTree

    from blisk_cam.core.kernels.knn import nearest_k, point_tree

    rng = np.random.default_rng(4)
    X = rng.normal(size=(60_000, 3)) * [4.0, 4.0, 1.0]
    X[:300] = X[300:600]  # exact duplicates: ties at the 8th place
    Q = np.vstack([rng.normal(size=(5000, 3)) * [4.0, 4.0, 1.0], X[:600]])
    kd = cKDTree(X, leafsize=64, balanced_tree=False, compact_nodes=False)

    def scipy_rows(rows):
        _, near = kd.query(rows, k=8, distance_upper_bound=0.4)
        return np.where(near < kd.n, near, -1)

    asked = []
    got = nearest_k(point_tree(X), Q, 8, 0.4, 2,
                    ties=lambda rows: asked.append(len(rows)) or scipy_rows(rows))
    assert asked and asked[0] > 0  # the duplicates made ties
    np.testing.assert_array_equal(np.sort(got, axis=1), np.sort(scipy_rows(Q), axis=1))
    assert 0 < np.mean(got >= 0) < 1  # some rows have fewer than 8 within the bound


compiled_stock = needs_compiled("stock_remove")


def _stock_program():
    """Moves on an annulus blank r 10..30, z 0..10 (4 blades): a rapid diving 2 mm into the
    top face (a rapid crash), a 5-axis ball cut with the axis tilting toward the blisk axis,
    plunges at three radii on one angle (rays split into more intervals than the blank's),
    and a plunge burying the Ø4 shank (a body crash)."""
    from blisk_cam.core.toolpath.types import MOVE_CUT, MOVE_RAPID, Program

    z = [0.0, 0.0, 1.0]
    th = np.radians(20.0)
    e = np.array([np.cos(th), np.sin(th), 0.0])
    rows = [([20, 5, 15], z, MOVE_RAPID), ([20, 5, 8], z, MOVE_RAPID),
            ([20, 5, 15], z, MOVE_RAPID)]
    t = np.linspace(0.3, 1.1, 9)
    for k, a in enumerate(t):
        ax = np.array([-np.sin(a) * 0.5, 0.0, 1.0])
        rows.append(([18.0 * np.cos(a), 18.0 * np.sin(a), 8.5 - 0.2 * k], ax / np.linalg.norm(ax),
                     MOVE_CUT))
    for r in (14.0, 20.0, 26.0):
        rows += [(list(r * e + [0, 0, 12]), z, MOVE_RAPID),
                 (list(r * e + [0, 0, 7.5]), z, MOVE_CUT), (list(r * e + [0, 0, 12]), z, MOVE_CUT)]
    rows += [([22, 14, 12], z, MOVE_RAPID), ([22, 14, 4], z, MOVE_CUT)]
    tips = np.array([r[0] for r in rows], float)
    axes = np.array([r[1] for r in rows], float)
    moves = np.array([r[2] for r in rows], np.int8)
    m = len(rows)
    return Program(tips, axes, moves, np.full(m, -1), np.full(m, -1), np.zeros(m, np.uint8))


@compiled_stock
def test_stock_removal_compiled_equals_numpy():
    """The compiled stock kernel against the numpy reference: the same intervals on every
    ray (1e-9 mm), the same volumes per move type and the same crashes (rows, kinds,
    volumes), on 1 and 2 threads."""
    from blisk_cam.core.geometry.axis import Axis
    from blisk_cam.core.runtime import parallel
    from blisk_cam.core.stock.blank import stock_from_profile
    from blisk_cam.core.stock.removal import remove_program
    from blisk_cam.core.tool.cutter import Cutter

    prog = _stock_program()
    ball = Cutter.ball(1.5, h=3.0, shank_diameter=4.0)
    bull = Cutter.bull(2.0, 0.5, h=4.0, shank_diameter=5.0)

    def run(cutter):
        s = stock_from_profile([[10, 0], [30, 0], [30, 10], [10, 10]], Axis(), 4, 0.0, 0.2)
        return s, remove_program(s, prog, cutter, batch=5, swept=False)

    for cutter in (ball, bull):
        with backend.numpy_only():
            ref_s, ref = run(cutter)
        assert ref_s.lo.shape[1] > 2  # the plunges split rays beyond the blank's K
        assert {c.kind for c in ref.crashes} == {"rapid", "body"}
        for threads in (1, 2):
            with parallel(threads):
                s, got = run(cutter)
            assert s.lo.shape == ref_s.lo.shape
            np.testing.assert_allclose(s.lo, ref_s.lo, rtol=0, atol=1e-9)
            np.testing.assert_allclose(s.hi, ref_s.hi, rtol=0, atol=1e-9)
            for k, v in ref.removed.items():
                assert got.removed[k] == pytest.approx(v, rel=1e-9, abs=1e-9)
            assert [(c.row, c.kind, c.move) for c in got.crashes] == \
                [(c.row, c.kind, c.move) for c in ref.crashes]
            for c, r in zip(got.crashes, ref.crashes, strict=True):
                assert c.volume == pytest.approx(r.volume, rel=1e-9)
                assert c.depth == pytest.approx(r.depth, abs=1e-9)
            assert (got.sub_poses, got.pairs) == (ref.sub_poses, ref.pairs)


compiled_sweep = needs_compiled("stock_sweep")


@compiled_sweep
def test_stock_swept_body_is_the_posed_body():
    """The body through the sweep kernel (its sub-poses, culled per move and frustum) against
    the numpy reference's posed body: the same intervals on every ray (1e-9 mm) and the same
    crashes (rows, kinds, volumes, depths), on 1 and 2 threads — a Ø6 holder lying along the
    blades, sloping into the annulus' top face and turning while the flute stays in the air
    (so only the body's route differs)."""
    from blisk_cam.core.geometry.axis import Axis
    from blisk_cam.core.kernels import stock as stock_kernels
    from blisk_cam.core.runtime import parallel
    from blisk_cam.core.stock.blank import stock_from_profile
    from blisk_cam.core.stock.removal import remove_program
    from blisk_cam.core.tool.cutter import Cutter
    from blisk_cam.core.toolpath.types import MOVE_CUT, MOVE_RAPID, Program

    if not stock_kernels.sweep_body_available():
        pytest.skip("the compiled kernels were built before the swept body")
    tool = Cutter.ball(1.0, h=3.0, shank_diameter=2.0, holder_diameter=6.0, holder_length=25.0)
    phi = np.radians(np.arange(7) * 3.0)
    axes = np.stack([np.sin(phi), np.cos(phi), np.full(7, -0.125)], 1)
    axes /= np.linalg.norm(axes, axis=1)[:, None]
    tips = np.stack([20.0 + 0.6 * np.arange(7), np.zeros(7), np.full(7, 15.0)], 1)
    tips[0, 2] = 25.0
    moves = np.array([MOVE_RAPID] + [MOVE_CUT] * 6, np.int8)
    prog = Program(tips, axes, moves, np.full(7, -1), np.full(7, -1), np.zeros(7, np.uint8))

    def run():
        s = stock_from_profile([[10, 0], [30, 0], [30, 10], [10, 10]], Axis(), 24, 0.0, 0.2)
        return s, remove_program(s, prog, tool, batch=3)

    with backend.numpy_only():
        ref_s, ref = run()
    assert len([c for c in ref.crashes if c.kind == "body"]) >= 3
    for threads in (1, 2):
        with parallel(threads):
            s, got = run()
        np.testing.assert_allclose(s.lo, ref_s.lo, rtol=0, atol=1e-9)
        np.testing.assert_allclose(s.hi, ref_s.hi, rtol=0, atol=1e-9)
        assert [(c.row, c.kind, c.move) for c in got.crashes] == \
            [(c.row, c.kind, c.move) for c in ref.crashes]
        for c, r in zip(got.crashes, ref.crashes, strict=True):
            assert c.volume == pytest.approx(r.volume, rel=1e-9)
            assert c.depth == pytest.approx(r.depth, abs=1e-9)


@compiled_sweep
def test_stock_swept_moves_against_sampled_numpy():
    """The compiled swept flute against the numpy reference's sub-poses on the same program:
    the sweep holds every sub-pose (it removes at least what the sub-poses remove, less the
    chords' sagitta ≤ the 4 µm sweep tolerance over the ≲ 200 mm² of cut faces: 1 mm³), the
    ball's sweep agrees with sub-poses 8× finer (a scallop of 0.5 µm) within 0.1 % (its
    centre chords' sagitta), and the crashes (rows and kinds) are the same."""
    from blisk_cam.core.geometry.axis import Axis
    from blisk_cam.core.stock.blank import stock_from_profile
    from blisk_cam.core.stock.removal import remove_program
    from blisk_cam.core.tool.cutter import Cutter

    prog = _stock_program()

    def run(cutter, **kw):
        s = stock_from_profile([[10, 0], [30, 0], [30, 10], [10, 10]], Axis(), 4, 0.0, 0.2)
        return remove_program(s, prog, cutter, batch=5, **kw)

    for cutter in (Cutter.ball(1.5, h=3.0, shank_diameter=4.0),
                   Cutter.bull(2.0, 0.5, h=4.0, shank_diameter=5.0),
                   Cutter.flat(2.0, h=4.0, shank_diameter=5.0)):
        with backend.numpy_only():
            ref = run(cutter)
            fine = run(cutter, sweep_tolerance=5e-4) if cutter.type == "ball" else None
        got = run(cutter, swept=True)
        assert got.volume >= ref.volume - 1.0
        assert got.volume <= ref.volume + 0.01 * ref.volume
        if fine is not None:
            assert got.volume == pytest.approx(fine.volume, rel=1e-3)
            assert abs(got.volume - fine.volume) < abs(ref.volume - fine.volume)
        assert {(c.row, c.kind) for c in got.crashes} == {(c.row, c.kind) for c in ref.crashes}


@compiled
def test_threads_asking_one_worker_each_get_pools_of_their_own():
    """runtime.map_chunks spreads chunks over Python threads that each call a kernel with one
    worker; on one shared single-worker pool they ran one after another (the bull-nose verify
    on 2 threads took as long as on 1). Each thread's one-worker pool is its own and is kept;
    a pool of several workers is shared."""
    import threading

    from blisk_cam.core.runtime import map_chunks, parallel

    ids = {}
    both = threading.Barrier(2, timeout=60)  # the first two chunks meet: two threads

    def one(s):
        if s < 2:
            both.wait()
        ids[(threading.get_ident(), s)] = (backend.pool_identity(1), backend.pool_identity(1),
                                           backend.pool_identity(2))

    with parallel(2):
        map_chunks(one, 8, 1)
    threads = {t for t, _ in ids}
    assert len(threads) >= 2  # the chunks ran on several Python threads
    for own, again, _ in ids.values():
        assert own == again  # kept for the thread
    per_thread = {t: ids[(t, s)][0] for t, s in ids}
    assert len(set(per_thread.values())) == len(threads)  # one pool per thread
    assert len({v[2] for v in ids.values()}) == 1  # the 2-worker pool is shared


@compiled
@pytest.mark.parametrize("offset", [0.0, 3.0e4])
def test_nearest_faces_plane_bound_skips_no_nearer_face(offset):
    """The tree without per-face bounds skips a face whose plane lies beyond the reach of
    the best (``FaceTree::d2_within``): on a flat grid (every plane through the query's
    foot: nothing skipped, ties at the very same distance), inside a finely bent sheet
    (ball centres 6 mm off a concave cylinder of radius 8 mm: many faces near the least
    distance), on and just off the sheet, near slivers, and with the mesh 30 m from the
    origin (coarser rounding), the faces are numpy's (the least distance, then the lowest
    id) on 1 and 2 threads."""
    from blisk_cam.core.geometry.distance import NearestFaces
    from blisk_cam.core.runtime import parallel

    rng = np.random.default_rng(7)
    u, v = np.meshgrid(np.linspace(0.0, 4.0, 41), np.linspace(0.0, 3.0, 31), indexing="ij")
    nu, nv = u.shape
    ids = np.arange(nu * nv).reshape(nu, nv)
    q = np.stack([ids[:-1, :-1], ids[1:, :-1], ids[1:, 1:], ids[:-1, 1:]], -1).reshape(-1, 4)
    F = np.vstack([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])
    flat = np.stack([u.ravel(), v.ravel(), np.zeros(u.size)], 1)
    ang = u.ravel() / 8.0  # the sheet bent about the line y = 0.. 3 at z = 8
    bent = np.stack([8.0 * np.sin(ang), v.ravel(), 8.0 - 8.0 * np.cos(ang)], 1)
    sliver = bent[F[:40, 0]] + 1e-7 * (bent[F[:40, 1]] - bent[F[:40, 0]])
    for V0, Fm in ((flat, F), (np.vstack([bent, sliver]),
                              np.vstack([F, np.stack([F[:40, 0], F[:40, 1],
                                                      len(bent) + np.arange(40)], 1)]))):
        V = V0 + offset
        mesh = TriMesh(V, Fm)
        f = rng.integers(0, len(F), 800)
        w = rng.dirichlet([1.0, 1.0, 1.0], 800)
        on = np.einsum("ij,ijk->ik", w, V[F[f]])
        n = mesh.face_normals[f]
        P = np.vstack([on, on + rng.normal(scale=1e-6, size=on.shape),
                       on + 6.0 * n, on - 6.0 * n, V[:nu * nv] + 6.0 * mesh.vertex_normals[
                           :nu * nv], V[:nu * nv]])
        with backend.numpy_only():
            ref = NearestFaces(mesh).query(P)
        for threads in (1, 2):
            with parallel(threads):
                got = NearestFaces(mesh).query(P)
            for g, r in zip(got, ref, strict=True):
                np.testing.assert_array_equal(g, r)
