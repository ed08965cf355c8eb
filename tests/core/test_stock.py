"""The in-process stock (core/stock): removed volumes against exact values, a planted gouge
found where it is, crashes, the interval kernels against brute force, saved states.

The exact values: a flat end mill Ø3 with its axis along the blisk axis, its bottom 2 mm
below a flat face of the blank, moved sideways L mm removes 2 (2 R L + π R²); a ball
plunged d ≥ R below a flat face removes ⅔ π R³ + π R² (d − R); a ball swept along a curve
inside the material (curvature < 1/R, no self-overlap) adds π R² per mm of its centre's path
(the tube formula) — here a helix about the blisk axis with the tool axis turning along the
tangent (5-axis), measured between two states so that the ends cancel.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from blisk_cam.core.errors import StockError
from blisk_cam.core.geometry.axis import Axis
from blisk_cam.core.stock.blank import stock_from_profile
from blisk_cam.core.stock.deviation import deviation_map
from blisk_cam.core.stock.dexels import RadialDexels, merge_intervals, subtract_intervals
from blisk_cam.core.stock.removal import ray_solid_intervals, remove_program
from blisk_cam.core.tool.cutter import Cutter
from blisk_cam.core.toolpath.types import MOVE_CUT, MOVE_RAPID, Program

RES = 0.05
BLANK = [[10.0, 0.0], [30.0, 0.0], [30.0, 10.0], [10.0, 10.0]]  # annulus r 10..30, z 0..10


def program(tips, axes, moves=None) -> Program:
    tips = np.asarray(tips, float)
    m = len(tips)
    axes = np.broadcast_to(np.asarray(axes, float), (m, 3)).copy()
    moves = np.full(m, MOVE_CUT) if moves is None else np.asarray(moves)
    return Program(tips, axes, moves.astype(np.int8), np.full(m, -1), np.full(m, -1),
                   np.zeros(m, np.uint8))


def blank(res=RES, n=4):
    return stock_from_profile(BLANK, Axis(), n, 0.0, res)


def test_blank_volume_exact():
    s = blank(0.1)
    assert math.isclose(s.volume(), math.pi * (30**2 - 10**2) * 10 / 4, rel_tol=1e-12)


def test_flat_slot_volume():
    s = blank()
    v0 = s.volume()
    R = 1.5
    r = remove_program(s, program([[18, 8, 8], [22, 10, 8]], [0, 0, 1]), Cutter.flat(R),
                       check_body=False)
    exact = 2.0 * (2 * R * math.hypot(4, 2) + math.pi * R * R)
    assert abs(r.volume / exact - 1) < 0.01
    assert math.isclose(v0 - s.volume(), r.volume, rel_tol=1e-9)
    assert not r.crashes


def test_ball_plunge_volume():
    s = blank()
    R, d = 1.0, 3.0
    r = remove_program(s, program([[15, 15, 12], [15, 15, 10 - d]], [0, 0, 1],
                                  [MOVE_RAPID, MOVE_CUT]), Cutter.ball(R), check_body=False)
    exact = 2.0 / 3.0 * math.pi * R**3 + math.pi * R * R * (d - R)
    assert abs(r.volume / exact - 1) < 0.01
    assert r.removed["cut"] == r.volume and not r.crashes  # the rapid ends in the air


def _helix(n=121):
    Rc, pz, R = 15.0, 4.0, 1.0
    t = np.linspace(math.radians(15), math.radians(75), n)
    c = np.stack([Rc * np.cos(t), Rc * np.sin(t), 5.0 - 4.0 + pz * (t - t[0])], 1)
    tan = np.stack([-Rc * np.sin(t), Rc * np.cos(t), np.full_like(t, pz)], 1)
    ax = -tan / np.linalg.norm(tan, axis=1)[:, None]
    return c - R * ax, ax, R


def test_five_axis_ball_sweep_along_helix():
    tips, ax, R = _helix()
    s = stock_from_profile([[12, 0], [18, 0], [18, 10], [12, 10]], Axis(), 4, 0.0, RES)
    ball = Cutter.ball(R, h=1.02 * R)  # the flute's cylinder trails inside the tube
    k, m = 20, 100
    remove_program(s, program(tips[:k + 1], ax[:k + 1]), ball, check_body=False)
    v1 = s.volume()
    remove_program(s, program(tips[k:m + 1], ax[k:m + 1]), ball, check_body=False)
    removed = v1 - s.volume()
    # the centre's path (tip linear, axis slerp), measured densely
    length = 0.0
    u = np.linspace(0, 1, 400)[:, None]
    for j in range(k, m):
        om = math.acos(np.clip(ax[j] @ ax[j + 1], -1, 1))
        a = (np.sin((1 - u) * om) * ax[j] + np.sin(u * om) * ax[j + 1]) / math.sin(om)
        cc = tips[j] + (tips[j + 1] - tips[j]) * u + R * a
        length += np.linalg.norm(np.diff(cc, axis=0), axis=1).sum()
    exact = math.pi * R * R * length
    assert abs(removed / exact - 1) < 0.01


def test_planted_gouge_found_in_place():
    # the blank's outer face r = 30 is the "part" surface; a ball dips 0.05 mm into it
    res = 0.025
    s = stock_from_profile([[25, 3], [30, 3], [30, 7], [25, 7]], Axis(), 24, 0.0, res)
    th0, z0, depth, R = math.radians(7.3), 5.1, 0.05, 2.0
    e = np.array([math.cos(th0), math.sin(th0), 0.0])
    tip = np.array([0, 0, z0]) + (30.0 - depth) * e
    r = remove_program(s, program([tip + 0.5 * e, tip, tip + 0.5 * e], e, [MOVE_RAPID, MOVE_CUT,
                                                                        MOVE_CUT]),
                       Cutter.ball(R), check_body=False)
    assert r.volume > 0 and not r.crashes
    th, z = np.meshgrid(np.radians(np.linspace(4, 11, 61)), np.linspace(3.5, 6.5, 61))
    P = np.stack([30 * np.cos(th), 30 * np.sin(th), z], -1).reshape(-1, 3)
    N = P * [1, 1, 0] / 30.0
    dev = deviation_map(s, P, N, reach_out=0.5, reach_in=0.5)
    i = int(np.argmin(dev))
    assert abs(dev[i] + depth) <= res
    assert np.linalg.norm(P[i] - 30.0 * e - [0, 0, z0]) <= 2 * res
    far = np.linalg.norm(P - (30.0 * e + [0, 0, z0]), axis=1) > 1.0
    assert np.all(np.abs(dev[far]) <= 1e-3)  # the untouched face: no deviation


def test_rapid_through_stock_is_a_crash():
    s = blank(0.2)
    moves = [MOVE_RAPID, MOVE_RAPID, MOVE_RAPID, MOVE_CUT]
    tips = [[20, 5, 15], [20, 5, 12], [20, 5, 8], [20, 5, 15]]  # row 2 dives 2 mm into it
    r = remove_program(s, program(tips, [0, 0, 1], moves), Cutter.ball(2.0), check_body=False)
    assert [(c.row, c.kind) for c in r.crashes] == [(2, "rapid")]
    # the ball's lower half went below the face z = 10
    assert r.crashes[0].volume == pytest.approx(2.0 / 3.0 * math.pi * 2.0**3, rel=0.02)
    assert r.removed["rapid"] == pytest.approx(r.crashes[0].volume)


def test_body_removing_material_is_a_crash():
    s = blank(0.2)
    # flute 3 mm, shank Ø4 over a Ø2 ball: plunging 5 mm buries 2 mm of the shank
    ball = Cutter.ball(1.0, h=3.0, shank_diameter=4.0)
    r = remove_program(s, program([[20, 5, 15], [20, 5, 5]], [0, 0, 1],
                                  [MOVE_RAPID, MOVE_CUT]), ball)
    assert [(c.row, c.kind) for c in r.crashes] == [(1, "body")]
    # the shank's ring outside the flute's hole, 2 mm high
    assert r.crashes[0].volume == pytest.approx(math.pi * (2.0**2 - 1.0**2) * 2.0, rel=0.03)
    # a shank no wider than the flute follows in the flute's hole: no crash
    s = blank(0.2)
    r = remove_program(s, program([[20, 5, 15], [20, 5, 5]], [0, 0, 1],
                                  [MOVE_RAPID, MOVE_CUT]), Cutter.ball(1.0, h=3.0))
    assert not r.crashes


def test_holder_along_the_blades_meets_the_neighbouring_sectors():
    """A Ø6 holder lying along the blades (the axis at x = 20 mm pointing along y, sloping
    down 1 in 8) dips into the annulus' top face only 38°–54° from the tip's angle — beyond the
    first 15° sector of 24 from its start: the body crash is found, with the volume of the
    holder below the face integrated exactly per (x, y) column (the quadratic in z of the
    cylinder, the linear bounds of its ends)."""
    tip = np.array([20.0, 0.0, 15.0])
    ax = np.array([0.0, 1.0, -0.125]) / math.hypot(1.0, 0.125)
    tool = Cutter.ball(1.0, h=3.0, shank_diameter=2.0, holder_diameter=6.0, holder_length=25.0)
    t0, t1 = 3.0 + 2.0 * 2.0, 3.0 + 2.0 * 2.0 + 25.0  # the holder: above flute and shank
    g = 0.02
    x, y = np.meshgrid(np.arange(16.0, 24.0, g) + g / 2, np.arange(10.0, 26.0, g) + g / 2)
    x, y = x.ravel(), y.ravel()
    w = np.stack([x, y, np.zeros_like(x)], 1) - tip  # P(z) − tip = w + z ez
    wt, zt = w @ ax, ax[2]
    # ρ² = |w + z ez|² − (wt + z zt)² ≤ 9: a z² + b z + c ≤ 0
    a, b, c = 1.0 - zt * zt, 2.0 * (w[:, 2] - wt * zt), (w * w).sum(1) - wt * wt - 9.0
    disc = np.maximum(b * b - 4.0 * a * c, 0.0)
    lo, hi = (-b - np.sqrt(disc)) / (2 * a), (-b + np.sqrt(disc)) / (2 * a)
    # t0 ≤ wt + z zt ≤ t1 (zt < 0), 0 ≤ z ≤ 10, the annulus
    lo = np.maximum.reduce([lo, (t1 - wt) / zt, np.zeros_like(lo)])
    hi = np.minimum.reduce([hi, (t0 - wt) / zt, np.full_like(hi, 10.0)])
    r = np.hypot(x, y)
    exact = float(np.where((r >= 10.0) & (r <= 30.0), np.maximum(hi - lo, 0.0), 0.0).sum()) * g * g
    s = blank(RES, n=24)
    prog = program([tip + [0.0, 0.0, 10.0], tip], ax, [MOVE_RAPID, MOVE_CUT])
    r = remove_program(s, prog, tool)
    assert [(c.row, c.kind) for c in r.crashes] == [(1, "body")]
    assert exact > 1.0
    assert r.crashes[0].volume == pytest.approx(exact, rel=0.02)


def test_ray_solid_intervals_match_point_classification():
    rng = np.random.default_rng(3)
    for cutter in (Cutter.ball(2.0), Cutter.bull(3.0, 1.0), Cutter.flat(2.5),
                   Cutter.taper(2.0, math.radians(5.0))):
        from blisk_cam.core.stock.removal import cutter_halfplanes

        planes = cutter_halfplanes(cutter, 1e-4)
        k = 400
        th = rng.uniform(0, 2 * math.pi, k)
        u = np.stack([np.cos(th), np.sin(th), np.zeros(k)], 1)
        O = np.stack([np.zeros(k), np.zeros(k), rng.uniform(-3, 3, k)], 1)
        tip = u * rng.uniform(8, 12, k)[:, None] + rng.normal(0, 1, (k, 3))
        ax = rng.normal(0, 1, (k, 3))
        ax /= np.linalg.norm(ax, axis=1)[:, None]
        lo, hi = ray_solid_intervals(O, u, tip, ax, planes)
        r = np.linspace(0, 25, 2501)
        pts = O[:, None] + r[None, :, None] * u[:, None]
        sd = cutter.signed_distance(pts.reshape(-1, 3), np.repeat(tip, len(r), 0),
                                    np.repeat(ax, len(r), 0)).reshape(k, len(r))
        inside = sd < -2e-3
        outside = sd > 2e-3
        got = (r[None] >= lo[:, None]) & (r[None] <= hi[:, None])
        assert not (inside & ~got).any(), cutter.type
        assert not (outside & got).any(), cutter.type


def test_interval_kernels_match_brute_force():
    rng = np.random.default_rng(5)
    n = 50
    lo = np.zeros((n, 2))
    hi = np.zeros((n, 2))
    lo[:, 0], hi[:, 0] = 1.0, 4.0
    lo[:, 1], hi[:, 1] = 6.0, 9.0
    grid = np.linspace(0, 10, 10001)[:-1] + 5e-4
    mat = ((grid >= lo[:, :1]) & (grid < hi[:, :1])) | ((grid >= lo[:, 1:]) & (grid < hi[:, 1:]))
    rays = rng.integers(0, n, 300)
    a = rng.uniform(0, 10, 300)
    b = a + rng.uniform(0, 2, 300)
    mr, ma, mb, rank = merge_intervals(rays, a, b)
    for k in range(int(rank.max()) + 1):
        sel = rank == k
        lo, hi, _ = subtract_intervals(lo, hi, mr[sel], ma[sel], mb[sel])
    for ray, x0, x1 in zip(rays, a, b, strict=True):
        mat[ray] &= ~((grid >= x0) & (grid < x1))
    got = np.zeros_like(mat)
    for j in range(lo.shape[1]):
        got |= (grid >= lo[:, j:j + 1]) & (grid < hi[:, j:j + 1])
    assert (got != mat).sum() <= 2 * len(rays)  # only samples at an interval's very end


def test_state_round_trip_and_errors(tmp_path):
    s = blank(0.5)
    remove_program(s, program([[18, 8, 8], [22, 10, 8]], [0, 0, 1]), Cutter.flat(1.5),
                   check_body=False)
    f = s.save(tmp_path / "after_roughing.npz")
    t = RadialDexels.load(f)
    assert t.volume() == s.volume() and np.array_equal(t.lo, s.lo)
    (tmp_path / "junk.npz").write_bytes(b"not a stock")
    with pytest.raises(StockError, match="not a stock state"):
        RadialDexels.load(tmp_path / "junk.npz")
    with pytest.raises(StockError, match="resolution"):
        stock_from_profile(BLANK, Axis(), 4, 0.0, 0.0)


def test_crash_tolerance_is_half_the_resolution():
    """A rapid grazing the stock by less than half the resolution removes what it meets but
    is no crash (the stock knows its surface between rays to about that); one reaching
    deeper is, with all it removed as the crash's volume."""
    for dip, crash in ((0.15, False), (1.0, True)):
        s = blank(0.2)  # crash tolerance 0.1 mm; the top rays at z = 9.9
        tips = [[20, 5, 15], [20, 5, 10 - dip], [20, 5, 15]]
        r = remove_program(s, program(tips, [0, 0, 1], [MOVE_RAPID, MOVE_RAPID, MOVE_CUT]),
                           Cutter.ball(2.0), check_body=False)
        assert r.removed["rapid"] > 0
        assert [c.row for c in r.crashes] == ([1] if crash else [])
        if crash:
            cap = math.pi * dip * dip * (2.0 - dip / 3.0)  # the spherical cap below the face
            assert r.crashes[0].volume == pytest.approx(r.removed["rapid"])
            assert r.crashes[0].volume == pytest.approx(cap, rel=0.15)
