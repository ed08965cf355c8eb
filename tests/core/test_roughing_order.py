"""Channel roughing ordered by gap or by level (#23: "order by level or by gap; links,
approaches and retracts that stay clear of stock and part (the stock simulation says so)").

Measured truths, each by a means the planner does not use:

* the order is read back from the rows: the gap of a row from its tip's angle about the
  blisk axis against the same pose of gap 0 (a whole number of pitches, asserted), its level
  from its pass. Posted by level (the program of one gap, its levels linked alone, the post
  running level 1 in every gap, then level 2 …) the (level, gap) keys of the cutting blocks
  never go back; a program that holds three gaps itself (``gaps=3``, both orders) has its
  (gap, level) or (level, gap) keys never going back, every gap every level with the same
  rows;
* between two gaps the tool leaves the channel: only retract, rapid and approach rows lie
  between the last cutting row of one gap and the first of the next (a safe retract and a
  rapid from the safe radius in the posted program), and every straight rapid segment keeps
  its closest point to the axis (closed form) at least the clearance above the blank;
* the stock simulation of the three-gap programs (the periodic blank at 1 mm, both orders)
  reports no crash — no rapid, link or body meets material;
* the post does not repeat a program that already holds several gaps.

Cheap on purpose: the 25 mm test blisk of test_roughing.py, the radial axis (no wall levels),
8 mm levels, 1 mm stations.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from blisk_cam.core.errors import BliskCamError, PostError
from blisk_cam.core.machine.description import load_machine
from blisk_cam.core.part.model import part_from_demo, theta_about
from blisk_cam.core.post.blocks import SAFE, NcOptions, build_blocks
from blisk_cam.core.process.roughing import RoughRequest, plan_roughing
from blisk_cam.core.stock.blank import stock_from_envelope
from blisk_cam.core.stock.removal import remove_program
from blisk_cam.core.toolpath.types import (
    MOVE_APPROACH,
    MOVE_CUT,
    MOVE_RAPID,
    MOVE_RETRACT,
)
from tests.core.test_roughing import _demo, _tool

CLEARANCE = 5.0


@pytest.fixture(scope="module")
def setup():
    part = part_from_demo(_demo())
    return part, stock_from_envelope(part, 2.0, 1.0)


def _plan(setup, order, gaps=None, **kw):
    part, stock = setup
    req = RoughRequest(tool=_tool(), stepover=6.0, depth_per_cut=8.0, follow_blades=False,
                       station_step=1.0, clearance=CLEARANCE, order=order, gaps=gaps, **kw)
    return plan_roughing(part, req, stock)


@pytest.fixture(scope="module")
def by_level(setup):
    return _plan(setup, "level")


@pytest.fixture(scope="module")
def three(setup):
    return {order: _plan(setup, order, gaps=3) for order in ("gap", "level")}


def _gap_level(part, path):
    """(rows, gap, level) of the program's cutting rows: the gap from the angle about the axis
    between the row's tip and the same pose of gap 0 (a whole number of pitches, asserted)."""
    P = path.program
    cut = np.nonzero(P.move == MOVE_CUT)[0]
    n = len(path.curves) // path.stats["gaps_in_program"]
    base = np.array([path.curves[c % n].tip[i] for c, i in zip(P.curve[cut], P.index[cut],
                                                                strict=True)])
    r, th, z = theta_about(P.tip[cut], part.axis)
    r0, th0, z0 = theta_about(base, part.axis)
    np.testing.assert_allclose(np.stack([r, z], 1), np.stack([r0, z0], 1), atol=1e-9)
    turns = ((th - th0) % (2 * math.pi)) / part.pitch
    k = np.round(turns).astype(int)
    assert np.abs(turns - k).max() < 1e-9  # each row is gap 0's pose turned by k pitches
    lv = np.array([int(path.curves[c].s) for c in P.curve[cut]])
    return cut, k % part.blade_count, lv


def _never_back(keys):
    keys = np.asarray(keys)
    d = np.diff(keys, axis=0)
    first = np.where(d[:, 0] != 0, d[:, 0], d[:, 1])
    return bool((first >= 0).all())


