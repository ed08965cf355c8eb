"""Crashes thinner than the stock's cells (core/stock/fine_check) and rapids kept clear of the
stock (core/stock/rapid_clearance), on a ring blank (one 10° sector, r 50..60 mm).

The planted crash: a Ø6 ball on a radial axis rapids along the blisk axis with its tip
``DIP`` = 0.3 mm inside the ring's outer face. On a 1 mm stock the crash test (the ball shrunk
by half a cell, 0.5 mm) cannot see it — the job's check before this change; the fine
re-check finds it, as deep as planted, with the volume of the ball's cap swept along the
ring (the circular segment of depth DIP times the ring's height).
"""

from __future__ import annotations

import math

import numpy as np

from blisk_cam.core.geometry.axis import Axis
from blisk_cam.core.stock import rapid_clearance
from blisk_cam.core.stock.blank import stock_from_profile
from blisk_cam.core.stock.fine_check import FineCheck
from blisk_cam.core.stock.rapid_clearance import clear_rapids, cutter_meets_stock
from blisk_cam.core.stock.removal import remove_program
from blisk_cam.core.tool.assembly import ToolAssembly
from blisk_cam.core.tool.cutter import Cutter
from blisk_cam.core.toolpath.types import (
    MOVE_APPROACH,
    MOVE_CUT,
    MOVE_RAPID,
    MOVE_RETRACT,
    Program,
)

RHO = 3.0
DIP = 0.3
RING = [[50.0, 0.0], [60.0, 0.0], [60.0, 10.0], [50.0, 10.0]]
BLADES = 36  # a 10° sector
THETA0 = -math.radians(5.0)  # θ = 0 in its middle


def _stock(poly, res):
    return stock_from_profile(poly, Axis(), BLADES, THETA0, res)


def _program(tips, axes, moves) -> Program:
    m = len(tips)
    return Program(np.asarray(tips, float), np.asarray(axes, float),
                   np.asarray(moves, np.int8), np.full(m, -1), np.full(m, -1),
                   np.zeros(m, np.uint8))


def _grazing_rapid() -> Program:
    r = 60.0 - DIP
    tips = [[r, 0.0, -6.0], [r, 0.0, 16.0]]
    return _program(tips, [[1.0, 0.0, 0.0]] * 2, [MOVE_RAPID, MOVE_RAPID])


def test_a_rapid_thinner_than_the_cell_is_caught_by_the_fine_check():
    ball = Cutter.from_spec("ball", RHO)
    coarse = _stock(RING, 1.0)
    prog = _grazing_rapid()
    near: list = []
    res = remove_program(coarse, prog, ball, near=near)
    assert res.crashes == []  # the coarse check alone (the job's before) misses it
    assert {(row, kind) for row, kind, _ in near} == {(1, "rapid")}
    found = FineCheck(_stock(RING, 0.1), []).crashes(coarse, prog, ball, None, near)
    assert [(c.row, c.kind) for c in found] == [(1, "rapid")]
    c = found[0]
    assert c.resolution == 0.1
    assert abs(c.depth - DIP) <= 0.05
    # the cap of the ball below the ring's face (a circular segment of depth DIP, the ring's
    # convexity neglected: it takes < 1 %) swept over the ring's 10 mm height
    seg = RHO ** 2 * math.acos((RHO - DIP) / RHO) - (RHO - DIP) * math.sqrt(2 * RHO * DIP
                                                                            - DIP ** 2)
    assert abs(c.volume - 10.0 * seg) <= 0.15 * 10.0 * seg


def test_a_body_graze_thinner_than_the_cell_is_caught_by_the_fine_check():
    """A pose whose Ø8 shank, parallel to the blisk axis, dips DIP into the ring's outer face
    over its whole height (the flute below the ring): the body's volume in the ring is the
    lens of the two circles (shank, ring) times the ring's 10 mm."""
    ball = Cutter.from_spec("ball", RHO)
    rs = 4.0
    body = ToolAssembly(ball.h, ((ball.h, rs), (ball.h + 40.0, rs)))
    d = 60.0 + rs - DIP
    prog = _program([[d, 0.0, -ball.h - 5.0]], [[0.0, 0.0, 1.0]], [MOVE_CUT])
    coarse = _stock(RING, 1.0)
    near: list = []
    res = remove_program(coarse, prog, ball, body, near=near)
    assert res.crashes == []  # the job's check before: the body shrunk by 0.5 mm misses it
    found = FineCheck(_stock(RING, 0.1), []).crashes(coarse, prog, ball, body, near)
    assert [(c.row, c.kind) for c in found] == [(0, "body")]
    R = 60.0
    lens = (rs ** 2 * math.acos((d * d + rs * rs - R * R) / (2 * d * rs))
            + R ** 2 * math.acos((d * d + R * R - rs * rs) / (2 * d * R))
            - 0.5 * math.sqrt((-d + rs + R) * (d + rs - R) * (d - rs + R) * (d + rs + R)))
    assert abs(found[0].volume - 10.0 * lens) <= 0.15 * 10.0 * lens
    assert abs(found[0].depth - DIP) <= 0.05


