"""The cone gizmos' math without Blender (``blisk_cam.gizmos.cone_frame``) and the live LMC
preview cache (``blisk_cam.gizmos.lmc_preview``).

Handle matrices ↔ cone end points are checked against the core's own meridional coordinates
(``core.geometry.axis.meridional``), for random axes, half-plane angles and unit scales; draw
geometry is checked to lie on the cones it draws; the preview's curves to lie on their LMCs.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from blisk_cam.core.errors import BliskCamError, MeshError
from blisk_cam.core.geometry.axis import Axis, meridional
from blisk_cam.core.part.cones import Cone, MorphingCones
from blisk_cam.gizmos import cone_frame as cf
from blisk_cam.gizmos.lmc_preview import DEFAULT_LEVELS, LmcPreview, Throttle

ROOT = Path(__file__).resolve().parents[2]

finite = st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False)
unit_vec = st.tuples(finite, finite, finite).filter(lambda v: np.linalg.norm(v) > 1e-3)
angle = st.floats(-10.0, 10.0, allow_nan=False, allow_infinity=False)
scale = st.sampled_from([1.0, 10.0, 25.4, 1000.0, 0.5])
radius = st.floats(0.0, 500.0, allow_nan=False, allow_infinity=False)
height = st.floats(-500.0, 500.0, allow_nan=False, allow_infinity=False)

FAST = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def angle_diff(a, b):
    return abs((a - b + math.pi) % (2.0 * math.pi) - math.pi)


# --- frame and matrices ------------------------------------------------------------------
@FAST
@given(o=st.tuples(finite, finite, finite), d=unit_vec, theta=angle, f=scale, r=radius, z=height)
def test_handle_matrix_round_trip_and_meridional_position(o, d, theta, f, r, z):
    axis = Axis(o, d)
    plane = cf.MeridionalPlane(axis, theta, f)
    M = plane.handle_matrix(r, z)
    R = M[:3, :3]
    # a rigid frame: orthonormal, right-handed; local Y is the axis, local Z the plane normal
    assert np.allclose(R.T @ R, np.eye(3), atol=1e-12)
    assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-12)
    assert np.allclose(R[:, 1], axis.d, atol=1e-12)
    assert np.allclose(M[3], [0, 0, 0, 1])
    # the translation (BU) in mm has the core's meridional coordinates (r, z)
    p_mm = M[:3, 3] * f
    rr, zz = meridional(p_mm[None], axis)
    tol = 1e-9 * (1.0 + np.abs(o).max() + abs(r) + abs(z))
    assert rr[0] == pytest.approx(r, abs=tol)
    assert zz[0] == pytest.approx(z, abs=tol)
    # ... and lies in the half-plane at θ about the axis
    if r > 1e-3:
        assert angle_diff(cf.half_plane_angle(axis, p_mm), theta) < 1e-7
    # back: matrix → (r, z)
    r2, z2 = plane.matrix_to_rz(M)
    assert r2 == pytest.approx(r, abs=tol) and z2 == pytest.approx(z, abs=tol)


@FAST
@given(
    o=st.tuples(finite, finite, finite), d=unit_vec, theta=angle, f=scale, r=radius, z=height,
    k=st.floats(-300.0, 300.0, allow_nan=False),
)
def test_dragged_point_is_projected_into_the_half_plane(o, d, theta, f, r, z, k):
    """A point off the plane (by k mm along its normal) comes back as the (r, z) it is above."""
    axis = Axis(o, d)
    plane = cf.MeridionalPlane(axis, theta, f)
    p = plane.to_world(r, z) + k * plane.normal / f
    tol = 1e-9 * (1.0 + np.abs(o).max() + abs(r) + abs(z) + abs(k))
    assert plane.out_of_plane(p) == pytest.approx(k, abs=tol)
    r2, z2 = plane.from_world(p)
    assert r2 == pytest.approx(r, abs=tol) and z2 == pytest.approx(z, abs=tol)


@FAST
@given(
    o=st.tuples(finite, finite, finite), d=unit_vec, theta=angle, r=st.floats(1e-3, 400.0),
    z=height,
)
def test_point_beyond_the_axis_is_clamped_to_r_zero(o, d, theta, r, z):
    axis = Axis(o, d)
    plane = cf.MeridionalPlane(axis, theta)
    p = plane.to_world(-r, z)  # the opposite half-plane
    r2, z2 = plane.from_world(p)
    assert r2 == 0.0
    assert z2 == pytest.approx(z, abs=1e-9 * (1 + np.abs(o).max() + r + abs(z)))
    r3, _ = plane.from_world(p, clamp=False)
    assert r3 == pytest.approx(-r, abs=1e-9 * (1 + np.abs(o).max() + r + abs(z)))


def test_vectorised_world_round_trip():
    rng = np.random.default_rng(1)
    axis = Axis((10.0, -5.0, 3.0), (0.3, -0.2, 0.9))
    plane = cf.MeridionalPlane(axis, 2.0, 25.4)
    r = rng.uniform(0, 300, 50)
    z = rng.uniform(-100, 100, 50)
    P = plane.to_world(r, z)
    assert P.shape == (50, 3)
    r2, z2 = plane.from_world(P)
    assert np.allclose(r2, r, atol=1e-9) and np.allclose(z2, z, atol=1e-9)
    rr, zz = meridional(P * 25.4, axis)
    assert np.allclose(rr, r, atol=1e-9) and np.allclose(zz, z, atol=1e-9)


def test_axis_frame_matches_the_usual_angle_for_z():
    axis = Axis()
    e1, e2, d = cf.axis_frame(axis)
    assert np.allclose([e1, e2, d], np.eye(3))
    for th in (0.3, 2.5, -1.2):
        p = [100 * math.cos(th), 100 * math.sin(th), 7.0]
        assert cf.half_plane_angle(axis, p) == pytest.approx(th)
    assert cf.half_plane_angle(axis, [0.0, 0.0, 50.0]) == 0.0  # on the axis
    # an axis along world X: e1 falls back to Y projected, still orthonormal
    e1, e2, d = cf.axis_frame(Axis(direction=(1.0, 0.0, 0.0)))
    F = np.stack([e1, e2, d])
    assert np.allclose(F @ F.T, np.eye(3)) and np.linalg.det(F) == pytest.approx(1.0)


def test_handle_matrices_name_the_right_numbers():
    plane = cf.MeridionalPlane(Axis((1.0, 2.0, 3.0), (0.0, 1.0, 1.0)), 0.7, 10.0)
    c1, c2 = (150.0, -25.0, 165.0, 35.0), (215.0, -24.0, 225.0, 36.0)
    mats = plane.handle_matrices(c1, c2)
    assert sorted(mats) == ["P1", "P2", "Q1", "Q2"]
    expect = {"P1": c1[:2], "P2": c1[2:], "Q1": c2[:2], "Q2": c2[2:]}
    for name, M in mats.items():
        assert plane.matrix_to_rz(M) == pytest.approx(expect[name], abs=1e-9)
        h = cf.handle(name)
        vals = c1 if h.prop == "cone1" else c2
        assert (vals[h.indices[0]], vals[h.indices[1]]) == expect[name]


# --- dragging: rays and constraints --------------------------------------------------------
@FAST
@given(
    d=unit_vec, theta=angle, f=scale, r=radius, z=height, u=unit_vec,
    t=st.floats(1.0, 1e3, allow_nan=False),
)
def test_view_ray_meets_the_plane_at_the_point_it_was_cast_through(d, theta, f, r, z, u, t):
    axis = Axis((5.0, -3.0, 2.0), d)
    plane = cf.MeridionalPlane(axis, theta, f)
    u = np.asarray(u) / np.linalg.norm(u)
    cos = abs(float(u @ plane.normal))
    X = plane.to_world(r, z)
    origin = X - t * u
    hit = plane.intersect_ray(origin, u, forward_only=True)
    if cos < 1e-6:
        assert hit is None
        return
    assert hit is not None
    scale_ = 1.0 + np.abs(X).max() + t
    assert np.allclose(hit, X, atol=1e-7 * scale_ / cos)
    # looking away from the plane (perspective): nothing; orthographic: the whole line
    assert plane.intersect_ray(X + t * u, u, forward_only=True) is None
    assert np.allclose(plane.intersect_ray(X + t * u, u), X, atol=1e-7 * scale_ / cos)


def test_ray_parallel_to_the_plane_gives_none():
    plane = cf.MeridionalPlane(Axis(), 0.0)
    # plane through the Z axis at θ = 0 is the XZ plane; a ray along X never meets it twice
    assert plane.intersect_ray([0.0, 5.0, 0.0], [1.0, 0.0, 0.0]) is None
    assert plane.intersect_ray([0.0, 5.0, 0.0], [1.0, 0.01, 0.0], min_cos=0.05) is None
    hit = plane.intersect_ray([0.0, 5.0, 0.0], [1.0, -1.0, 0.0])
    assert np.allclose(hit, [5.0, 0.0, 0.0])


def test_move_end_point_writes_only_its_two_numbers_and_keeps_the_cone_valid():
    c = (150.0, -25.0, 165.0, 35.0)
    assert cf.move_end_point(c, 0, 151.0, -20.0) == (151.0, -20.0, 165.0, 35.0)
    assert cf.move_end_point(c, 1, 170.0, 40.0) == (150.0, -25.0, 170.0, 40.0)
    assert cf.move_end_point(c, 0, -4.0, -20.0) == (0.0, -20.0, 165.0, 35.0)  # r ≥ 0
    # onto the other end point: refused (the generatrix would vanish)
    assert cf.move_end_point(c, 0, 165.0, 35.0) is None
    assert cf.move_end_point(c, 1, 150.0 + 1e-4, -25.0) is None
    out = cf.move_end_point(c, 1, 150.0, -25.0 + 2 * cf.MIN_GENERATRIX)
    assert out is not None and cf.is_cone_set(out)
    with pytest.raises(cf.GizmoError, match="0 .*or 1"):
        cf.move_end_point(c, 2, 1.0, 1.0)
    with pytest.raises(cf.GizmoError, match="finite"):
        cf.move_end_point(c, 0, float("nan"), 1.0)


def test_is_cone_set_and_pair_problem():
    assert not cf.is_cone_set((0.0, 0.0, 0.0, 0.0))  # the unset default
    assert not cf.is_cone_set((-1.0, 0.0, 5.0, 5.0))
    assert cf.is_cone_set((0.0, 0.0, 5.0, 5.0))
    assert cf.pair_problem((150, -25, 165, 35), (215, -25, 225, 35)) is None
    crossing = cf.pair_problem((150, -25, 225, 35), (215, -25, 165, 35))
    assert crossing and "cross" in crossing


# --- draw geometry ------------------------------------------------------------------------
@FAST
@given(
    o=st.tuples(finite, finite, finite), d=unit_vec, theta=angle, f=scale,
    r1=st.floats(0.0, 300.0), z1=height, r2=st.floats(0.0, 300.0), z2=height,
)
def test_cone_wire_lines_lie_on_the_cone(o, d, theta, f, r1, z1, r2, z2):
    if math.hypot(r2 - r1, z2 - z1) < 1e-3:
        return
    axis = Axis(o, d)
    plane = cf.MeridionalPlane(axis, theta, f)
    cone = Cone(r1, z1, r2, z2)
    L = cf.cone_wire_lines(plane, cone, generatrices=6, circle_segments=24)
    n_circles = (r1 > 0) + (r2 > 0)
    assert L.shape == (2 * (6 + 24 * n_circles), 3)
    rr, zz = meridional(L * f, axis)
    tol = 1e-8 * (1.0 + np.abs(o).max() + 300 + 500)
    # on the generatrix line, and inside the segment's (r, z) box
    assert np.all(np.abs(cone.signed_distance(rr, zz)) < tol)
    assert np.all((zz >= min(z1, z2) - tol) & (zz <= max(z1, z2) + tol))
    assert np.all((rr >= min(r1, r2) - tol) & (rr <= max(r1, r2) + tol))
    # the first generatrix joins the two handles
    M = plane.handle_matrices(cone.as_list(), cone.as_list())
    assert np.allclose(L[0], M["P1"][:3, 3], atol=tol / f)
    assert np.allclose(L[1], M["P2"][:3, 3], atol=tol / f)


def test_circle_segments_close_and_generatrices_spread():
    plane = cf.MeridionalPlane(Axis(), 0.4)
    L = cf.cone_wire_lines(plane, (100.0, 0.0, 120.0, 50.0), generatrices=4, circle_segments=8)
    gen = L[: 2 * 4].reshape(4, 2, 3)
    angles = np.arctan2(gen[:, 0, 1], gen[:, 0, 0])
    assert np.allclose(np.diff(np.unwrap(angles)), math.pi / 2)
    assert angles[0] == pytest.approx(0.4)
    ring = L[8 : 8 + 16].reshape(8, 2, 3)
    assert np.allclose(ring[-1, 1], ring[0, 0])  # closed
    assert np.allclose(np.linalg.norm(ring[:, :, :2], axis=2), 100.0)
    # an end point on the axis draws no circle there
    L0 = cf.cone_wire_lines(plane, (0.0, 0.0, 120.0, 50.0), generatrices=4, circle_segments=8)
    assert len(L0) == 2 * (4 + 8)


def test_polyline_lines_pairs_and_units():
    p = np.array([[0.0, 0, 0], [10, 0, 0], [10, 10, 0]])
    open_ = cf.polyline_lines(p, False, 10.0)
    assert np.allclose(open_, [[0, 0, 0], [1, 0, 0], [1, 0, 0], [1, 1, 0]])
    closed = cf.polyline_lines(p, True)
    assert closed.shape == (6, 3) and np.allclose(closed[-2:], [[10, 10, 0], [0, 0, 0]])
    assert cf.polyline_lines(p[:1], True).shape == (0, 3)


def test_middle_cone_is_the_average_generatrix_also_for_reversed_cone2():
    c1, c2 = (150.0, -25.0, 165.0, 35.0), (215.0, -25.0, 225.0, 35.0)
    m = cf.middle_cone(c1, c2)
    assert m.as_list() == pytest.approx([182.5, -25.0, 195.0, 35.0])
    # cone 2 given Q2 → Q1: the family is the same (core swaps), so is the middle cone
    m2 = cf.middle_cone(c1, (225.0, 35.0, 215.0, -25.0))
    assert m2.as_list() == pytest.approx(m.as_list())
    with pytest.raises(BliskCamError):
        cf.middle_cone(c1, c1)


def test_bad_inputs_raise_gizmo_errors():
    with pytest.raises(cf.GizmoError, match="mm_per_unit"):
        cf.MeridionalPlane(Axis(), 0.0, 0.0)
    with pytest.raises(cf.GizmoError, match="mm_per_unit"):
        cf.MeridionalPlane(Axis(), 0.0, float("nan"))
    with pytest.raises(cf.GizmoError, match="theta"):
        cf.MeridionalPlane(Axis(), float("inf"))
    with pytest.raises(cf.GizmoError, match="Axis"):
        cf.MeridionalPlane((0, 0, 0, 0, 0, 1))
    with pytest.raises(cf.GizmoError, match="P1, P2, Q1 and Q2"):
        cf.handle("R1")
    plane = cf.MeridionalPlane(Axis())
    with pytest.raises(cf.GizmoError, match="4 × 4"):
        plane.matrix_to_rz(np.eye(3))
    with pytest.raises(cf.GizmoError, match="finite"):
        plane.from_world([np.nan, 0.0, 0.0])
    with pytest.raises(cf.GizmoError, match="four finite numbers"):
        plane.handle_matrices((1, 2, 3), (1, 2, 3, 4))
    with pytest.raises(BliskCamError, match="coincide"):
        cf.cone_wire_lines(plane, (5.0, 5.0, 5.0, 5.0))
    with pytest.raises(cf.GizmoError, match="finite 3-vector"):
        cf.ray_plane_intersection([0, 0], [1, 0, 0], [0, 0, 0], [0, 0, 1])
    assert issubclass(cf.GizmoError, BliskCamError)


def test_gizmo_math_and_preview_import_without_blender():
    script = r"""