def _assert_order(part, path, order, n_gaps):
    cut, gap, lv = _gap_level(part, path)
    assert path.stats["order"] == order and path.stats["gaps_in_program"] == n_gaps
    assert sorted(set(gap.tolist())) == list(range(n_gaps))
    keys = np.stack([gap, lv], 1) if order == "gap" else np.stack([lv, gap], 1)
    assert _never_back(keys), f"the rows are not ordered by {order}"
    counts = {(g, v): int(((gap == g) & (lv == v)).sum()) for g in range(n_gaps)
              for v in np.unique(lv)}
    for v in np.unique(lv):  # every gap gets every level, the same passes
        assert len({counts[(g, v)] for g in range(n_gaps)}) == 1
        assert counts[(0, v)] > 0
    return cut, gap


def _assert_clear_between_gaps(part, stock, path):
    P = path.program
    cut, gap = _gap_level(part, path)[:2]
    top = float(stock.hi.max())
    r, _, _ = theta_about(P.tip, part.axis)
    changes = np.nonzero(np.diff(gap) != 0)[0]
    assert len(changes) >= path.stats["gaps_in_program"] - 1
    for i in changes:
        a, b = cut[i], cut[i + 1]
        between = P.move[a + 1:b]
        assert np.isin(between, (MOVE_RETRACT, MOVE_RAPID, MOVE_APPROACH)).all()
        assert r[a + 1:b].max() >= top + CLEARANCE - 1e-6  # out at the safe radius
    # every rapid's straight segment: its nearest point to the axis, closed form
    j = np.nonzero(P.move == MOVE_RAPID)[0]
    j = j[j > 0]
    o, d = part.axis.o, part.axis.d
    p0, p1 = P.tip[j - 1] - o, P.tip[j] - o
    p0 -= np.outer(p0 @ d, d)
    p1 -= np.outer(p1 @ d, d)
    e = p1 - p0
    t = np.clip(-np.einsum("ij,ij->i", p0, e) / np.maximum(np.einsum("ij,ij->i", e, e), 1e-12),
                0.0, 1.0)
    nearest = np.linalg.norm(p0 + t[:, None] * e, axis=1)
    assert nearest.min() >= top + CLEARANCE - 1e-6, nearest.min()


def test_posted_by_level_a_level_runs_in_every_gap_before_the_next(setup, by_level):
    """The post of a one-gap program ordered by level, read back from its blocks: each pose
    block is its program row turned by the blade's k pitches (measured), the (level, gap)
    keys never go back, every gap gets every level's rows in program order, and before each
    level of each gap a safe retract then a rapid at the safe radius."""
    part, stock = setup
    path = by_level
    s = path.stats
    assert s["order"] == "level" and s["gaps_in_program"] == 1
    P = path.program
    n = part.blade_count
    blocks = build_blocks(path, load_machine("ac-trunnion"), NcOptions(blades=n), solve=False)
    assert blocks.blades == n and not blocks.indexed
    pose = blocks.kind != SAFE
    src, gap = blocks.source[pose], blocks.blade[pose]
    r0, th0, z0 = theta_about(P.tip[src], part.axis)
    r1, th1, z1 = theta_about(blocks.tip[pose], part.axis)
    np.testing.assert_allclose(np.stack([r1, z1], 1), np.stack([r0, z0], 1), atol=1e-9)
    turns = ((th1 - th0) % (2 * math.pi)) / part.pitch
    k = np.round(turns).astype(int) % n
    assert np.abs(turns - np.round(turns)).max() < 1e-9 and np.array_equal(k, gap)
    cut = P.move[src] == MOVE_CUT
    lv = np.array([int(path.curves[c].s) for c in P.curve[src[cut]]])
    assert _never_back(np.stack([lv, gap[cut]], 1)), "the posted rows are not ordered by level"
    for g in range(n):  # each gap: the whole program, in order
        assert np.array_equal(src[gap == g], np.arange(len(P)))
    # a safe retract before each level of each gap, then a rapid from the safe radius
    safe = np.nonzero(blocks.kind == SAFE)[0]
    assert len(safe) == n * len(s["level_blocks"])
    assert (blocks.kind[safe + 1] == MOVE_RAPID).all()
    r_first, _, _ = theta_about(blocks.tip[safe + 1], part.axis)
    assert r_first.min() >= float(stock.hi.max()) + CLEARANCE - 1e-6
    # the time of one gap is the program's, all gaps N times it
    assert s["machining_time_min_all_gaps"] == pytest.approx(s["machining_time_min_gap"] * n)


