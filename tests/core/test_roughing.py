"""Channel roughing (#23), judged by the stock simulation and by an independent distance
measurement: a small demo blisk (24 blades, 25 mm tall blades, 22 mm chord) from its
default blank (the envelope + 2 mm), a Ø8 R1 bull nose on a long neck.

Tolerances. The stock is simulated at 0.5 mm (coarse, to stay cheap). A ray stands for its
(θ, z) cell, so the deviation read along a part normal sees the stock's wall up to half a cell
diagonal away — res/√2 = 0.354 mm — from where it is: the stock judge asserts "never below
0.5 − 0.02 − res/√2". The sharp check of "never below 0.5 − 0.02" is the second test: the
exact distance from points on the cutter, at every fourth cut pose, to the blade meshes
(triangle-exact) and to the hub profile (exact); 48 points round the cutter of 4 mm radius
can miss the nearest one by its sag, 0.009 mm.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from blisk_cam.cli.main import main
from blisk_cam.core.channel.levels import channel_volume, level_radii
from blisk_cam.core.errors import BliskCamError, StockError, ToolError
from blisk_cam.core.geometry.closest import segment_distance2_2d
from blisk_cam.core.geometry.distance import closest_points
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.part.model import part_from_blade, part_from_demo, theta_about
from blisk_cam.core.process.roughing import RoughingOperation, RoughRequest, plan_roughing
from blisk_cam.core.stock.blank import (
    stock_from_allowance,
    stock_from_envelope,
    stock_from_profile,
)
from blisk_cam.core.stock.deviation import deviation_map
from blisk_cam.core.stock.removal import remove_program
from blisk_cam.core.stock.simulation import part_surface
from blisk_cam.core.tool.cutter import Cutter
from blisk_cam.core.toolpath.paths_io import read_paths_json, write_paths_json
from blisk_cam.core.toolpath.types import MOVE_CUT
from tests.support.blades import nasa_blade
from tests.support.mesh_files import write_binary_stl

RES = 0.5
ALLOWANCE = 0.5


def _demo():
    return make_demo_blisk(resolution=0.2, hub_cone=(150.0, -12.0, 154.0, 12.0),
                           tip_cone=(178.0, -12.0, 181.0, 12.0), chord_hub=22.0,
                           chord_tip=22.0, fillet_radius=4.0, hub_extension=4.0,
                           max_thickness_hub=2.5, max_thickness_tip=1.5)


def _tool():
    return Cutter.bull(4.0, 1.0, h=24.0, neck_length=30.0)


@pytest.fixture(scope="module")
def rough():
    part = part_from_demo(_demo())
    stock = stock_from_envelope(part, 2.0, RES)
    req = RoughRequest(tool=_tool(), stepover=6.0, depth_per_cut=8.0, allowance=ALLOWANCE)
    path = plan_roughing(part, req, stock)
    return part, stock, path


def _simulated(part, blank, path):
    """(share of the channel outside the allowance removed, crashes, part points (k, 3),
    their normals (k, 3), hub-only mask (k,), deviation (k,) mm) after ``path``."""
    stock = blank.copy()
    before = channel_volume(stock, part.hub_profile)
    shell = channel_volume(stock_from_allowance(part, ALLOWANCE, RES), part.hub_profile)
    # sweep tolerance 0.05 mm: the sampled sweep lies inside the true one, so it can only
    # leave material (never hide a gouge) and under-state the share removed
    res = remove_program(stock, path.program, path.tool, sweep_tolerance=0.05)
    after = channel_volume(stock, part.hub_profile)
    V, F, N, surf = part_surface(part, RES)
    hub_faces = part.part_mesh()[2]
    on_blade = np.zeros(len(V), bool)
    on_blade[np.unique(F[~hub_faces])] = True
    dev = deviation_map(stock, V[surf], N[surf], reach_out=12.0)
    return ((before - after) / (before - shell), res.crashes, V[surf], N[surf],
            ~on_blade[surf], dev)


@pytest.fixture(scope="module")
def roughed(rough):
    return _simulated(*rough)


def test_stock_simulation_keeps_the_allowance_removes_the_channel_no_crash(rough, roughed):
    part, _, path = rough
    share, crashes, _, _, _, dev = roughed
    assert crashes == []  # no rapid and no shank/holder removes material
    assert share >= 0.95, f"only {share:.1%} of the channel outside the allowance removed"
    assert dev.min() >= ALLOWANCE - 0.02 - RES / math.sqrt(2), dev.min()
    # the cut reached the walls: most of the part's surface carries less than 1 mm
    assert np.median(dev) < 1.0
    assert path.stats["unreachable_levels"] == []


def _level_step_cusp(part, path, P, N, step):
    """(k,) the level step cusp (mm) at part points P (k, 3) with normals N: a staircase of
    steps ``step`` (k,) mm along the tool axis a on a wall of unit normal n leaves at most
    s |n · a| normal to the wall (the two corners of a step lie s |n · a| off the plane
    through the touching points; a corner radius leaves less). a: the radial direction tilted
    toward +θ by each side tilt the program used (the largest |n · a| over them)."""
    _, th, _ = theta_about(P, part.axis)
    radial = np.stack([np.cos(th), np.sin(th), np.zeros_like(th)], 1)
    tang = np.stack([-np.sin(th), np.cos(th), np.zeros_like(th)], 1)
    nu, nt = np.einsum("ij,ij->i", N, radial), np.einsum("ij,ij->i", N, tang)
    lo, hi = np.radians(path.stats["side_tilt_range_deg"])
    na = np.max([np.abs(nu * math.cos(p) + nt * math.sin(p))
                 for p in np.linspace(min(lo, 0.0), max(hi, 0.0), 13)], axis=0)
    return step * na


def _floor_band(part, P, depth):
    """(k,) True where P lies less than the allowance + one depth per cut above the hub:
    the band the floor level and the wall levels above it cut."""
    r, _, z = theta_about(P, part.axis)
    H = part.hub_profile
    return r < np.interp(z, H[:, 1], H[:, 0]) + ALLOWANCE + depth


def test_material_left_above_the_floor_band_is_within_the_level_step_cusp(rough, roughed):
    """Acceptance #23: between 0.5 − 0.02 and 0.5 + (level step cusp) on the stock, above
    the floor band (every level there has the axis leaning with the blades and ends its
    passes on the walls; the stock judge's ± res/√2, module docstring)."""
    part, _, path = rough
    _, _, P, N, _, dev = roughed
    depth = path.stats["depth_per_cut_mm"]
    above = ~_floor_band(part, P, depth)
    assert above.sum() > 500
    bound = ALLOWANCE + _level_step_cusp(part, path, P, N, depth) + RES / math.sqrt(2)
    over = above & (dev > bound)
    assert not over.any(), (f"{over.sum()} points above the bound, by up to "
                            f"{(dev - bound)[over].max():.3f} mm")
    assert dev[above].min() >= ALLOWANCE - 0.02 - RES / math.sqrt(2)


def test_material_left_in_the_floor_band_is_within_the_wall_level_cusp(rough, roughed):
    """Acceptance #23 in the band between the floor and the level above: the bull nose's
    corner rides on the hub fillet there and the wall levels' contours touch each wall where
    their tilt puts the tool first; the surface-driven passes (rows of contacts on the
    allowance offset, :mod:`blisk_cam.core.channel.floor_band`) take the rest, so the stock
    keeps at most the wall-level step cusp beyond the allowance."""
    part, _, path = rough
    _, _, P, N, _, dev = roughed
    assert path.stats["floor_band_passes"] > 0
    band = _floor_band(part, P, path.stats["depth_per_cut_mm"])
    assert band.sum() > 300
    step = path.stats["wall_level_step_mm"]
    bound = ALLOWANCE + _level_step_cusp(part, path, P, N, step) + RES / math.sqrt(2)
    over = band & (dev > bound)
    assert not over.any(), (f"{over.sum()} points above the bound, by up to "
                            f"{(dev - bound)[over].max():.3f} mm")
    assert dev[band].min() >= ALLOWANCE - 0.02 - RES / math.sqrt(2)


def test_axis_turn_per_step_is_bounded(rough):
    """Between consecutive cutting poses the tool axis turns by at most ``max_turn`` (2°),
    measured on the program's axes (the side tilt's own bound is not enough: the radial
    direction turns as the tip moves round the blisk axis); the stats report the largest
    turn."""
    part, _, path = rough
    P = path.program
    i = np.nonzero((P.move[1:] == MOVE_CUT) & (P.move[:-1] == MOVE_CUT))[0]
    a, b = P.axis[i], P.axis[i + 1]
    turn = np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.einsum("ij,ij->i", a, b))
    assert turn.max() <= math.radians(2.0) + 1e-9
    assert path.stats["max_axis_turn_deg"] == pytest.approx(math.degrees(turn.max()))
    # the side tilt's bound alone would not have kept it: poses were inserted
    assert path.stats["poses_inserted_for_turn"] > 0
    # the axis does lean: the twisted blades' mean camber surface is not radial
    lo, hi = path.stats["side_tilt_range_deg"]
    assert hi - lo > 5.0


