"""Hub and fillet finishing (issue 24): measured on the demo blisk — the CC points on the
revolved hub profile, the ball's clearance from both blades, the scallop left on a simulated
stock, the tool body clear of the blades, the fillet loops, bad inputs and the CLI."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from blisk_cam.core.errors import BliskCamError, ToolError
from blisk_cam.core.geometry.distance import MeshDistance
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.geometry.vectors import rotate_about
from blisk_cam.core.hub.surface import scallop_for_stepover, stepover_for_scallop
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.part.model import part_from_demo, theta_about
from blisk_cam.core.process.fillet_finish import FILLET_FINISH
from blisk_cam.core.process.hub_finish import HUB_FINISH, HubRequest
from blisk_cam.core.process.operation import run_operation
from blisk_cam.core.stock.blank import stock_from_allowance
from blisk_cam.core.stock.deviation import deviation_map
from blisk_cam.core.stock.removal import remove_program
from blisk_cam.core.toolpath.paths_io import path_from_dict, path_to_dict
from blisk_cam.core.toolpath.types import MOVE_CUT, Program

RHO = 3.0


@pytest.fixture(scope="module")
def part():
    return part_from_demo(make_demo_blisk(resolution=0.3))


@pytest.fixture(scope="module")
def blade_distance(part):
    return MeshDistance(TriMesh.from_arrays(part.blade_vertices, part.blade_faces))


@pytest.fixture(scope="module")
def hub_result(part):
    req = HubRequest(tool_diameter=2 * RHO, scallop=0.05, extend=4.0, allowance=0.05)
    return req, run_operation(HUB_FINISH, part, req)


def _profile_distance(points, part):
    """Distance (mm) of points to the revolved hub profile, measured here independently."""
    r, _, z = theta_about(points, part.axis)
    P = part.hub_profile
    best = np.full(len(r), np.inf)
    for a, b in zip(P[:-1], P[1:], strict=True):
        d = b - a
        t = np.clip(((r - a[0]) * d[0] + (z - a[1]) * d[1]) / (d @ d), 0.0, 1.0)
        best = np.minimum(best, np.hypot(r - a[0] - t * d[0], z - a[1] - t * d[1]))
    return best


def _blade_distance(points, part, dist, k):
    q = rotate_about(points, part.axis.d, -k * part.pitch, part.axis.o) if k else points
    return dist.query(q).distance


# ---------------------------------------------------------------- the scallop formula
@pytest.mark.parametrize("kappa", [0.0, 1.0 / 150.0, 1.0 / 12.0, -1.0 / 20.0])
def test_scallop_formula_matches_the_two_balls_measured(kappa):
    """The stepover for a scallop h on a circle of curvature κ: the cusp between two balls
    that far apart, found numerically along rays from the circle's centre, is h."""
    h = 0.05
    w = float(stepover_for_scallop(RHO, h, np.array([kappa]))[0])
    assert float(scallop_for_stepover(RHO, np.array([w]), np.array([kappa]))[0]) == \
        pytest.approx(h, rel=1e-9)
    if kappa == 0.0:
        x = np.linspace(-w / 2, w / 2, 20001)
        low = np.minimum(RHO - np.sqrt(np.maximum(RHO**2 - (x + w / 2) ** 2, 0)),
                         RHO - np.sqrt(np.maximum(RHO**2 - (x - w / 2) ** 2, 0)))
        assert low.max() == pytest.approx(h, abs=1e-6)
        return
    R = 1.0 / abs(kappa)
    L = R + RHO if kappa > 0 else R - RHO
    half = 0.5 * w / R
    centres = [L * np.array([math.cos(a), math.sin(a)]) for a in (-half, half)]
    best = -np.inf
    for a in np.linspace(-half, half, 4001):
        u = np.array([math.cos(a), math.sin(a)])
        # the cut surface along the ray: the nearest ball boundary to the circle
        depths = []
        for c in centres:
            b = u @ c
            disc = b * b - (c @ c - RHO**2)
            if disc < 0:
                depths.append(np.inf if kappa > 0 else -np.inf)
                continue
            depths.append(b - math.sqrt(disc) if kappa > 0 else b + math.sqrt(disc))
        height = (min(depths) - R) if kappa > 0 else (R - max(depths))
        best = max(best, height)
    assert best == pytest.approx(h, abs=2e-5)