import importlib, json, sys
class Block:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in {"bpy", "bmesh", "mathutils", "gpu"}:
            raise ImportError(name + " is blocked")
sys.meta_path.insert(0, Block())
import blisk_cam.gizmos.cone_frame, blisk_cam.gizmos.lmc_preview
print(json.dumps(sorted(m for m in sys.modules if m.split(".")[0] in {"bpy", "gpu"})))
"""
    proc = subprocess.run(
        [sys.executable, "-c", script], cwd=ROOT, capture_output=True, text=True, timeout=120,
        stdin=subprocess.DEVNULL,
    )
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout.strip().splitlines()[-1]) == []


# --- live preview cache ---------------------------------------------------------------------
class CountingLoader:
    def __init__(self, V, F):
        self.V, self.F, self.calls = V, F, 0

    def __call__(self):
        self.calls += 1
        return self.V, self.F


@pytest.fixture
def tube_mesh(make_tube):
    """A small analytic blade (tests/support/blades.py): 3k triangles, sections on the LMCs."""
    return make_tube(n_u=64, n_v=24)


def test_preview_curves_lie_on_their_lmcs_and_cover_every_level(tube_mesh):
    V, F, mc = tube_mesh
    axis = Axis()
    preview = LmcPreview()
    load = CountingLoader(V, F)
    res = preview.compute("tube", load, axis, mc.cone1.as_list(), mc.cone2.as_list())
    assert res.error is None
    assert sorted({c.s for c in res.curves}) == pytest.approx(list(DEFAULT_LEVELS))
    assert len(res.level_seconds) == len(DEFAULT_LEVELS) and res.setup_seconds > 0
    for c in res.curves:
        assert c.closed and len(c.points) >= 32  # the tube's section is one closed loop
        r, z = meridional(c.points, axis)
        assert np.abs(mc.cone_at(c.s).signed_distance(r, z)).max() < 1e-6
    # the curve at s = 0 runs along the tube's hub boundary: its points are mesh vertices
    hub = [c for c in res.curves if c.s == 0.0][0]
    dist = np.linalg.norm(hub.points[:, None, :] - V[None, : 64, :], axis=2).min(axis=1)
    assert dist.max() < 1e-9


def test_preview_cache_reuses_mesh_and_result_and_invalidates(tube_mesh):
    V, F, mc = tube_mesh
    axis = Axis()
    preview = LmcPreview(levels=(0.0, 0.5, 1.0))
    load = CountingLoader(V, F)
    c1, c2 = mc.cone1.as_list(), mc.cone2.as_list()
    a = preview.compute("tube", load, axis, c1, c2)
    assert load.calls == 1 and preview.mesh_loads == 1 and a.mesh_seconds > 0
    assert preview.compute("tube", load, axis, c1, c2) is a  # same request: cached result
    assert preview.is_current("tube", axis, c1, c2)
    # new cones: the mesh is reused, only slicing again
    c1b = [c1[0] + 1.0, *c1[1:]]
    b = preview.compute("tube", load, axis, c1b, c2)
    assert b is not a and load.calls == 1 and b.mesh_seconds == 0.0
    assert not preview.is_current("tube", axis, c1, c2)
    # other mesh key or invalidate(): the mesh is read again
    preview.compute("tube-2", load, axis, c1b, c2)
    assert load.calls == 2
    preview.invalidate()
    assert not preview.has_mesh() and preview.result is None
    preview.compute("tube-2", load, axis, c1b, c2)
    assert load.calls == 3 and preview.mesh_loads == 3


def test_preview_reports_bad_cones_and_bad_meshes_instead_of_raising(tube_mesh):
    V, F, mc = tube_mesh
    preview = LmcPreview(levels=(0.5,))
    load = CountingLoader(V, F)
    res = preview.compute("tube", load, Axis(), (100, -10, 140, 30), (140, -10, 100, 30))
    assert res.curves == [] and "cross" in res.error
    assert load.calls == 0  # the cones are checked before the mesh is read

    def broken():
        raise MeshError("the mesh has no faces")

    res = preview.compute("empty", broken, Axis(), mc.cone1.as_list(), mc.cone2.as_list())
    assert res.curves == [] and "no faces" in res.error
    with pytest.raises(BliskCamError, match="ratios in"):
        LmcPreview(levels=(0.0, 1.5))


def test_throttle_allows_one_action_per_interval():
    now = [0.0]
    th = Throttle(0.1, clock=lambda: now[0])
    assert th.ready() and not th.ready()
    now[0] = 0.06
    assert not th.ready() and th.remaining() == pytest.approx(0.04)
    now[0] = 0.1
    assert th.ready() and th.remaining() == pytest.approx(0.1)
    th.reset()
    assert th.remaining() == 0.0 and th.ready()
    with pytest.raises(BliskCamError):
        Throttle(float("nan"))


def test_lmc_preview_uses_the_morphing_family_of_the_core(tube_mesh):
    """The middle preview curve is on the s = 0.5 LMC of the same (possibly swapped) pair the
    path generator would use: a reversed cone 2 gives the same curve."""
    V, F, mc = tube_mesh
    c1, c2 = mc.cone1.as_list(), mc.cone2.as_list()
    rev = [c2[2], c2[3], c2[0], c2[1]]
    a = LmcPreview(levels=(0.5,)).compute("t", CountingLoader(V, F), Axis(), c1, c2)
    b = LmcPreview(levels=(0.5,)).compute("t", CountingLoader(V, F), Axis(), c1, rev)
    assert len(a.curves) == len(b.curves) == 1
    assert np.allclose(a.curves[0].points, b.curves[0].points)
    assert MorphingCones(Cone(*c1), Cone(*rev)).cone2.as_list() == c2


def _curves_by_level(res):
    return [(c.s, c.closed, c.points) for c in res.curves]


def _same_curves(a, b):
    """Same levels, same components in the same order, the same points (bit for bit)."""
    assert [(s, cl, len(p)) for s, cl, p in a] == [(s, cl, len(p)) for s, cl, p in b]
    for (_, _, p), (_, _, q) in zip(a, b, strict=True):
        np.testing.assert_array_equal(p, q)


def test_indexed_preview_equals_slicing_the_whole_mesh(make_tube):
    """The slicer on the faces near the levels gives the curves of the slicer on the whole
    mesh, for cone pairs crossing the blade anywhere (also partly off it), and a drag step
    reusing the levels that did not move gives them too."""
    V, F, mc = make_tube(n_u=96, n_v=40)
    axis = Axis()
    c1, c2 = mc.cone1.as_list(), mc.cone2.as_list()
    rng = np.random.default_rng(7)
    fast, whole = LmcPreview(), LmcPreview(indexed=False)
    pairs = [(c1, c2)]
    for _ in range(6):  # cones moved by up to a few mm, tilted
        pairs.append(([x + rng.uniform(-3, 3) for x in c1], [x + rng.uniform(-3, 3) for x in c2]))
    pairs += [(c1, c2), ([c1[0] + 0.5, *c1[1:]], c2)]  # a drag of P1: s = 1 is reused
    n_reused = []
    for a1, a2 in pairs:
        f = fast.compute("t", CountingLoader(V, F), axis, a1, a2)
        w = whole.compute("t", CountingLoader(V, F), axis, a1, a2)
        assert f.error is None and w.error is None
        assert 0 < f.faces_sliced < len(F) == w.faces_sliced
        _same_curves(_curves_by_level(f), _curves_by_level(w))
        n_reused.append(f.levels_reused)
    assert n_reused[-1] == 1 and fast.mesh_loads == 1 and fast.index_builds == 1
    # levels reused only while their LMC is the same: another axis rebuilds the index
    tilted = Axis(origin=(0.0, 0.0, 0.5))
    f = fast.compute("t", CountingLoader(V, F), tilted, c1, c2)
    w = whole.compute("t", CountingLoader(V, F), tilted, c1, c2)
    assert f.levels_reused == 0 and fast.index_builds == 2
    _same_curves(_curves_by_level(f), _curves_by_level(w))


def test_meridional_index_keeps_every_face_a_level_crosses(make_tube):
    """faces_near ⊇ the faces with vertices on both sides of a level's LMC (brute force over
    every face), and it leaves most faces out."""
    from blisk_cam.core.geometry.mesh import TriMesh
    from blisk_cam.gizmos.lmc_preview import MeridionalIndex

    V, F, mc = make_tube(n_u=96, n_v=40)
    mesh = TriMesh.from_arrays(V, F)
    index = MeridionalIndex(mesh, Axis(), faces_per_cell=4)
    r, z = meridional(mesh.V, Axis())
    levels = (0.0, 0.3, 0.77, 1.0)
    near = index.faces_near(mc, levels, 1e-3)
    assert np.all(np.diff(near) > 0)
    crossing = np.zeros(len(mesh.F), dtype=bool)
    for s in levels:
        f = mc.f(s, r, z)[mesh.F]  # (m, 3) signed distances, mm
        crossing |= (f.min(axis=1) <= 1e-4) & (f.max(axis=1) > 1e-4)
    assert np.isin(np.flatnonzero(crossing), near).all()
    assert crossing.sum() <= len(near) < 0.5 * len(mesh.F)