def test_a_rapid_clear_of_the_stock_is_not_near():
    ball = Cutter.from_spec("ball", RHO)
    prog = _grazing_rapid()
    prog.tip[:, 0] = 60.0 + 0.6  # 0.6 mm outside the ring
    near: list = []
    res = remove_program(_stock(RING, 1.0), prog, ball, near=near)
    assert res.crashes == [] and near == []


# a ring with a 2 mm ridge round z 3..7: stock a finishing pass's approach distance does not
# clear
RIDGE = [[50.0, 0.0], [60.0, 0.0], [60.0, 3.0], [62.0, 3.0], [62.0, 7.0], [60.0, 7.0],
         [60.0, 10.0], [50.0, 10.0]]


def _route(r_up: float) -> Program:
    """A cut at z 1, a retract 1 mm up the radial axis, a straight rapid to above z 9 (over
    the ridge), an approach down to the next cut."""
    th = math.radians(1.0)
    a0 = [1.0, 0.0, 0.0]
    a1 = [math.cos(th), math.sin(th), 0.0]
    tips = [[60.0, 0.0, 1.0], [r_up, 0.0, 1.0],
            [r_up * a1[0], r_up * a1[1], 9.0], [60.0 * a1[0], 60.0 * a1[1], 9.0]]
    return _program(tips, [a0, a0, a1, a1], [MOVE_CUT, MOVE_RETRACT, MOVE_RAPID, MOVE_APPROACH])


def _ball_reach(prog: Program, rows, n: int = 400):
    """The least radius (mm) the ball reaches along the moves ending at ``rows`` where it is
    over the ridge's heights (z within 3 − ρ … 7 + ρ): centre radius − ρ, sampled."""
    out = math.inf
    for j in rows:
        t = np.linspace(0.0, 1.0, n)[:, None]
        tip = prog.tip[j - 1] + t * (prog.tip[j] - prog.tip[j - 1])
        ax = prog.axis[j - 1] + t * (prog.axis[j] - prog.axis[j - 1])
        ax /= np.linalg.norm(ax, axis=1)[:, None]
        c = tip + RHO * ax
        over = (c[:, 2] > 3.0 - RHO) & (c[:, 2] < 7.0 + RHO)
        if over.any():
            out = min(out, float((np.hypot(c[over, 0], c[over, 1]) - RHO).min()))
    return out


def test_clear_rapids_lifts_the_route_out_of_the_stock_along_the_tool_axes():
    ball = Cutter.from_spec("ball", RHO)
    stock = _stock(RIDGE, 0.25)
    prog = _route(61.0)
    assert _ball_reach(prog, [2]) < 62.0  # the rapid runs through the ridge
    margin = 0.5
    out, info = clear_rapids(prog, stock, ball, margin=margin)
    assert info["moved"] == 1 and info["still_meeting"] == 0
    lift = out.tip - prog.tip
    # the cut and the approach's end stay; the two points move out along their own axes
    assert np.allclose(lift[[0, 3]], 0.0)
    for j in (1, 2):
        s = float(np.linalg.norm(lift[j]))
        assert np.allclose(lift[j], s * prog.axis[j], atol=1e-9)
    # the rapid now clears the ridge by the margin, to the grid's half cell and one step
    assert _ball_reach(out, [2]) >= 62.0 + margin - 0.125 - 1e-9
    assert s <= 62.0 + margin - 61.0 + 2 * 0.125 + 0.125 + 1e-9  # the least lift that does
    # the same route already above the ridge is left as it is
    high = _route(63.0)
    again, info = clear_rapids(high, stock, ball, margin=margin)
    assert info["moved"] == 0 and np.array_equal(again.tip, high.tip)


def test_the_cutter_meets_the_stock_alike_compiled_and_numpy(monkeypatch):
    """The posed cutter's test against the stock: the compiled kernel's per-pose measure and
    numpy's intervals tell the same poses (random ones round the ridge)."""
    ball = Cutter.from_spec("ball", RHO)
    stock = _stock(RIDGE, 0.25)
    rng = np.random.default_rng(1)
    tips = np.column_stack([rng.uniform(58, 66, 200), rng.uniform(-3, 3, 200),
                            rng.uniform(-4, 14, 200)])
    axes = np.tile([1.0, 0.0, 0.0], (200, 1))
    first = cutter_meets_stock(stock, ball, tips, axes, 0.5)
    monkeypatch.setattr(rapid_clearance.compiled_stock, "available", lambda: False)
    second = cutter_meets_stock(stock, ball, tips, axes, 0.5)
    assert 0 < first.sum() < len(first)
    assert np.array_equal(first, second)
    # and against the ridge's own geometry: a pose whose grown ball (centre radius − ρ −
    # margin) stays beyond r 62 over the ridge's heights, or beyond 60 elsewhere, is clear
    c = tips + RHO * axes
    reach = np.hypot(c[:, 0], c[:, 1]) - RHO - 0.5
    z_in = (c[:, 2] > 3.0 - RHO - 0.5) & (c[:, 2] < 7.0 + RHO + 0.5)
    clear = np.where(z_in, reach > 62.0 + 0.25, reach > 60.0 + 0.25)
    assert not (first & clear).any()