def test_cutter_never_enters_the_allowance_exact_distance(rough):
    part, _, path = rough
    _assert_clear(part, path)


@pytest.fixture(scope="module")
def plunged():
    part = part_from_demo(_demo())
    stock = stock_from_envelope(part, 2.0, RES)
    req = RoughRequest(tool=_tool(), stepover=6.0, depth_per_cut=8.0, levels="morph",
                       pattern="plunge")
    return part, stock, plan_roughing(part, req, stock)


def test_plunge_in_morphed_levels_never_enters_the_allowance(plunged):
    part, _, path = plunged
    # plunges: every cut of the levels feeds along the tool axis (leaning with the blades);
    # the surface-driven passes of the walls after them (the last passes) follow the walls
    P = path.program
    first = path.stats["floor_band_first_pass"]
    assert first > 0
    cut = np.nonzero((P.move == MOVE_CUT) & (P.curve < first))[0]
    step = P.tip[cut] - P.tip[cut - 1]
    cross = np.linalg.norm(np.cross(step, P.axis[cut]), axis=1)
    assert cross.max() < 1e-9 and len(cut) > 100
    _assert_clear(part, path)


@pytest.fixture(scope="module")
def plunged_sim(plunged):
    return _simulated(*plunged)


def test_plunge_removes_95_percent_of_the_channel(plunged_sim):
    """Acceptance #23: ≥ 95 % of the channel outside the allowance shell removed, judged by
    the stock (the sampled sweep under-states the share), never below the allowance."""
    share, crashes, _, _, _, dev = plunged_sim
    assert crashes == []
    assert share >= 0.95, f"only {share:.1%} removed"
    assert dev.min() >= ALLOWANCE - 0.02 - RES / math.sqrt(2)