# ---------------------------------------------------------------- hub finishing
def test_hub_passes_lie_on_the_hub_and_keep_the_ball_clear_of_both_blades(
        part, hub_result, blade_distance):
    req, res = hub_result
    path = res.path
    assert path.operation == "hub-finish"
    cc = np.vstack([c.cc for c in path.curves])
    assert _profile_distance(cc, part).max() <= req.chord
    target = RHO + req.allowance
    near = []
    for c in path.curves:
        centre = c.cc + RHO * c.normal
        d0 = _blade_distance(centre, part, blade_distance, 0)
        d1 = _blade_distance(centre, part, blade_distance, 1)
        assert min(d0.min(), d1.min()) >= target - 1e-3, c.s
        near.append((c.s, d0.min(), d1.min()))
    # boundary-conformed: the first pass follows blade 0, the last blade 1 (within 0.05 mm)
    first = min(near)
    last = max(near)
    assert first[1] == pytest.approx(target, abs=0.05)
    assert last[2] == pytest.approx(target, abs=0.05)
    # the tool axis leans off the contact normal by the lead: never cutting at zero speed
    cut_angles = np.concatenate([np.degrees(np.arccos(np.clip(
        np.einsum("ij,ij->i", c.axis, c.normal), -1, 1))) for c in path.curves])
    assert cut_angles.min() >= math.degrees(req.lead) - 1e-6
    assert path.stats["zero_speed_poses"] == 0
    # the passes reach past both edges by the extension
    m_le, m_te = path.stats["leading_edge_m_mm"], path.stats["trailing_edge_m_mm"]
    z = np.concatenate([(c.cc - part.axis.o) @ part.axis.d for c in path.curves])
    rb, _, zb = theta_about(part.blade_vertices, part.axis)
    root = rb < rb.min() + 1.0
    assert z.min() < zb[root].min() - 0.5 * req.extend
    assert z.max() > zb[root].max() + 0.5 * req.extend
    assert m_te - m_le > 0
    assert path.stats["scallop_estimate_mm"] <= req.scallop + 1e-9


def test_hub_tool_body_is_clear_of_the_blades_and_the_program_is_linked(part, hub_result):
    req, res = hub_result
    path = res.path
    prog = path.program
    assert path.collision["unresolved"] == 0
    assert path.stats["body_collision_rows"] == 0
    assert path.stats["body_clearance_min_mm"] >= req.safety
    assert np.all(prog.collision_status == 0)
    # one approach, cut and retract per pass; every pass pose is in the program
    assert int(np.count_nonzero(prog.move == MOVE_CUT)) + len(path.curves) == path.n_poses
    assert prog.move[0] == 4 and prog.move[-1] == 4
    back = path_from_dict(json.loads(json.dumps(path_to_dict(path))))
    assert back.operation == "hub-finish"
    assert np.array_equal(back.program.tip, prog.tip)
    assert back.collision["unresolved"] == 0


