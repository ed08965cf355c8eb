"""Semi-finishing (issue 23, item 2): blade finishing that leaves an allowance a on the blade.

Measured truths, each by a means the planner does not use:

* the grown cutter is the Minkowski sum of the cutter and a ball of radius a: a point's
  signed distance to the cutter is its distance to the grown cutter (a lower on the same
  axis) plus a;
* demo blade, a = 0.1 mm: a ball's centres lie R + a from the blade mesh and a bull nose's
  corner-circle ring r + a (exact point-to-triangle distances, ``geometry.distance``); the CC
  points lie a from the blade and the blade points under the first and last pass on cone 1
  and cone 2;
* the stock simulation (``core.stock``: the part plus 0.5 mm, a few passes run through it,
  the deviation along the vertex normals) leaves between a − chord − resolution and
  a + cusp + chord + resolution on the blade where those passes cover it, its median within
  a − chord … a + cusp + chord (a path that ignored the allowance would leave about 0);
* the verifier passes the path with material left between a − chord and a + cusp + chord;
* bad input (a negative allowance, one the blade's concave radius cannot take, one wider
  than half the gap to the neighbour blade) is refused with a message naming it.

Cheap on purpose: the demo blade at mesh resolution 0.5, the region between the morphs at
0.4 and 0.6 of the demo's cones, a 0.15 mm stock and 4 passes × 20 poses of each program.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from blisk_cam.cli import main as cli
from blisk_cam.core.errors import ToleranceError, ToolError
from blisk_cam.core.geometry.distance import MeshDistance
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.geometry.vectors import rotation_matrix
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.part.model import part_from_demo
from blisk_cam.core.part.profiles import morph_between
from blisk_cam.core.process.blade_finish import (
    PathRequest,
    check_allowance_in_channel,
    plan_paths,
)
from blisk_cam.core.stock.blank import stock_from_allowance
from blisk_cam.core.stock.deviation import simulation_summary
from blisk_cam.core.stock.removal import RemovalResult, remove_program
from blisk_cam.core.stock.simulation import part_surface
from blisk_cam.core.tool.cutter import Cutter
from blisk_cam.core.toolpath.paths_io import read_paths_json, write_paths_json
from blisk_cam.core.toolpath.types import MOVE_CUT, Program
from blisk_cam.core.verify.measure import verify_path
from blisk_cam.core.verify.verdict import judge, verdict_lines
from tests.support.mesh_files import write_binary_stl
from tests.support.patch import deviation_under_passes, short_flute

A = 0.1  # mm, the allowance of paper 003's semi-finishing
CUSP = CHORD = 0.05
RES = 0.15  # mm, stock resolution
BALL = {}
BULL = {"tool_type": "bull", "tool_diameter": 12.0, "corner_radius": 2.0,
        "lead": math.radians(5.0)}


@pytest.fixture(scope="module")
def demo():
    d = make_demo_blisk(resolution=0.5)
    mesh = TriMesh.from_arrays(d.blade_vertices, d.blade_faces)
    band = morph_between(d.hub_cone, d.tip_cone)
    return d, mesh, band.cone_at(0.4), band.cone_at(0.6)


def _plan(demo, tool, allowance=A):
    d, mesh, c1, c2 = demo
    req = PathRequest(axis=d.axis, cone1=c1, cone2=c2, cusp=CUSP, chord=CHORD,
                      allowance=allowance, **tool)
    return plan_paths(mesh, req).path


@pytest.fixture(scope="module")
def ball_path(demo):
    return _plan(demo, BALL)


@pytest.fixture(scope="module")
def bull_path(demo):
    return _plan(demo, BULL)


# ------------------------------------------------------------------------ the grown cutter
@pytest.mark.parametrize("cutter", [Cutter.ball(6.0), Cutter.bull(6.0, 2.0), Cutter.flat(5.0),
                                    Cutter.taper(3.0, math.radians(3.0))],
                         ids=["ball", "bull", "flat", "taper"])
def test_grown_cutter_is_the_cutter_plus_a_ball(cutter):
    a = 0.3
    grown = cutter.grown(a)
    rng = np.random.default_rng(7)
    axis = np.array([0.2, -0.3, 1.0]) / np.linalg.norm([0.2, -0.3, 1.0])
    tip = np.array([1.0, 2.0, 3.0])
    # points around the cutting part, outside the grown cutter
    P = tip + rng.uniform([-9, -9, -4], [9, 9, 8], size=(4000, 3))
    d_grown = grown.signed_distance(P, tip - a * axis, axis)
    d_real = cutter.signed_distance(P, tip, axis)
    # below the flute top only (the grown flute ends a higher than the real one's cap offset)
    z = (P - tip) @ axis
    keep = (d_grown > 1e-3) & (z < cutter.h - 1.0)
    assert keep.sum() > 500
    np.testing.assert_allclose(d_real[keep], d_grown[keep] + a, atol=1e-9)
    assert grown.type == ("bull" if cutter.type == "flat" else cutter.type)
    assert grown.radius == pytest.approx(cutter.radius + a)
    assert grown.r == pytest.approx(cutter.r + a)
    with pytest.raises(ToolError, match="allowance > 0"):
        cutter.grown(0.0)


# ------------------------------------------------------------------ where the cutter sits
def test_ball_centres_lie_radius_plus_allowance_from_the_blade(demo, ball_path):
    _, mesh, c1, c2 = demo
    md = MeshDistance(mesh)
    R = ball_path.tool.radius
    assert ball_path.tool.type == "ball" and R == 6.0  # the real cutter, not the grown one
    assert ball_path.allowance == A and ball_path.stats["planning_tool_radius"] == R + A
    tip = np.vstack([c.tip for c in ball_path.curves])
    axis = np.vstack([c.axis for c in ball_path.curves])
    dist = md.query(tip + R * axis).distance
    assert np.abs(dist - (R + A)).max() < 1e-3, (dist.min() - R, dist.max() - R)
    # the CC points on the blade offset by a; the blade points under them on the cones
    cc = np.vstack([c.cc for c in ball_path.curves])
    assert np.abs(md.query(cc).distance - A).max() < 1e-3
    lmc = morph_between(c1, c2)
    for c, s in ((ball_path.curves[0], 0.0), (ball_path.curves[-1], 1.0)):
        assert c.s == s
        on_blade = c.cc - A * c.normal
        assert np.abs(lmc.ratio_of_points(on_blade, ball_path.axis) - s).max() < 1e-6


def test_bull_nose_corner_ring_lies_corner_plus_allowance_from_the_blade(demo, bull_path):
    _, mesh, _, _ = demo
    md = MeshDistance(mesh)
    T = bull_path.tool
    assert (T.type, T.radius, T.r) == ("bull", 6.0, 2.0)
    tip = np.vstack([c.tip for c in bull_path.curves])[::4]
    axis = np.vstack([c.axis for c in bull_path.curves])[::4]
    w1 = np.cross(axis, [0.0, 0.0, 1.0])
    w1 /= np.linalg.norm(w1, axis=1)[:, None]
    w2 = np.cross(axis, w1)
    phi = np.linspace(0.0, 2.0 * np.pi, 72, endpoint=False)
    ring = (tip + T.f * axis)[:, None, :] + T.e * (
        np.cos(phi)[None, :, None] * w1[:, None, :] + np.sin(phi)[None, :, None] * w2[:, None, :])
    dist = md.query(ring.reshape(-1, 3)).distance.reshape(len(tip), -1).min(axis=1)
    # the 5° ring sampling finds the nearest ring point to within ~1e-3 mm
    assert np.abs(dist - (T.r + A)).max() < 3e-3, (dist.min() - T.r, dist.max() - T.r)


# -------------------------------------------------------------------- the stock simulation
def _simulate_patch(demo, path, passes=4, poses=20):
    """Run ``poses`` cut poses of ``passes`` passes around the middle of the region through
    the part plus 0.5 mm; the deviation (mm) at the blade vertices those passes cover."""
    d = demo[0]
    part = part_from_demo(d)
    stock = stock_from_allowance(part, 0.5, RES)
    s = np.array([c.s for c in path.curves])
    chosen = np.sort(np.argsort(np.abs(s - 0.5))[:passes])
    mid = path.curves[chosen[0]].cc[len(path.curves[chosen[0]].cc) // 3]
    # the flute cut short; the sweep sampled to 0.01 mm (a tenth of the allowance, far inside
    # the bounds' resolution term)
    cutter = short_flute(path.tool)
    core, core_n = [], []
    for i in chosen:
        c = path.curves[i]
        k = int(np.argmin(np.linalg.norm(c.cc - mid, axis=1)))
        idx = np.arange(k - poses // 2, k + poses // 2) % len(c.cc)
        n = len(idx)
        remove_program(stock, Program(c.tip[idx], c.axis[idx], np.full(n, MOVE_CUT, np.int8),
                                      np.full(n, i), idx, np.zeros(n, np.uint8)),
                       cutter, check_body=False, sweep_tolerance=0.01)
        inner = idx[poses // 4: -poses // 4]
        core.append(c.cc[inner] - path.allowance * c.normal[inner])  # the blade points
        core_n.append(c.normal[inner])
    V, F, N, outer = part_surface(part, RES)
    _, _, hub = part.part_mesh()
    on_blade = np.zeros(len(V), bool)
    on_blade[np.unique(F[~hub])] = True
    ratio = morph_between(path.cone1, path.cone2).ratio_of_points(V, path.axis)
    dev, P = deviation_under_passes(stock, (V, N, outer, on_blade), ratio, s[chosen[1]],
                                    s[chosen[-2]], core, core_n)
    return dev, part, stock, P


@pytest.mark.parametrize("tool", ["ball", "bull"])
def test_stock_left_on_the_blade_is_the_allowance(demo, ball_path, bull_path, tool):
    path = {"ball": ball_path, "bull": bull_path}[tool]
    dev, part, stock, P = _simulate_patch(demo, path)
    lo, hi = A - CHORD, A + CUSP + CHORD
    assert dev.min() >= lo - RES, dev.min()
    assert dev.max() <= hi + RES, dev.max()
    assert lo <= np.median(dev) <= hi, np.median(dev)
    # the simulation's verdict judges gouges against the allowance the programs leave
    tol = CHORD + RES
    judged = simulation_summary(part, stock, RemovalResult(), P, dev, gouge_tolerance=tol,
                                initial_volume=1.0, allowance=A)["deviation_mm"]
    assert judged["allowance"] == A
    assert judged["max_gouge"] == pytest.approx(max(0.0, A - dev.min()))
    assert judged["gouged_vertices"] == int((dev < A - tol).sum()) == 0


# ------------------------------------------------------------------ verify, JSON, errors
def test_verify_judges_the_material_left_against_the_allowance(demo, ball_path):
    _, mesh, _, _ = demo
    report = verify_path(mesh, ball_path)
    assert report.allowance == A
    left = A + report.max_material_left  # on the blade
    assert A - CHORD <= left <= A + CUSP + CHORD
    assert A + np.nanmin(report.sample_values) >= A - CHORD  # nowhere below a − chord
    verdict = judge(report, CUSP, CHORD, ball_path.tool, ball_path)
    assert verdict.passed and verdict.allowance == A
    checks = {c.name: c for c in verdict.checks}
    assert checks["material_left"].bound == pytest.approx(A + CUSP + CHORD)
    assert checks["material_left"].value == pytest.approx(left)
    text = "\n".join(verdict_lines(verdict))
    assert "allowance 0.1 mm" in text and "cut into the allowance" in text


def test_paths_json_records_the_allowance(ball_path, tmp_path):
    f = write_paths_json(ball_path, tmp_path / "semi.json")
    data = json.loads(open(f, encoding="utf-8").read())
    assert data["tolerances"]["allowance"] == A and data["stats"]["allowance"] == A
    back = read_paths_json(f)
    assert back.allowance == A
    np.testing.assert_array_equal(back.curves[0].tip, ball_path.curves[0].tip)
    data["tolerances"]["allowance"] = -0.1
    (tmp_path / "bad.json").write_text(json.dumps(data), encoding="utf-8")
    with pytest.raises(Exception, match="allowance must be ≥ 0"):
        read_paths_json(tmp_path / "bad.json")


def test_a_finishing_path_says_nothing_of_an_allowance(demo, tmp_path):
    d, mesh, c1, c2 = demo
    req = PathRequest(axis=d.axis, cone1=c1, cone2=c2, cusp=0.5, chord=0.2)
    path = plan_paths(mesh, req).path
    data = json.loads(open(write_paths_json(path, tmp_path / "f.json"), encoding="utf-8").read())
    assert data["tolerances"] == {"cusp": 0.5, "chord": 0.2}
    assert "allowance" not in data["stats"] and path.allowance == 0.0


def test_bad_allowances_are_refused(demo, tmp_path, capsys):
    d, mesh, _, _ = demo
    with pytest.raises(ToleranceError, match=r"Allowance \(--allowance\): -0.1 mm is out of "
                                             r"range; the allowance must be ≥ 0 mm"):
        PathRequest(axis=d.axis, allowance=-0.1)
    # the full demo region reaches into the hub fillet (concave radius ≈ 3.3 mm): an
    # allowance of 4 mm would fold the offset blade there
    req = PathRequest(axis=d.axis, cone1=d.hub_cone, cone2=d.tip_cone, allowance=4.0)
    with pytest.raises(ToleranceError, match=r"allowance of 4 mm is more than .* concave "
                                             r"radius .* is 3\.\d\d mm"):
        plan_paths(mesh, req)
    stl = write_binary_stl(tmp_path / "blade.stl", d.blade_vertices, d.blade_faces)
    rc = cli.main(["paths", "--mesh", str(stl), *["--cone1", *map(str, d.hub_cone.as_list())],
                   *["--cone2", *map(str, d.tip_cone.as_list())], "--allowance", "-0.2",
                   "--out", str(tmp_path / "p.json")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc != 0 and len(err) == 1 and "--allowance" in err[0] and "≥ 0 mm" in err[0]
    assert not (tmp_path / "p.json").exists()


def test_an_allowance_wider_than_half_the_channel_is_refused(demo, tmp_path, capsys):
    d, mesh, _, _ = demo
    neighbour = TriMesh.from_arrays(
        (mesh.V - d.axis.o) @ rotation_matrix(d.axis.d, 2 * math.pi / d.blade_count).T
        + d.axis.o, mesh.F)
    brute = MeshDistance(neighbour).query(mesh.V).distance.min()  # every vertex, exactly
    gap = check_allowance_in_channel(mesh, d.axis, d.blade_count, A)
    assert gap == pytest.approx(brute, abs=1e-9)
    with pytest.raises(ToleranceError, match=r"narrowest gap .* is 12\.\d+ mm"):
        check_allowance_in_channel(mesh, d.axis, d.blade_count, 0.5 * gap + 0.01)
    stl = write_binary_stl(tmp_path / "blade.stl", d.blade_vertices, d.blade_faces)
    rc = cli.main(["paths", "--mesh", str(stl), *["--cone1", *map(str, d.hub_cone.as_list())],
                   *["--cone2", *map(str, d.tip_cone.as_list())], "--allowance", "6.5",
                   "--blade-count", str(d.blade_count), "--out", str(tmp_path / "p.json")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 1 and len(err) == 1 and "channel" in err[0], err
    assert not (tmp_path / "p.json").exists()


def test_cli_semi_finishing_writes_and_verifies_the_allowance(demo, tmp_path, capsys):
    d, _, c1, c2 = demo
    stl = write_binary_stl(tmp_path / "blade.stl", d.blade_vertices, d.blade_faces)
    out = tmp_path / "semi.json"
    rc = cli.main(["paths", "--mesh", str(stl), "--cone1", *map(str, c1.as_list()),
                   "--cone2", *map(str, c2.as_list()), "--cusp", "0.2", "--chord", "0.1",
                   "--lead", "5", "--allowance", "0.1", "--verify", "--quiet", "--out", str(out)])
    printed = capsys.readouterr().out
    assert rc == 0, printed
    data = json.loads(out.read_text(encoding="utf-8"))
    assert data["tolerances"]["allowance"] == 0.1 and data["verify"]["allowance"] == 0.1
    left = data["stats"]["verify_max_material_left"]  # on the blade
    assert 0.1 - 0.1 <= left <= 0.1 + 0.2 + 0.1
    assert data["verify"]["checks"]["material_left"]["bound"] == pytest.approx(0.4)
    assert "allowance 0.1 mm" in printed and "material left on the blade" in printed