def test_plunge_material_left_is_within_the_level_step_cusp(plunged, plunged_sim):
    """Acceptance #23's upper bound for plunge roughing, judged by the stock: above the floor
    band 0.5 + the level step cusp of the depth per cut, in it of the wall-level step (the
    plunge levels keep one axis each; the surface-driven rows up the walls take the wedge a
    leaning wall keeps from it, and the fillet's)."""
    part, _, path = plunged
    _, _, P, N, _, dev = plunged_sim
    depth = path.stats["depth_per_cut_mm"]
    band = _floor_band(part, P, depth)
    step = np.where(band, path.stats["wall_level_step_mm"], depth)
    bound = ALLOWANCE + _level_step_cusp(part, path, P, N, step) + RES / math.sqrt(2)
    for name, m in (("above the floor band", ~band), ("in the floor band", band)):
        over = m & (dev > bound)
        assert not over.any(), (f"{name}: {over.sum()} points above the bound, by up to "
                                f"{(dev - bound)[over].max():.3f} mm")


def test_tilted_axis_from_the_shroud_never_enters_the_allowance():
    part = part_from_demo(_demo())
    stock = stock_from_envelope(part, 2.0, 1.0)
    req = RoughRequest(tool=_tool(), stepover=6.0, depth_per_cut=8.0, levels="from-shroud",
                       lead=math.radians(3.0), side_tilt=math.radians(4.0),
                       follow_blades=False, check_stock=False)
    path = plan_roughing(part, req, stock)
    # every cutting axis is the radial direction tilted 3° toward +z and 4° toward +θ
    P = path.program
    cut = P.move == MOVE_CUT
    tip, axis = P.tip[cut], P.axis[cut]
    r, th, _ = theta_about(tip, part.axis)
    radial = np.stack([np.cos(th), np.sin(th), np.zeros_like(th)], 1)
    tang = np.stack([-np.sin(th), np.cos(th), np.zeros_like(th)], 1)
    np.testing.assert_allclose(np.degrees(np.arctan2(axis[:, 2], np.einsum(
        "ij,ij->i", axis, radial))), 3.0, atol=1e-6)
    np.testing.assert_allclose(np.degrees(np.arctan2(np.einsum("ij,ij->i", axis, tang),
                                                     np.einsum("ij,ij->i", axis, radial))),
                               4.0, atol=1e-6)
    _assert_clear(part, path)