def _left_between_two_passes(part, req, stock_allowance, res_mm):
    """The hub's two most widely spaced neighbouring passes of ``req`` (their middle part)
    run on a stock ``stock_allowance`` mm above the part at ``res_mm``: (path, the material
    left on the hub between them, read on the stock on the passes' own CC lines)."""
    path = run_operation(HUB_FINISH, part, req).path
    widest = int(np.argmax(np.diff([c.s for c in path.curves])))
    pair = path.curves[widest:widest + 2]

    def middle(c):
        n = len(c.cc)
        a, b = int(0.35 * n), int(0.65 * n)
        return replace(c, cc=c.cc[a:b], normal=c.normal[a:b], tip=c.tip[a:b],
                       axis=c.axis[a:b], flags=c.flags[a:b], move=c.move[a:b])
    pair = [middle(c) for c in pair]
    tips = np.vstack([c.tip for c in pair])
    axes = np.vstack([c.axis for c in pair])
    move = np.zeros(len(tips), np.int8)
    move[len(pair[0].tip)] = 1  # a link across to the second pass (zigzag: its start)
    prog = Program(tip=tips, axis=axes, move=move,
                   curve=np.repeat([0, 1], [len(c.tip) for c in pair]),
                   index=np.concatenate([np.arange(len(c.tip)) for c in pair]),
                   flags=np.zeros(len(tips), np.uint8))
    stock = stock_from_allowance(part, stock_allowance, res_mm)
    remove_program(stock, prog, path.tool, check_body=False, sweep_tolerance=0.01)
    # hub points between the two passes, away from their ends (the part's own hub: the
    # passes' CC lines read on it by their (m, θ))
    from blisk_cam.core.hub.surface import HubSurface
    hub = HubSurface(part.hub_profile, part.axis)
    ma, ta, _ = hub.coordinates(pair[0].cc)
    mb, tb, _ = hub.coordinates(pair[1].cc)
    lo, hi = max(ma.min(), mb.min()) + 3.0, min(ma.max(), mb.max()) - 3.0
    ms = np.linspace(lo, hi, 120)
    oa, ob = np.argsort(ma), np.argsort(mb)
    thA, thB = np.interp(ms, ma[oa], ta[oa]), np.interp(ms, mb[ob], tb[ob])
    f = np.linspace(0.0, 1.0, 41)
    TH = (thA[:, None] + f[None, :] * (thB - thA)[:, None]).ravel()
    M = np.repeat(ms, len(f))
    return path, deviation_map(stock, hub.point(M, TH), hub.normal(M, TH))


def test_hub_scallop_measured_on_the_stock(part):
    """Two neighbouring passes (their middle part) run on a stock 0.3 mm above the part: the
    material left between them, read on the stock at the hub, stays within the scallop
    target plus the stock's resolution, and the passes did cut (less than the 0.3 mm)."""
    res_mm, h = 0.15, 0.15
    req = HubRequest(tool_diameter=2 * RHO, scallop=h, extend=4.0, allowance=0.4,
                     collisions="off")
    _, left = _left_between_two_passes(part, req, 0.3, res_mm)
    assert left.max() <= h + res_mm
    assert left.max() < 0.3 - res_mm  # the passes cut
    assert left.min() >= -req.chord - res_mm  # and did not dig into the hub


def test_hub_semi_finishing_leaves_the_hub_allowance_on_the_stock(part):
    """Issue 23 item 2 for the hub: with a hub allowance a the passes run on the hub offset
    by a. Measured independently: the ball centres lie ρ + a from the part's own hub
    profile, and on a stock 0.6 mm above the part the hub keeps between a − chord and
    a + scallop (± the stock's resolution) between two passes — the passes cut, but no
    deeper than the allowance."""
    res_mm, h, a = 0.15, 0.15, 0.25
    req = HubRequest(tool_diameter=2 * RHO, scallop=h, extend=4.0, allowance=0.4,
                     hub_allowance=a, collisions="off")
    path, left = _left_between_two_passes(part, req, 0.6, res_mm)
    centres = np.vstack([c.cc[5:-5] + RHO * c.normal[5:-5] for c in path.curves])
    inside = _profile_distance(centres, part)
    z = (centres - part.axis.o) @ part.axis.d
    hz = part.hub_profile[:, 1]
    within = (z > hz.min() + RHO + 1.0) & (z < hz.max() - RHO - 1.0)
    assert within.sum() > 100
    assert np.abs(inside[within] - (RHO + a)).max() <= 1e-3
    assert path.stats["hub_allowance_mm"] == a
    assert path.stats["hub_left_min_mm"] == pytest.approx(a, abs=1e-3)
    assert left.max() <= a + h + res_mm
    assert left.max() < 0.6 - res_mm  # the passes cut
    assert left.min() >= a - req.chord - res_mm  # and left the allowance


