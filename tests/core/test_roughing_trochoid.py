"""Channel roughing (#23): the trochoidal slotting pattern — loops across the channel stepped
along it by the stepover, then a pass along each wall — on a synthetic straight channel (the
loops stay between the bounds and leave no point of the channel farther than the tool radius
from the tip's path) and on the demo blisk judged by the stock simulation at 1 mm and by exact
distances of the cutter to the blades (the helpers of tests/core/test_roughing.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from blisk_cam.core.channel.trochoid import trochoid_passes
from blisk_cam.core.part.model import part_from_demo
from blisk_cam.core.process.roughing import PATTERNS, RoughRequest, plan_roughing
from blisk_cam.core.stock.blank import stock_from_envelope
from tests.core import test_roughing as tr

RES = 1.0


def test_trochoid_loops_stay_between_the_bounds_and_cover_the_channel():
    """A straight channel 30 mm long, 14 mm wide at radius 100 (θ in rad, developed r θ),
    the bounds narrowing to 9 mm in the middle; a Ø8 tool (R 4), advance 6 mm."""
    r0, R, adv = 100.0, 4.0, 6.0
    z = np.linspace(-15.0, 15.0, 61)
    half = (7.0 - 2.5 * np.exp(-(z / 6.0) ** 2)) / r0
    lo, hi = -half, half
    reach = np.ones(len(z), bool)
    outside = (z < -12.0) | (z > 12.0)

    def frame(theta, zz, rr):  # developed: x = r θ, y = z
        tips = np.stack([np.asarray(rr) * np.asarray(theta), np.asarray(zz), np.zeros(len(zz))],
                        1)
        return tips, np.tile([0.0, 0.0, 1.0], (len(zz), 1))

    pcs, _ = trochoid_passes(0, z, np.full(len(z), r0), lo, hi, reach, outside, adv, frame,
                             True, R)
    assert len(pcs) == 3  # the loops, then one pass along each wall
    loops = pcs[0].tip
    assert pcs[0].outside == (True, True)
    # every point of the loops between the bounds of its station, within the run
    x, y = loops[:, 0] / r0, loops[:, 1]
    assert np.all(x >= np.interp(y, z, lo) - 1e-12) and np.all(x <= np.interp(y, z, hi) + 1e-12)
    assert y.min() >= z[0] - 1e-12 and y.max() <= z[-1] + 1e-12
    # moves of at most the chord (0.5 mm); the loops reach both walls once per turn
    assert np.linalg.norm(np.diff(loops, axis=0), axis=1).max() <= 0.5 + 1e-9
    w = (x - np.interp(y, z, lo)) / (np.interp(y, z, hi) - np.interp(y, z, lo))
    turns = math.ceil(30.0 / adv)
    assert (np.diff((w > 0.999).astype(int)) == 1).sum() == turns
    # coverage: every point of the channel within the tool radius of the tip's path
    path = np.vstack([p.tip[:, :2] for p in pcs])
    seg = np.linspace(0, 1, 11)[:, None, None]
    dense = (path[:-1][None] + seg * (path[1:] - path[:-1])[None]).reshape(-1, 2)
    gz = np.linspace(-15.0, 15.0, 121)
    gx = np.linspace(-1.0, 1.0, 41)
    G = np.stack([(np.interp(gz, z, lo)[None] + (gx[:, None] + 1) / 2
                   * np.interp(gz, z, hi - lo)[None]) * r0,
                  np.broadcast_to(gz, (len(gx), len(gz)))], -1).reshape(-1, 2)
    d, _ = cKDTree(dense).query(G)
    assert d.max() <= R, d.max()
    # the walls' passes run on the bounds
    np.testing.assert_allclose(pcs[1].tip[:, 0] / r0, np.interp(pcs[1].tip[:, 1], z, lo),
                               atol=1e-12)
    np.testing.assert_allclose(pcs[2].tip[:, 0] / r0, np.interp(pcs[2].tip[:, 1], z, hi),
                               atol=1e-12)


@pytest.fixture(scope="module")
def trochoid():
    part = part_from_demo(tr._demo())
    stock = stock_from_envelope(part, 2.0, RES)
    # the radial axis, no floor band and no stock check: cheap; the simulation judges
    req = RoughRequest(tool=tr._tool(), stepover=8.0, depth_per_cut=8.0, pattern="trochoid",
                       follow_blades=False, floor_band_step=0.0, check_stock=False)
    return part, stock, plan_roughing(part, req, stock)


def test_trochoid_roughing_removes_the_channel_and_keeps_the_allowance(trochoid, monkeypatch):
    part, stock, path = trochoid
    assert "trochoid" in PATTERNS and path.stats["pattern"] == "trochoid"
    monkeypatch.setattr(tr, "RES", RES)
    share, crashes, _, _, _, dev = tr._simulated(part, stock, path)
    assert crashes == []
    assert share >= 0.95, f"only {share:.1%} of the channel outside the allowance removed"
    assert dev.min() >= tr.ALLOWANCE - 0.02 - RES / math.sqrt(2), dev.min()
    assert path.stats["unreachable_levels"] == []
    tr._assert_clear(part, path, every=48)