@pytest.mark.parametrize("order", ["gap", "level"])
def test_three_gaps_in_order_and_the_stock_simulation_finds_no_crash(setup, three, order):
    part, stock = setup
    path = three[order]
    _assert_order(part, path, order, 3)
    _assert_clear_between_gaps(part, stock, path)
    res = remove_program(stock.copy(), path.program, path.tool, sweep_tolerance=0.05)
    assert res.crashes == []
    assert res.volume > 0


def test_the_post_does_not_repeat_a_program_of_several_gaps(setup, three):
    part, _ = setup
    machine = load_machine("ac-trunnion")
    blocks = build_blocks(three["level"], machine, NcOptions(blades=3), solve=False)
    assert blocks.blades == 1 and (blocks.kind == SAFE).sum() == 1
    assert np.array_equal(blocks.source[blocks.kind != SAFE], np.arange(len(three["level"]
                                                                              .program)))
    with pytest.raises(PostError, match="already holds 3 gaps"):
        build_blocks(three["gap"], machine, NcOptions(blades=part.blade_count), solve=False)


def test_bad_order_and_gap_count_are_refused(setup):
    for kw, msg in (({"order": "spiral"}, "order must be one of gap, level"),
                    ({"gaps": 0}, "whole number from 1 to the blade count 24"),
                    ({"gaps": 25}, "whole number from 1 to the blade count 24"),
                    ({"floor_band_step": -1.0}, r"floor band step \(0: no floor-band passes\) "
                                                r"must be ≥ 0 mm, got -1")):
        with pytest.raises(BliskCamError, match=msg):
            _plan(setup, **{"order": "gap", **kw})


def test_a_job_takes_the_order_and_checks_it_up_front(tmp_path):
    from blisk_cam.core.process.job import iter_run_job, load_job
    from tests.core.test_process_kinds import ROUGH_JOB

    job = tmp_path / "bad.toml"
    for line, msg in (('order = "spiral"', "order must be one of gap, level"),
                      ("floor_band_step = -0.5", r"key 'floor_band_step': a length must be "
                                                 r"≥ 0 mm, got -0.5")):
        job.write_text(ROUGH_JOB.replace("stepover = 6\n", f"stepover = 6\n{line}\n"))
        gen = iter_run_job(load_job(job))
        with pytest.raises(BliskCamError, match=r"operation 1 \('roughing'\).*" + msg):
            for _ in range(3):
                next(gen)


def test_the_rough_command_takes_the_order(capsys):
    from blisk_cam.cli.main import build_parser, main

    base = ["rough", "--part", "b.stl", "--blade-count", "24", "--stock", "envelope:2",
            "--tool", "flat", "--tool-diameter", "8", "--depth-per-cut", "4", "--stepover", "4",
            "--out", "r.json"]
    parser = build_parser()
    assert parser.parse_args(base).order == "gap"
    assert parser.parse_args(base + ["--order", "LEVEL"]).order == "level"
    assert main(base + ["--order", "spiral"]) == 2
    assert "--order" in capsys.readouterr().err
    assert parser.parse_args(base).floor_band_step == 0.5
    assert parser.parse_args(base + ["--floor-band-step", "0"]).floor_band_step == 0.0
    assert main(base + ["--floor-band-step", "-1"]) == 2
    assert "--floor-band-step" in capsys.readouterr().err