def test_hub_offset_that_folds_is_refused():
    """A concave bend of the hub profile tighter than the offset is refused by name; a gentle
    one is offset exactly (every segment moved a along its normal)."""
    from blisk_cam.core.errors import PartError
    from blisk_cam.core.geometry.axis import Axis
    from blisk_cam.core.hub.surface import HubSurface
    axis = Axis(np.zeros(3), np.array([0.0, 0.0, 1.0]))
    # (r, z): a notch 0.5 mm deep and 1 mm wide in a hub at r 100
    notch = HubSurface(np.array([[100.0, -20.0], [100.0, -0.5], [99.5, 0.0], [100.0, 0.5],
                                 [100.0, 20.0]]), axis)
    with pytest.raises(PartError, match="folds over itself"):
        notch.offset(2.0)
    gentle = HubSurface(np.array([[100.0, -20.0], [102.0, 0.0], [103.0, 20.0]]), axis)
    off = gentle.offset(0.7)
    pts = off.point(np.linspace(1.0, off.length - 1.0, 200), np.zeros(200))
    assert np.abs(gentle.distance(pts) - 0.7).max() <= 1e-9
    assert gentle.offset(0.0) is gentle


def test_two_regions_space_the_ring_beside_the_blades_by_its_own_stepover(part):
    req = HubRequest(tool_diameter=2 * RHO, stepover=1.5, ring_width=2.0, ring_stepover=0.4,
                     extend=2.0, collisions="off")
    path = run_operation(HUB_FINISH, part, req).path

    def gap(a, b):  # largest distance from a CC point of pass a to pass b
        d = np.linalg.norm(a.cc[:, None, :] - b.cc[None, :, :], axis=2).min(axis=1)
        return float(d.max())
    curves = sorted(path.curves, key=lambda c: c.s)
    ring = gap(curves[0], curves[1])
    middle = gap(curves[len(curves) // 2], curves[len(curves) // 2 + 1])
    assert ring <= 0.4 + 0.05
    assert 0.4 + 0.05 < middle <= 1.5 + 0.05


def test_ball_too_big_for_the_gap_is_refused(part):
    with pytest.raises(ToolError, match="does not fit the gap between the blades at the hub"):
        run_operation(HUB_FINISH, part, HubRequest(tool_diameter=32.0, stepover=2.0,
                                                    collisions="off"))
    with pytest.raises(BliskCamError, match="stepover or a scallop"):
        run_operation(HUB_FINISH, part, HubRequest(tool_diameter=6.0))


# ---------------------------------------------------------------- fillet finishing
def test_fillet_loops_touch_the_fillet_with_a_smaller_ball(part, blade_distance):
    rho = 2.0
    req = HubRequest(tool_diameter=2 * rho, fillet_radius=8.0, layers=2,
                     tilt=math.radians(10.0), collisions="off")
    path = run_operation(FILLET_FINISH, part, req).path
    assert path.operation == "fillet-finish"
    assert len(path.curves) == 2 and all(c.closed for c in path.curves)
    lower, upper = path.curves
    for c in path.curves:
        centre = c.tip + rho * c.axis
        d = _blade_distance(centre, part, blade_distance, 0)
        assert d.min() >= rho - 1e-3  # no gouge of blade or fillet
        assert np.median(d) == pytest.approx(rho, abs=0.02)  # touching it
    # the lower edge: the ball sits on the hub (centre ρ above it, contact on the hub)
    assert np.median(_profile_distance(lower.tip + rho * lower.axis, part)) == \
        pytest.approx(rho, abs=0.02)
    assert np.median(_profile_distance(lower.cc, part)) <= req.chord
    # the upper layer climbs the fillet
    assert _profile_distance(upper.tip + rho * upper.axis, part).min() > rho + 1.0
    with pytest.raises(ToolError, match=r"radius 8 mm, the fillet radius is 8 mm"):
        run_operation(FILLET_FINISH, part, HubRequest(tool_diameter=16.0, fillet_radius=8.0))


# ---------------------------------------------------------------- the command line
def test_hub_command_writes_the_paths_json_and_refuses_a_big_ball(part, tmp_path, capsys):
    import sys

    sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parents[1]))
    from support.mesh_files import write_binary_stl

    from blisk_cam.cli.main import main

    stl = write_binary_stl(tmp_path / "blade.stl", part.blade_vertices, part.blade_faces)
    csv = tmp_path / "hub.csv"
    csv.write_text("".join(f"{r}, {z}\n" for r, z in part.hub_profile))
    out = tmp_path / "hub.json"
    base = ["hub", "--part", str(stl), "--hub-profile", str(csv), "--blade-count", "24"]
    assert main(base + ["--tool-diameter", "6", "--stepover", "2", "--collisions", "off",
                        "--out", str(out)]) == 0
    d = json.loads(out.read_text())
    assert d["operation"] == "hub-finish" and "program" in d
    capsys.readouterr()
    assert main(base + ["--operation", "fillet", "--tool-diameter", "20", "--fillet-radius",
                        "8", "--out", str(tmp_path / "f.json")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "fillet radius is 8 mm" in err[0]
    assert not (tmp_path / "f.json").exists()
    # the fillet pass leaves no stock on the hub: a hub allowance there is refused by name
    assert main(base + ["--operation", "fillet", "--tool-diameter", "6", "--fillet-radius",
                        "8", "--hub-allowance", "0.1", "--out", str(tmp_path / "f.json")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--hub-allowance" in err[0]
    assert not (tmp_path / "f.json").exists()


def test_all_gaps_are_gap_zero_turned_by_the_pitch(part, hub_result):
    from blisk_cam.core.process.hub_finish import pattern_gaps

    _, res = hub_result
    path = res.path
    curves, prog = pattern_gaps(path.curves, path.program, part)
    n, k = part.blade_count, len(path.curves)
    assert len(curves) == n * k
    for g in (1, n - 1):
        turned = rotate_about(path.curves[0].tip, part.axis.d, g * part.pitch, part.axis.o)
        assert np.abs(curves[g * k].tip - turned).max() < 1e-9
    # every pass pose is in the program once per gap, the curve indices point at its copy
    cut = prog.curve >= 0
    assert np.allclose(prog.tip[cut], np.vstack([curves[c].tip[i] for c, i in
                                                 zip(prog.curve[cut], prog.index[cut],
                                                     strict=True)]))
    # rapids between two points outside the blade tips stay outside all along (the arcs
    # between gaps are sampled so their chords do not dip into the blades)
    r_top = float(part.envelope[:, 0].max())
    r, _, _ = theta_about(prog.tip, part.axis)
    both = (prog.move[1:] == 4) & (r[1:] > r_top) & (r[:-1] > r_top)
    mid = 0.5 * (prog.tip[1:] + prog.tip[:-1])[both]
    rm, _, _ = theta_about(mid, part.axis)
    assert both.sum() >= n - 1 and rm.min() > r_top


def test_fillet_axis_aimed_through_the_channel_keeps_the_shank_off_the_leaning_wall(
        part, blade_distance):
    """A Ø6 ball on a Ø5 shank to 100 mm, then a Ø16 holder, along the demo's lower fillet
    edge: with the hub normal tilted 20° off the wall the shank runs into the leaning wall
    (measured here: points on the shank axis closer to a blade than the shank radius); aimed
    through the blade tips' gap on each side (axis mode "channel", no tilt) it stays a shank
    radius + the safety off blade 0 and both neighbours at every pose."""
    holder = ((12.0, 2.5), (100.0, 2.5), (100.0, 8.0), (160.0, 8.0))

    def shank_gap(path):
        gaps = []
        for c in path.curves:
            z = np.linspace(12.0, 100.0, 45)
            P = (c.tip[:, None, :] + z[None, :, None] * c.axis[:, None, :]).reshape(-1, 3)
            d = np.min([_blade_distance(P, part, blade_distance, k) for k in (-1, 0, 1)],
                       axis=0)
            gaps.append(d.reshape(len(c.tip), -1).min(axis=1) - 2.5)
        return np.concatenate(gaps)

    kw = dict(tool_diameter=6.0, fillet_radius=8.0, flute_length=12.0, holder=holder,
              collisions="off")
    normal = run_operation(FILLET_FINISH, part, HubRequest(axis_mode="normal",
                                                           tilt=math.radians(20.0), **kw))
    aimed = run_operation(FILLET_FINISH, part, HubRequest(**kw))
    assert shank_gap(normal.path).min() < 0.0  # in the wall
    assert shank_gap(aimed.path).min() >= 1.0 - 0.05  # the safety, to the sampling


# ---------------------------------------------------------------- Rotor 37 × 36 (acceptance 2)
def test_hub_finishing_on_rotor37_of_36_blades_leaves_the_scallop_target_on_the_stock():
    """Rotor 37's blade on its hub cone, patterned to 36 blades (pitch 10°): one gap (the
    others are its copies, test_all_gaps_are_gap_zero_turned_by_the_pitch) finished with a Ø4
    ball for a 0.3 mm scallop, a slim Ø4 shank then a Ø20 holder, 0.35 mm from the blades; run
    on a stock of the part + 0.3 mm. The stock's 0.4 mm cells sample the cusp ridge more than
    five times per stepover (≈ 2.2 mm), missing its peak by at most (0.2)² / (2 · 2) = 0.01 mm;
    along the hub normal the depth is read to res/256. Measured on the stock between the first
    and last pass: the hub keeps at most the target + that 0.01 mm, and does show cusps (a
    measurement that sees nothing fails); no crash; the job's final verdict finds no gouge on
    the blades or the hub (the ball keeps 0.35 mm off the blades' 0.3 mm stock)."""
    from blisk_cam.core.geometry.mesh_io import read_mesh
    from blisk_cam.core.hub.surface import HubSurface
    from blisk_cam.core.part.model import part_from_blade
    from blisk_cam.core.process.hub_finish import plan_channel
    from blisk_cam.core.process.job_verdict import OperationContacts, job_verdict
    from blisk_cam.core.runtime import run_to_end
    from blisk_cam.core.stock.simulation import iter_simulate
    from blisk_cam.core.tool.assembly import ToolAssembly
    from tests.support.blades import blade_meta, blade_stl

    hub = blade_meta("rotor37")["cones"]["hub"]
    a = np.array([hub["P1_xyz_mm"][0], hub["P1_xyz_mm"][2]])
    b = np.array([hub["P2_xyz_mm"][0], hub["P2_xyz_mm"][2]])
    u = (b - a) / np.linalg.norm(b - a)
    mesh = TriMesh.from_arrays(*read_mesh(blade_stl("rotor37")))  # welded
    part = part_from_blade(mesh.V, mesh.F, np.array([a - 15 * u, b + 15 * u]), 36)
    holder = ((20.0, 2.0), (100.0, 2.0), (100.0, 10.0), (160.0, 10.0))
    target, res = 0.3, 0.4
    req = HubRequest(tool_diameter=4.0, scallop=target, extend=3.0, allowance=0.35,
                     holder=holder, flute_length=20.0)
    path = run_operation(HUB_FINISH, part, req).path
    assert path.stats["passes"] >= 5
    stock = stock_from_allowance(part, 0.3, res)
    sim = run_to_end(iter_simulate(part, stock, [path], assembly=ToolAssembly(20.0, holder)))
    assert sim.summary["crashes"] == []
    ch = plan_channel(part, req)
    hs = HubSurface(part.hub_profile, part.axis)
    sel = (ch.m > ch.m_le) & (ch.m < ch.m_te)
    f = np.linspace(0.02, 0.98, 120)
    m = np.repeat(ch.m[sel][::2], len(f))
    th = (ch.theta_a[sel][::2, None] + f[None] * (ch.theta_b - ch.theta_a)[sel][::2, None]).ravel()
    left = deviation_map(sim.stock, hs.point(m, th), hs.normal(m, th))
    assert left.max() <= target + 0.01
    assert np.percentile(left, 99) > 0.3 * target  # the cusps are there and measured
    # no gouge on the blades (fillet included) or the hub where the 0.4 mm grid resolves the
    # part (Rotor 37's 0.1 mm edges it does not: a cut near one takes a whole ray)
    v = job_verdict(part, sim.stock, [OperationContacts.from_path(1, "hub", path)])
    assert not [(z.surface, z.worst_mm) for z in v.zones if z.what == "gouge"]
    assert v.area_unresolved_mm2 < 0.25 * v.area_surface_mm2