def test_rotor37_narrow_floor_is_reported_not_gouged():
    """Rotor 37 × 36 with a Ø16 R1 bull nose: the tool does not fit the throat at the hub;
    that part of the floor level is named and left out, and nothing cuts into the allowance.
    The blade mesh is open and extended past the hub and tip, so beyond its open ends the
    side of a face says nothing: only distances are checked."""
    V, F, hub, _ = nasa_blade("rotor37")
    part = part_from_blade(V, F, np.array([[hub.r1, hub.z1], [hub.r2, hub.z2]]), 36)
    stock = stock_from_envelope(part, 2.0, 1.0)
    # the radial axis keeps this test cheap (≈ 15 s); the leaning axis on Rotor 37 is
    # measured by bench/bench_rough.py --rotor37
    req = RoughRequest(tool=Cutter.bull(8.0, 1.0, h=40.0, neck_length=60.0), stepover=8.0,
                       depth_per_cut=8.0, follow_blades=False, check_stock=False)
    path = plan_roughing(part, req, stock)
    last = path.stats["level_labels"][-1]
    assert path.stats["unreachable_levels"] == [last]
    assert any(w.startswith(last) and "left out" in w for w in path.warnings)
    _assert_clear(part, path, every=12, signed=False)
    # the stock judges it too (#23 acceptance): no crash of a rapid, link or the body, and
    # never below 0.5 − 0.02 (± the stock's res/√2) where the blank held more than the
    # allowance (the default blank's envelope, binned per 1 mm of z, misses Rotor 37's tip
    # in places: the blank never held the blade there)
    sim = stock.copy()
    res = remove_program(sim, path.program, path.tool, sweep_tolerance=0.05)
    assert res.crashes == []
    V, _, N, surf = part_surface(part, stock.resolution)
    P, Nn = V[surf][::3], N[surf][::3]
    held = deviation_map(stock, P, Nn, reach_out=2.0) > ALLOWANCE + stock.resolution
    assert held.sum() > 5000
    dev = deviation_map(sim, P[held], Nn[held], reach_out=2.0)
    assert dev.min() >= ALLOWANCE - 0.02 - stock.resolution / math.sqrt(2), dev.min()
    assert np.median(dev) < 2.0  # the channel was cut