def test_round_the_axis_goes_the_shorter_way_in_bounded_steps():
    """From θ = 10° to θ = 190° + 20° (the shorter way: −160°) at radius 100 → 110, steps of
    at most 0.5 rad: every straight step keeps at least r cos(step/2) from the axis."""
    from blisk_cam.core.channel.gaps import round_the_axis
    from blisk_cam.core.geometry.axis import Axis

    ax = Axis(np.zeros(3), np.array([0.0, 0.0, 1.0]))
    t0, t1 = math.radians(10.0), math.radians(210.0)
    p0 = np.array([100 * math.cos(t0), 100 * math.sin(t0), -5.0])
    p1 = np.array([110 * math.cos(t1), 110 * math.sin(t1), 5.0])
    pts, axes = round_the_axis(p0, np.array([math.cos(t0), math.sin(t0), 0.0]), p1, ax, 0.5)
    path = np.vstack([p0, pts, p1])
    th = np.unwrap(np.arctan2(path[:, 1], path[:, 0]))
    assert th[-1] - th[0] == pytest.approx(math.radians(-160.0))
    assert np.all(np.diff(th) < 0) and np.abs(np.diff(th)).max() <= 0.5 + 1e-12
    r = np.hypot(path[:, 0], path[:, 1])
    assert np.all(np.diff(r) > 0) and np.all(np.diff(path[:, 2]) > 0)
    np.testing.assert_allclose(np.linalg.norm(axes, axis=1), 1.0)
    # each tool axis turned with its position: radial here
    np.testing.assert_allclose(axes[:, :2], pts[:, :2] / r[1:-1, None], atol=1e-12)
    a, b = path[:-1, :2], path[1:, :2]
    e = b - a
    t = np.clip(-np.einsum("ij,ij->i", a, e) / np.einsum("ij,ij->i", e, e), 0, 1)
    near = np.linalg.norm(a + t[:, None] * e, axis=1)
    assert near.min() >= 100 * math.cos(0.25)


def test_where_the_body_meets_the_stock_is_left_out_or_flagged_at_the_users_choice(
        setup, monkeypatch):
    """Issue 23: what the tool body cannot pass without meeting the stock is left out with a
    warning naming the level, or — the user's choice, ``body_meets_stock="flag"`` — kept
    with its rows flagged as unresolved collisions, which the post's gate refuses unless
    collisions are allowed. A body crash is planted on one cutting row of the stock check's
    first round (the crash finding itself is the stock simulation's, tested there)."""
    from blisk_cam.core.post.gate import CollisionGateError, collision_gate
    from blisk_cam.core.process import roughing
    from blisk_cam.core.stock.removal import Crash
    from blisk_cam.core.toolpath.types import STATUS_UNRESOLVED

    clean = _plan(setup, "gap")
    assert clean.collision["unresolved"] == 0
    collision_gate(clean)  # checked and clear: posted without a note
    cut = np.flatnonzero(clean.program.move == MOVE_CUT)
    planted = int(cut[len(cut) // 2])
    where = tuple(clean.program.tip[planted])
    calls = []

    def crashing(stock, program, *a, **kw):
        res = remove_program(stock, program, *a, **kw)
        calls.append(len(program.tip))
        if len(calls) == 1:  # the first round runs the program planned clean
            assert np.array_equal(program.tip, clean.program.tip)
            res.crashes.append(Crash(planted, "body", "cut", 1.0, 0.5, where))
        return res
    monkeypatch.setattr(roughing, "remove_program", crashing)

    calls.clear()
    left = _plan(setup, "gap")
    assert len(left.program.tip) < len(clean.program.tip)
    assert not np.any(np.all(np.isclose(left.program.tip, where), axis=1))
    assert any("would meet the stock" in w and "left out" in w for w in left.warnings)
    assert left.collision["unresolved"] == 0

    calls.clear()
    flagged = _plan(setup, "gap", body_meets_stock="flag")
    assert np.array_equal(flagged.program.tip, clean.program.tip)  # nothing left out
    status = flagged.program.collision_status
    assert np.flatnonzero(status == STATUS_UNRESOLVED).tolist() == [planted]
    assert flagged.collision["unresolved"] == 1
    # the level of the planted row (a pass's s is its level's index)
    level = clean.stats["level_labels"][int(clean.curves[int(clean.program.curve[planted])].s)]
    assert any(w.startswith(level) and "flagged as unresolved" in w for w in flagged.warnings)
    with pytest.raises(CollisionGateError):
        collision_gate(flagged)
    assert collision_gate(flagged, allow_collisions=True).unresolved == 1
    with pytest.raises(BliskCamError, match="where the body meets the stock: one of "
                                            "leave-out, flag"):
        _plan(setup, "gap", body_meets_stock="ignore")