def _assert_clear(part, path, every=4, signed=True):
    P = path.program
    cut = np.nonzero(P.move == 0)[0][::every]
    tip, ax = P.tip[cut], P.axis[cut]
    c = path.tool
    prof = c.profile(6)
    side = np.stack([np.full(16, c.max_radius), np.linspace(prof[-2, 1], c.h, 16)], 1)
    prof = np.vstack([prof[1:-1], side])  # the corner arc and the side (ρ, h)
    phi = np.linspace(0, 2 * math.pi, 48, endpoint=False)
    # a frame per pose
    ref = np.where(np.abs(ax[:, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
    u = np.cross(ax, ref)
    u /= np.linalg.norm(u, axis=1)[:, None]
    v = np.cross(ax, u)
    ring = np.cos(phi)[:, None, None] * u[None] + np.sin(phi)[:, None, None] * v[None]
    pts = (tip[None, None] + prof[:, 1][None, :, None, None] * ax[None, None]
           + prof[:, 0][None, :, None, None] * ring[:, None]).reshape(-1, 3)
    V, F = part.blade_vertices, part.blade_faces
    Vs, Fs = [], []
    for k in (-1, 0, 1, 2):  # the gap's two blades and their outer neighbours
        a = k * part.pitch
        R = np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])
        Fs.append(F + len(V) * len(Vs))
        Vs.append(V @ R.T)
    Vs, Fs = np.vstack(Vs), np.vstack(Fs)
    edge = float(np.linalg.norm(Vs[Fs[:, 1:]] - Vs[Fs[:, :1]], axis=2).max())
    # only points within the allowance + the longest edge of a vertex can be that near a face
    near, _ = cKDTree(Vs).query(pts, distance_upper_bound=ALLOWANCE + edge, workers=-1)
    cand = pts[np.isfinite(near)]
    cp = closest_points(TriMesh.from_arrays(Vs, Fs), cand)
    if signed:  # behind a face (not beyond an open end of the blade: edge, vertex nearest)
        assert not np.any((cp.sign < 0) & (cp.feature == 0)), "a cutter point inside a blade"
    assert cp.distance.min() >= ALLOWANCE - 0.02, f"cutter {cp.distance.min():.4f} mm from a blade"
    r, _, z = theta_about(pts, part.axis)
    H = part.hub_profile
    inside = (z >= H[0, 1]) & (z <= H[-1, 1])
    d2 = np.full(inside.sum(), np.inf)
    for a, b in zip(H[:-1], H[1:], strict=True):
        d2 = np.minimum(d2, segment_distance2_2d(r[inside], z[inside], a[0], a[1], b[0], b[1]))
    above = r[inside] > np.interp(z[inside], H[:, 1], H[:, 0])
    assert above.all()
    assert np.sqrt(d2).min() >= ALLOWANCE - 0.02


def test_paths_json_round_trip_and_nc_reads_it(rough, tmp_path):
    part, _, path = rough
    f = write_paths_json(path, tmp_path / "rough.json")
    d = json.loads(open(f).read())
    assert d["operation"] == "rough"
    back = read_paths_json(f)
    assert back.operation == "rough"
    np.testing.assert_array_equal(back.program.tip, path.program.tip)
    np.testing.assert_array_equal(back.program.move, path.program.move)
    assert back.stats["machining_time_min_all_gaps"] == pytest.approx(
        24 * back.stats["machining_time_min_gap"])
    # the time estimate: the cut length at the feed is a lower bound
    cut_len = float(np.linalg.norm(np.diff(path.program.tip, axis=0), axis=1)[
        path.program.move[1:] == MOVE_CUT].sum())
    assert back.stats["machining_time_min_gap"] >= cut_len / back.stats["feed_mm_min"]
    out = tmp_path / "rough.ngc"
    assert main(["nc", "--paths", str(f), "--machine", "ac-trunnion", "--post", "linuxcnc",
                 "--out", str(out), "--quiet"]) == 0
    assert out.stat().st_size > 1000


def test_levels_steps_never_exceed_the_depth_and_end_on_the_floor():
    z = np.linspace(-10, 10, 41)
    floor = 150 + 0.2 * z
    top = 180 + 0.05 * z
    for mode in ("from-hub", "from-shroud", "morph"):
        lv = level_radii(z, floor, top, mode, 4.0)
        R = np.array([x.r for x in lv])
        np.testing.assert_allclose(R[-1], floor)  # the last level is the floor
        assert np.all(R[:-1] >= R[1:] - 1e-12)  # from the shroud down
        assert np.all(R[:-1] - R[1:] <= 4.0 + 1e-9)
        assert np.all(top - R[0] <= 4.0 + 1e-9)
        assert len(lv) == math.ceil((top - floor).max() / 4.0)


def test_bad_inputs_are_named():
    part = part_from_demo(_demo())
    stock = stock_from_envelope(part, 2.0, 1.0)
    op = RoughingOperation()

    def req(**kw):
        base = dict(tool=_tool(), stepover=5.0, depth_per_cut=6.0)
        base.update(kw)
        return RoughRequest(**base)

    with pytest.raises(BliskCamError, match="half the channel"):
        op.start(part, req(allowance=15.0), stock)
    with pytest.raises(ToolError, match="does not fit the channel at the hub"):
        op.start(part, req(tool=Cutter.flat(16.0, h=40.0)), stock)
    with pytest.raises(BliskCamError, match="depth per cut"):
        op.start(part, req(depth_per_cut=0.0), stock)
    with pytest.raises(BliskCamError, match="depth per cut"):
        op.start(part, req(depth_per_cut=-1.0), stock)
    small = stock_from_profile([[140, -20], [165, -20], [165, 20], [140, 20]], part.axis,
                               part.blade_count, part.sector_start, 1.0)
    with pytest.raises(StockError, match="does not contain the part"):
        op.start(part, req(), small)
    with pytest.raises(ToolError, match="stepover"):
        op.start(part, req(stepover=9.0), stock)
    with pytest.raises(BliskCamError, match="largest axis turn per step"):
        op.start(part, req(max_turn=0.0), stock)


def test_cli_rough_writes_the_program_and_rejects_bad_input(tmp_path, capsys):
    demo = _demo()
    blade = write_binary_stl(tmp_path / "blade.stl", demo.blade_vertices, demo.blade_faces)
    hub = tmp_path / "hub.csv"
    H = part_from_demo(demo).hub_profile
    hub.write_text("".join(f"{r}, {z}\n" for r, z in H))
    out = tmp_path / "rough.json"
    base = ["rough", "--part", str(blade), "--hub-profile", str(hub), "--blade-count", "24",
            "--stock", "envelope:2", "--resolution", "1", "--tool", "bull", "--tool-diameter",
            "8", "--corner-radius", "1", "--flute-length", "24", "--neck-length", "30",
            "--levels", "morph", "--depth-per-cut", "8", "--stepover", "6", "--axis", "radial"]
    assert main(base + ["--out", str(out)]) == 0
    d = json.loads(out.read_text())
    assert d["operation"] == "rough" and d["stats"]["level_mode"] == "morph"
    assert d["stats"]["axis"] == "radial" and d["stats"]["side_tilt_range_deg"] == [0.0, 0.0]
    assert "min for the 24 gaps" in capsys.readouterr().out
    bad = base[:-2] + ["--stepover", "6", "--allowance", "15", "--out",
                       str(tmp_path / "bad.json")]
    assert main(bad) == 1
    err = [x for x in capsys.readouterr().err.strip().splitlines() if "error" in x]
    assert len(err) == 1 and "half the channel" in err[0]  # one line, no traceback
    assert not (tmp_path / "bad.json").exists()


def test_mean_camber_lean_of_a_leaning_blade_and_the_turn_limiter():
    """A blade whose mean camber line leans s rad per mm of radius (θ_m = s (r − 160) + 0.1
    sin z / 10, both sides ± 0.01 rad round it): the axis's side tilt is atan(s r), r the
    middle of the band; beyond the blade's z the nearest station's tilt is held. The
    limiter keeps every step within the bound and moves no value that needs no limiting."""
    from blisk_cam.core.channel.axis import limit_turn, mean_camber_lean
    from blisk_cam.core.channel.region import Section

    s = 0.002
    zs = np.linspace(-10.0, 10.0, 401)
    secs = []
    for rc in np.arange(150.0, 170.1, 1.0):
        mid = s * (rc - 160.0) + 0.1 * np.sin(zs / 10.0)
        secs.append(Section(rc, np.concatenate([zs, zs]),
                            np.concatenate([mid - 0.01, mid + 0.01])))
    z = np.linspace(-14.0, 14.0, 57)
    phi = mean_camber_lean(secs, z, np.full(len(z), 152.0), np.full(len(z), 160.0))
    inside = np.abs(z) <= 10.0
    np.testing.assert_allclose(phi[inside], math.atan(s * 156.0), atol=1e-9)
    np.testing.assert_allclose(phi[~inside], math.atan(s * 156.0), atol=1e-9)
    x = np.array([0.0, 0.01, 0.2, 0.2, -0.3, -0.29, 0.0])
    y = limit_turn(x, 0.05)
    assert np.abs(np.diff(y)).max() <= 0.05 + 1e-12
    np.testing.assert_array_equal(limit_turn([0.0, 0.01, 0.02], 0.05), [0.0, 0.01, 0.02])


def test_bound_turn_inserts_poses_on_the_move_at_equal_angles():
    """Two poses 7° apart with a 2° bound: ⌈7/2⌉ = 4 steps of 1.75° each, the new axes on the
    great circle between the two (coplanar with them), the new tips on the straight move at
    the same fractions; a step already within the bound and the original poses are kept
    bit for bit; nothing to insert returns the input."""
    from blisk_cam.core.channel.axis import bound_turn, turn_angles

    w = math.radians(7.0)
    axes = np.array([[1.0, 0.0, 0.0], [math.cos(w), math.sin(w), 0.0],
                     [math.cos(w), math.sin(w), 0.0]])
    rot = np.linalg.qr(np.array([[1.0, 2.0, 0.5], [0.3, -1.0, 2.0], [1.5, 0.2, 1.0]]))[0]
    axes = axes @ rot.T
    tips = np.array([[0.0, 0.0, 0.0], [4.0, 1.0, -2.0], [5.0, 1.5, -2.5]])
    t2, a2, n = bound_turn(tips, axes, math.radians(2.0))
    assert n == 3 and len(t2) == 6
    steps = turn_angles(a2)
    np.testing.assert_allclose(steps[:4], w / 4, atol=1e-12)
    assert steps.max() <= math.radians(2.0)
    np.testing.assert_allclose(np.linalg.norm(a2, axis=1), 1.0, atol=1e-12)
    normal = np.cross(axes[0], axes[1])
    np.testing.assert_allclose(a2[:5] @ normal, 0.0, atol=1e-12)
    frac = np.arange(5) / 4.0
    np.testing.assert_allclose(t2[:5], tips[0] + frac[:, None] * (tips[1] - tips[0]),
                               atol=1e-12)
    np.testing.assert_array_equal(t2[[0, 4, 5]], tips)
    np.testing.assert_array_equal(a2[[0, 4, 5]], axes)
    same = bound_turn(tips, axes, math.radians(8.0))
    assert same[0] is tips and same[1] is axes and same[2] == 0
