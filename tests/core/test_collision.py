"""Collision detection and avoidance (issue 10, paper 004): measured truths only.

Analytic obstacles give exact clearances; the demo blisk in a narrow channel with a large
holder gives real collisions, which avoidance clears or reports — checked again by a brute
force distance computation independent of :mod:`blisk_cam.core.collision`.
"""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.spatial import cKDTree

from blisk_cam.core.collision.avoid import iter_run_collisions, run_collisions
from blisk_cam.core.collision.obstacles import Obstacles
from blisk_cam.core.collision.options import CollisionOptions
from blisk_cam.core.collision.posed_tool import PART_BODY
from blisk_cam.core.collision.scene import CollisionScene, detect_collisions
from blisk_cam.core.errors import BliskCamError, CollisionError
from blisk_cam.core.geometry.axis import Axis
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.geometry.vectors import rotate_about
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.part.cones import Cone
from blisk_cam.core.paths.orientation import lead_tilt_of, local_frames
from blisk_cam.core.process.blade_finish import PathRequest, plan_paths
from blisk_cam.core.tool.assembly import AssemblyError, ToolAssembly
from blisk_cam.core.tool.cutter import Cutter
from blisk_cam.core.toolpath.paths_io import (
    path_from_dict,
    path_to_dict,
    read_paths_json,
    write_paths_json,
)
from blisk_cam.core.toolpath.types import (
    MOVE_CUT,
    STATUS_CLEAR,
    STATUS_CORRECTED,
    STATUS_UNRESOLVED,
)
from blisk_cam.core.verify.measure import verify_path

FAR_BLADE = (np.array([[1000.0, 0, 0], [1001, 0, 0], [1000, 1, 0]]), np.array([[0, 1, 2]]))


def _plane_x(x0, half=500.0):
    """Two big triangles of the plane x = x0 (vertices ``half`` mm out)."""
    V = np.array([[x0, -half, -half], [x0, half, -half], [x0, half, half], [x0, -half, half]])
    return V, np.array([[0, 1, 2], [0, 2, 3]])


def _scene(extra, assembly, cutter=None):
    ob = Obstacles.build(*FAR_BLADE, Axis(), 2, 0, extra=extra)
    return CollisionScene(ob, cutter or Cutter.ball(3.0), assembly)


SHANK = ToolAssembly(20.0, ((20.0, 5.0), (60.0, 5.0), (60.0, 10.0), (100.0, 10.0)), 1.0)


# ----------------------------------------------------------------------------- analytic
def test_cylinder_against_plane_exact():
    """Shank Ø10 to 60 mm, holder Ø20 to 100 mm, axis +z, plane x = 20 (two 1000 mm
    triangles: every vertex ≥ 500 mm away, only their interiors come close)."""
    sc = _scene([("plane", *_plane_x(20.0))], SHANK)
    x = np.array([0.0, 3.0, 9.5, 9.9995, 12.0, 14.0])
    tips = np.stack([x, np.zeros_like(x), np.zeros_like(x)], 1)
    det = sc.detect(tips, np.tile([0.0, 0.0, 1.0], (len(x), 1)))
    want = np.minimum(20.0 - (x + 10.0), sc.cap)  # the holder's side decides
    assert np.allclose(det.clearance, want, atol=1e-6), det.clearance
    assert det.colliding.tolist() == [False, False, True, True, True, True]
    hit = det.clearance < sc.cap
    assert np.all(det.part[hit] == PART_BODY) and np.all(det.obstacle[hit] == 1)
    assert np.allclose(det.point[hit, 0], 20.0)
    # penetration: negative = depth of the holder's side beyond the plane
    assert det.clearance[-1] == pytest.approx(-4.0, abs=1e-6)
    # far poses are capped at ds + 5, never NaN
    assert det.clearance[0] == sc.cap == 6.0 and det.obstacle[0] == -1


def test_tapered_frustum_against_plane():
    """A cone Ø10 → Ø20 over 40 mm, tilted by its half-angle β so that one generatrix is
    parallel to the plane x = x0: the clearance is x0 minus that generatrix's x (a Ø2 ball
    flute, well inside)."""
    asm = ToolAssembly(20.0, ((20.0, 5.0), (60.0, 10.0)), 1.0)
    beta = math.atan(5.0 / 40.0)
    a = np.array([-math.sin(beta), 0.0, math.cos(beta)])
    x_gen = -20.0 * math.sin(beta) + 5.0 * math.cos(beta)
    for gap in (0.3, 1.7, 4.0):
        sc = _scene([("plane", *_plane_x(x_gen + gap))], asm, Cutter.ball(1.0))
        det = sc.detect(np.zeros((1, 3)), a[None])
        assert det.clearance[0] == pytest.approx(gap, abs=1e-6)
    # the same cone upright: the top rim is nearest, at x = 10
    sc = _scene([("plane", *_plane_x(12.5))], asm, Cutter.ball(1.0))
    det = sc.detect(np.zeros((1, 3)), np.array([[0.0, 0, 1]]))
    assert det.clearance[0] == pytest.approx(2.5, abs=1e-6)


def test_triangle_interior_collision_between_far_vertices():
    """A coarse triangle whose vertices are all > 40 mm from the tool and whose interior is
    0.4 mm from the shank: detected (a vertex-based check would not see it)."""
    V = np.array([[5.4, -60.0, -20.0], [5.4, 60.0, -20.0], [5.4, 0.0, 200.0]])
    sc = _scene([("coarse", V, np.array([[0, 1, 2]]))],
                ToolAssembly(20.0, ((20.0, 5.0), (60.0, 5.0)), 1.0))
    det = sc.detect(np.array([[0.0, 0, 0]]), np.array([[0.0, 0, 1]]))
    assert det.clearance[0] == pytest.approx(0.4, abs=1e-6) and det.colliding[0]
    assert det.point[0, 0] == pytest.approx(5.4) and 20.0 <= det.point[0, 2] <= 60.0
    assert np.min(np.linalg.norm(V - [0.0, 0.0, 40.0], axis=1)) > 40.0


def test_triangle_edge_collision_between_far_vertices():
    """Only an edge's interior comes close (1 mm from a Ø10 shank); the vertices are ≥ 44 mm
    away and the face lies beyond the edge."""
    V = np.array([[6.0, -50.0, 25.0], [6.0, 70.0, 45.0], [50.0, 0.0, 35.0]])
    sc = _scene([("edge", V, np.array([[0, 1, 2]]))],
                ToolAssembly(20.0, ((20.0, 5.0), (60.0, 5.0)), 1.0))
    det = sc.detect(np.array([[0.0, 0, 0]]), np.array([[0.0, 0, 1]]))
    assert det.clearance[0] == pytest.approx(1.0, abs=1e-6)
    assert np.allclose(det.point[0, :2], [6.0, 0.0], atol=1e-4)
    assert np.min(np.linalg.norm(V - det.point[0], axis=1)) > 44.0


def test_flute_ignores_target_blade_but_not_neighbours():
    """The flute cuts the target blade (not a collision); against any other obstacle it
    counts, with the cutter's exact shape."""
    V, F = _plane_x(4.0)
    asm = ToolAssembly(10.0, ((10.0, 2.0), (30.0, 2.0)), 0.5)
    ob = Obstacles.build(V, F, Axis(), 2, 0)  # the plane is the target blade itself
    det = detect_collisions(ob, Cutter.ball(3.0), asm, np.array([[0.0, 0, 0]]),
                            np.array([[0.0, 0, 1]]))
    assert det.clearance[0] == pytest.approx(2.0, abs=1e-6)  # the shank, not the ball (1.0)
    assert det.part[0] == PART_BODY
    # a pose that does not cut (a rapid): the flute counts against the target blade too
    det = CollisionScene(ob, Cutter.ball(3.0), asm).detect(
        np.array([[0.0, 0, 0]]), np.array([[0.0, 0, 1]]), flute_on_target=True)
    assert det.clearance[0] == pytest.approx(1.0, abs=1e-6) and det.part[0] == 0
    assert det.obstacle[0] == 0
    ob = Obstacles.build(*FAR_BLADE, Axis(), 2, 0, extra=[("wall", V, F)])
    det = detect_collisions(ob, Cutter.ball(3.0), asm, np.array([[0.0, 0, 0]]),
                            np.array([[0.0, 0, 1]]))
    assert det.clearance[0] == pytest.approx(1.0, abs=1e-6) and det.part[0] == 0
    # a tilted bull nose: the corner torus is nearest; the exact figure from its profile
    cut = Cutter.bull(3.0, 1.0)
    th = 0.3
    a = np.array([-math.sin(th), 0.0, math.cos(th)])
    det = detect_collisions(ob, cut, asm, np.array([[-1.0, 0, 0]]), a[None])
    prof = cut.profile(20000)
    prof = prof[prof[:, 1] <= 10.0]
    x = -1.0 + prof[:, 0] * math.cos(th) - prof[:, 1] * math.sin(th)  # farthest along +x
    assert det.clearance[0] == pytest.approx(4.0 - x.max(), abs=1e-6)


def test_neighbours_are_rotated_copies():
    V = np.array([[100.0, 0, 0], [110.0, 0, 0], [100.0, 0, 10.0]])
    ob = Obstacles.build(V, np.array([[0, 1, 2]]), Axis(), 8, 2)
    assert ob.names == ["blade", "blade +1", "blade -1", "blade +2", "blade -2"]
    turned = rotate_about(V, Axis().d, math.pi / 4, Axis().o, form="outer")
    assert np.allclose(ob.meshes[1].V, turned)
    assert np.allclose(ob.meshes[4].V[0], [0.0, -100.0, 0.0], atol=1e-9)


# ----------------------------------------------------------------------------- bad input
@pytest.mark.parametrize("kw, words", [
    (dict(blade_count=1), "blade count"),
    (dict(blade_count=4, neighbours=2), "wrap"),
    (dict(blade_count=8, neighbours=-1), "neighbours"),
])
def test_bad_obstacles(kw, words):
    with pytest.raises(CollisionError, match=words):
        Obstacles.build(*FAR_BLADE, Axis(), **kw)


@pytest.mark.parametrize("args, words", [
    ((20.0, ((20.0, 5.0), (15.0, 5.0))), "must not decrease"),
    ((20.0, ((20.0, 5.0), (40.0, -1.0))), "radius must be ≥ 0"),
    ((20.0, ((25.0, 5.0), (40.0, 5.0))), "start at the flute length"),
    ((20.0, ((18.0, 5.0), (40.0, 5.0))), "start at the flute length"),
    ((20.0, ((20.0, 5.0), (40.0, 5.0)), -0.5), "safety distance must be ≥ 0"),
    ((0.0, ((0.0, 5.0), (40.0, 5.0))), "flute length must be > 0"),
])
def test_bad_assembly(args, words):
    with pytest.raises(AssemblyError, match=words) as err:
        ToolAssembly(*args)
    assert isinstance(err.value, (CollisionError, BliskCamError))


def test_obstacle_containing_the_blade():
    d = make_demo_blisk(resolution=0.12, fillet=False)
    V, F = d.blade_vertices, d.blade_faces
    # the whole blisk selected, blade faces included
    with pytest.raises(CollisionError, match="blisk.*remove the blade's faces"):
        Obstacles.build(V, F, d.axis, 24, 1, extra=[("blisk", V, F)])
    # a closed box around the blade
    lo, hi = V.min(0) - 5, V.max(0) + 5
    BV = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                   for z in (lo[2], hi[2])])
    BF = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                   [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    with pytest.raises(CollisionError, match="fixture.*contains the blade"):
        Obstacles.build(V, F, d.axis, 24, 1, extra=[("fixture", BV, BF)])
    # the hub strip is fine
    Obstacles.build(V, F, d.axis, 24, 1, extra=[("hub", d.hub_vertices, d.hub_faces)])


def test_bad_options():
    with pytest.raises(CollisionError, match="mode"):
        CollisionOptions(mode="fix")
    with pytest.raises(CollisionError, match="blade count"):
        CollisionOptions(mode="avoid")
    with pytest.raises(CollisionError, match="max_lead"):
        CollisionOptions(mode="check", blade_count=20, max_lead=math.radians(95))


def test_presets_and_description():
    a = ToolAssembly.shrink_fit(12.0, 24.0, 16.0, 32.0, 80.0)
    assert a.profile[0] == (24.0, 6.0) and a.profile[1] == (40.0, 6.0)
    assert a.max_radius == 16.0
    assert np.all(np.diff([z for z, _ in a.profile]) >= 0)
    txt = a.describe()
    assert "Ø12 shank to 40 mm" in txt and "Ø32 holder to 120 mm" in txt, txt
    p = ToolAssembly.plain_shank(6.0, 18.0, 30.0)
    assert p.profile == ((18.0, 3.0), (48.0, 3.0))
    assert ToolAssembly.from_dict(a.as_dict()) == a


# ----------------------------------------------------------------------------- demo blisk
N_BLADES = 24
HOLDER = ((12.0, 3.0), (47.0, 3.0), (47.0, 12.0), (107.0, 12.0))  # Ø6 shank, Ø24 holder


@pytest.fixture(scope="module")
def channel():
    d = make_demo_blisk(resolution=0.3, fillet=False, blade_count=N_BLADES)
    mesh = TriMesh.from_arrays(d.blade_vertices, d.blade_faces)
    h, t = d.hub_cone, d.tip_cone
    mid = Cone(0.5 * (h.r1 + t.r1), h.z1, 0.5 * (h.r2 + t.r2), h.z2)
    req = PathRequest(axis=d.axis, cone1=h, cone2=mid, tool_type="ball", tool_radius=3.0,
                      cusp=0.3, chord=0.05, axis_mode="radial", radial_tilt=math.radians(20))
    path = plan_paths(mesh, req).path
    opts = CollisionOptions(mode="avoid", method="rotate", blade_count=N_BLADES, neighbours=1,
                            flute_length=12.0, holder=HOLDER, safety=1.0)
    fractions = []
    out, rep = run_collisions(mesh, path, [], opts, progress=fractions.append)
    return d, mesh, path, out, rep, opts, fractions


def _outline_distance(rho, z, outline):
    """(k,) distance from meridional points to a polyline (q, 2) of (r, z) — plain 2-D
    geometry, written here so the check shares no code with the module under test."""
    best = np.full(len(rho), np.inf)
    for (r0, z0), (r1, z1) in zip(outline, outline[1:], strict=False):
        dr, dz = r1 - r0, z1 - z0
        ll = dr * dr + dz * dz
        t = np.clip(((rho - r0) * dr + (z - z0) * dz) / ll if ll > 0 else 0.0, 0.0, 1.0)
        best = np.minimum(best, np.hypot(rho - r0 - t * dr, z - z0 - t * dz))
    return best


def _brute_clearance(obstacles, assembly, cutter, tips, axes, step=0.1):
    """Independent check: every obstacle triangle near the tool is sampled on a barycentric
    grid finer than ``step`` mm; the smallest signed distance of those points to the posed
    body (2-D distance to its outline, inside where ρ < r(z)) and, for obstacles other than
    the target blade, to the posed cutter (its own exact distance) is returned per pose —
    an upper bound of the true clearance, within ``step`` of it."""
    tris = [(i, m.V[m.F]) for i, m in enumerate(obstacles.meshes)]
    T = np.concatenate([t for _, t in tris])
    owner = np.concatenate([np.full(len(t), i) for i, t in tris])
    cen = T.mean(1)
    rad = np.max(np.linalg.norm(T - cen[:, None], axis=2), axis=1)
    tree = cKDTree(cen)
    prof = np.asarray(assembly.profile)
    fl, top = assembly.flute_length, prof[-1, 0]
    outline = np.vstack([[prof[0, 1] * 0.0, fl], prof[:, ::-1], [0.0, top]])
    out = np.full(len(tips), np.inf)
    reach = assembly.max_radius + 6.0 + rad.max()
    for i, (tp, a) in enumerate(zip(tips, axes, strict=True)):
        zs = np.arange(0.0, top + 2.0, 2.0)
        near = tree.query_ball_point(tp + zs[:, None] * a, r=reach)
        tj = np.unique(np.concatenate([np.asarray(x, dtype=np.int64) for x in near]))
        if len(tj) == 0:
            continue
        edge = np.max(np.linalg.norm(T[tj] - np.roll(T[tj], 1, axis=1), axis=2))
        n = max(1, int(math.ceil(edge / step)))
        uu, vv = np.meshgrid(np.arange(n + 1), np.arange(n + 1))
        keep = uu + vv <= n
        bu, bv = uu[keep] / n, vv[keep] / n
        W = np.stack([1 - bu - bv, bu, bv], 1)  # (g, 3)
        P = np.einsum("gk,tkj->tgj", W, T[tj])  # (t, g, 3)
        own = np.repeat(owner[tj], len(W))
        P = P.reshape(-1, 3)
        rel = P - tp
        z = rel @ a
        rho = np.sqrt(np.maximum(np.einsum("ij,ij->i", rel, rel) - z * z, 0.0))
        d = _outline_distance(rho, z, outline)
        inside = (z > fl) & (z < top) & (rho < np.interp(z, prof[:, 0], prof[:, 1]))
        d = np.where(inside, -d, d)
        other = own != 0
        if np.any(other):
            sd = replace(cutter, h=fl).signed_distance(P[other], tp, a)
            d[other] = np.minimum(d[other], sd)
        out[i] = float(d.min())
    return out


def test_demo_channel_avoidance(channel):
    d, mesh, path, out, rep, opts, fractions = channel
    s = rep.summary()
    assert rep.n_colliding_before > 50, s
    assert rep.n_corrected > 50, s
    assert fractions[-1] == 1.0 and np.all(np.diff(fractions) >= 0)
    # the input path is unchanged
    assert path.collision is None and all(c.collision is None for c in path.curves)
    status = np.concatenate([c.collision["status"] for c in out.curves])
    clear = np.concatenate([c.collision["clearance"] for c in out.curves])
    assert set(np.unique(status)) <= {STATUS_CLEAR, STATUS_CORRECTED, STATUS_UNRESOLVED}
    assert np.all(clear[status != STATUS_UNRESOLVED] >= opts.safety - 1e-9)
    assert np.all(clear[status == STATUS_UNRESOLVED] < opts.safety)
    # never dropped: same pose count, unresolved poses keep the planned pose
    assert [len(c) for c in out.curves] == [len(c) for c in path.curves]
    tip0 = np.vstack([c.tip for c in path.curves])
    tip1 = np.vstack([c.tip for c in out.curves])
    ax0 = np.vstack([c.axis for c in path.curves])
    ax1 = np.vstack([c.axis for c in out.curves])
    un = status == STATUS_UNRESOLVED
    assert np.array_equal(tip1[un], tip0[un]) and np.array_equal(ax1[un], ax0[un])
    # the ball keeps its centre (the contact at the CC point)
    assert np.allclose(tip1 + 3.0 * ax1, tip0 + 3.0 * ax0, atol=1e-9)
    # program rows follow the curves
    P = out.program
    on = P.curve >= 0
    offs = np.concatenate([[0], np.cumsum([len(c) for c in out.curves])])
    g = offs[P.curve[on]] + P.index[on]
    assert np.array_equal(P.tip[on], tip1[g]) and np.array_equal(P.collision_status[on],
                                                                  status[g])
    assert len(P.clearance) == len(P) and rep.n_checked == len(P)
    # rotation angles: measured, and the paper's comparison (Table 1): plane M ≤ normal dir
    first = np.concatenate(rep.curve_rotation_first)
    normal = np.concatenate(rep.curve_rotation_normal)
    both = np.isfinite(first) & np.isfinite(normal)
    assert both.sum() > 20 and np.all(first[both] <= normal[both] + 1e-6)
    rot = np.concatenate([c.collision["rotation"] for c in out.curves])
    corr = status == STATUS_CORRECTED
    assert np.all(rot[corr] > 0) and np.all(rot[status == STATUS_CLEAR] == 0)
    # INDEPENDENT re-check of a sample of the corrected and clear poses (cut moves)
    asm = opts.assembly(out.tool)
    ob = Obstacles.build(mesh.V, mesh.F, d.axis, N_BLADES, 1)
    cut = np.concatenate([c.move == MOVE_CUT for c in out.curves])
    rng = np.random.default_rng(1)
    tight = corr & cut & (clear < opts.safety + 1.0)
    pick = np.concatenate([rng.choice(np.nonzero(tight)[0], 8, replace=False),
                           rng.choice(np.nonzero(corr & cut & ~tight)[0], 5, replace=False),
                           rng.choice(np.nonzero((status == STATUS_CLEAR) & cut)[0], 5,
                                      replace=False)])
    brute = _brute_clearance(ob, asm, out.tool, tip1[pick], ax1[pick])
    assert np.all(brute >= opts.safety - 1e-6), brute
    # and the detection agrees with the brute force within its sampling step where it is
    # exact (below ds + 1 mm); above, both say "clear by more than 1 mm"
    near = clear[pick] < opts.safety + 1.0
    assert near.sum() >= 8
    assert np.all(brute[near] >= clear[pick][near] - 1e-6), (brute, clear[pick])
    assert np.all(brute[near] <= clear[pick][near] + 0.1), (brute, clear[pick])
    assert np.all(brute[~near] >= opts.safety + 1.0 - 1e-6)
    # smoothing: the turn limit is only exceeded where a corrected pose meets one that
    # cannot move (reported)
    assert s["turn_over_limit"] == rep.n_turn_over < 0.15 * sum(len(c) for c in out.curves)
    # the corrected path still machines the blade as planned
    vr = verify_path(mesh, out)
    assert vr.max_gouge <= out.chord, vr.summary()
    assert vr.max_material_left <= out.cusp + out.chord, vr.summary()


def test_check_mode_changes_nothing(channel):
    d, mesh, path, out, rep, opts, _ = channel
    chk = CollisionOptions(mode="check", blade_count=N_BLADES, neighbours=1,
                           flute_length=12.0, holder=HOLDER)
    p2, r2 = run_collisions(mesh, path, [], chk)
    st = np.concatenate([c.collision["status"] for c in p2.curves])
    assert set(np.unique(st)) == {STATUS_CLEAR, STATUS_UNRESOLVED}
    assert r2.n_corrected == 0 and r2.n_unresolved == r2.n_colliding_before \
        == rep.n_colliding_before
    for a, b in zip(p2.curves, path.curves, strict=True):
        assert np.array_equal(a.tip, b.tip) and np.array_equal(a.axis, b.axis)


def test_json_round_trip_and_off(channel, tmp_path):
    d, mesh, path, out, rep, opts, _ = channel
    f = write_paths_json(out, tmp_path / "p.json")
    raw = json.loads(open(f, encoding="utf-8").read())
    assert raw["version"] == 1
    c0 = raw["curves"][0]["collision"]
    assert set(c0) == {"status", "clearance", "rotation_deg"}
    assert raw["program"]["collision_status"] and len(raw["program"]["clearance"]) == \
        len(raw["program"]["tip"])
    top = raw["collision"]
    assert top["checked_poses"] == rep.n_checked and top["unresolved"] == rep.n_unresolved
    assert top["obstacles"]["blade_count"] == N_BLADES and top["safety"] == 1.0
    assert raw["tool"]["assembly"]["profile"] == [list(p) for p in HOLDER]
    back = read_paths_json(f)
    for a, b in zip(back.curves, out.curves, strict=True):
        assert np.array_equal(a.collision["status"], b.collision["status"])
        assert np.array_equal(a.collision["clearance"], b.collision["clearance"])
        assert np.allclose(a.collision["rotation"], b.collision["rotation"], atol=1e-15)
    assert np.array_equal(back.program.collision_status, out.program.collision_status)
    assert path_to_dict(back) == path_to_dict(out)
    # collisions off: the same path object, the same JSON as before, no collision keys
    off, r0 = run_collisions(mesh, path, [], CollisionOptions(mode="off"))
    assert off is path and r0.mode == "off"
    before = json.dumps(path_to_dict(path))
    assert json.dumps(path_to_dict(off)) == before
    # no collision field anywhere (the plan's stats and warnings may name clearance routes)
    d = path_to_dict(off)
    assert "collision" not in d and all("collision" not in c for c in d["curves"])
    assert not {"collision_status", "clearance", "rotation_deg"} & set(d["program"])
    # an old file (no collision fields) still reads
    old = path_to_dict(path)
    assert path_from_dict(old).collision is None


def test_progress_generator(channel):
    d, mesh, path, *_ = channel
    it = iter_run_collisions(mesh, path, [], CollisionOptions(
        mode="check", blade_count=N_BLADES, neighbours=1, flute_length=12.0, holder=HOLDER))
    seen = []
    while True:
        try:
            seen.append(next(it))
        except StopIteration as stop:
            p, r = stop.value
            break
    assert seen[-1] == 1.0 and all(0.0 <= x <= 1.0 for x in seen) and len(seen) >= 3
    assert r.mode == "check"


def test_bull_nose_keeps_its_contact():
    """A bull-nose cutter: corrected axes come with tips recomputed from the CC point, so the
    cutter still touches the surface exactly there; statuses and clearances as for the ball."""
    d = make_demo_blisk(resolution=0.3, fillet=False, blade_count=N_BLADES)
    mesh = TriMesh.from_arrays(d.blade_vertices, d.blade_faces)
    h, t = d.hub_cone, d.tip_cone
    c1 = Cone(0.75 * h.r1 + 0.25 * t.r1, h.z1, 0.75 * h.r2 + 0.25 * t.r2, h.z2)
    c2 = Cone(0.5 * (h.r1 + t.r1), h.z1, 0.5 * (h.r2 + t.r2), h.z2)
    path = plan_paths(mesh, PathRequest(
        axis=d.axis, cone1=c1, cone2=c2, tool_type="bull", tool_radius=3.0, corner_radius=1.0,
        cusp=0.3, chord=0.05, lead=math.radians(8))).path
    opts = CollisionOptions(mode="avoid", blade_count=N_BLADES, neighbours=1,
                            flute_length=12.0, holder=HOLDER)
    out, rep = run_collisions(mesh, path, [], opts)
    assert rep.n_colliding_before > 20 and rep.n_corrected > 20, rep.summary()
    cc = np.vstack([c.cc for c in out.curves])
    tip = np.vstack([c.tip for c in out.curves])
    ax = np.vstack([c.axis for c in out.curves])
    st = np.concatenate([c.collision["status"] for c in out.curves])
    clear = np.concatenate([c.collision["clearance"] for c in out.curves])
    assert np.any(st == STATUS_CORRECTED)
    assert np.abs(out.tool.signed_distance(cc, tip, ax)).max() <= 1e-9
    assert np.all(clear[st != STATUS_UNRESOLVED] >= opts.safety - 1e-9)
    # corrected axes stay within the lead/tilt limits from the normal
    for c in out.curves:
        f, n, k = local_frames(c.cc, c.normal, c.closed)
        lead, tilt = lead_tilt_of(c.axis, f, n, k)
        moved = c.collision["status"] == STATUS_CORRECTED
        assert np.all(np.abs(lead[moved]) <= opts.max_lead + 1e-9)
        assert np.all(np.abs(tilt[moved]) <= opts.max_tilt + 1e-9)



def test_limits_below_the_planned_lean_still_allow_a_turn(channel):
    """The planned axes lean 20° from the normal (radial strategy). With limits of 10° the
    limits cannot hold for any pose, planned or corrected; avoidance may still turn an axis
    as long as it leans no further than planned, and the turned poses are clear."""
    d, mesh, path, *_ = channel
    opts = CollisionOptions(mode="avoid", blade_count=N_BLADES, neighbours=1,
                            flute_length=12.0, holder=HOLDER, safety=1.0,
                            max_lead=math.radians(10), max_tilt=math.radians(10))
    out, rep = run_collisions(mesh, path, [], opts)
    assert rep.n_colliding_before > 20 and rep.n_corrected > 20, rep.summary()
    for c0, c in zip(path.curves, out.curves, strict=True):
        f, n, k = local_frames(c0.cc, c0.normal, c0.closed)
        lead0, tilt0 = lead_tilt_of(c0.axis, f, n, k)
        lead, tilt = lead_tilt_of(c.axis, f, n, k)
        moved = c.collision["status"] == STATUS_CORRECTED
        assert np.all(np.abs(tilt0) > math.radians(10))  # the plan is outside the limits
        assert np.all(np.abs(lead[moved]) <= np.maximum(opts.max_lead, np.abs(lead0[moved])) + 1e-9)
        assert np.all(np.abs(tilt[moved]) <= np.maximum(opts.max_tilt, np.abs(tilt0[moved])) + 1e-9)
        assert np.all(c.collision["clearance"][moved] >= opts.safety - 1e-9)

# ----------------------------------------------------------------------------- rotated copies
def _brute_force(ob, scene, tips, axes):
    """Per pose: the exact minimum of every part's signed distance over every triangle of
    the actual obstacle meshes (the neighbours as the rotated vertex arrays of
    ``Obstacles.build``), each triangle refined on its own — no tree, no turned poses.
    Only triangles whose centroid lies within the tool's reach of its axis segment are
    refined (a conservative cut: the others are farther than the cap). Returns
    (clearance (m,), obstacle (m,))."""
    from blisk_cam.core.collision.tri_tree import _refine

    top = scene.assembly.top
    best = np.full(len(tips), np.inf)
    who = np.full(len(tips), -1)
    for i, mesh in enumerate(ob.meshes):
        T = mesh.V[mesh.F]
        cen = T.mean(1)
        rad = np.max(np.linalg.norm(T - cen[:, None], axis=2), axis=1)
        nrm = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])
        ln = np.linalg.norm(nrm, axis=1)
        for j, (tp, a) in enumerate(zip(tips, axes, strict=True)):
            rel = cen - tp
            z = np.clip(rel @ a, 0.0, top)
            near = np.linalg.norm(rel - z[:, None] * a, axis=1) - rad <= \
                scene.assembly.max_radius + scene.cap + 1.0
            if not near.any():
                continue
            k = int(near.sum())
            for part, _ in scene.parts():
                if part.kind == 0 and i == 0:
                    continue  # the flute cuts the target blade
                d, _ = _refine(part, T[near, 0], T[near, 1], T[near, 2],
                               nrm[near] / ln[near, None], ln[near] > 0,
                               np.tile(tp, (k, 1)), np.tile(a, (k, 1)))
                if d.min() < best[j]:
                    best[j], who[j] = d.min(), i
    return np.minimum(best, scene.cap), np.where(best < scene.cap, who, -1)


def test_turned_pose_queries_equal_brute_force_over_rotated_copies():
    """The neighbours are queried on ONE tree over the blade with the poses turned back by
    their angle: the clearances, obstacle indices, contact points and normals must equal
    the brute-force minimum over the actual rotated copies (random poses on both sides of
    the +1 and −1 neighbour, a blisk axis off the origin and tilted, a holder with a
    taper), to 1e-9 mm wherever the figure is exact (0 ≤ clearance < ds + 1 mm)."""
    d = make_demo_blisk(resolution=0.1, fillet=False, blade_count=N_BLADES)
    rng = np.random.default_rng(7)
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    Q *= np.sign(np.linalg.det(Q))
    shift = np.array([30.0, -20.0, 15.0])
    V = d.blade_vertices @ Q.T + shift
    axis = Axis(tuple(shift), tuple(Q @ np.asarray(d.axis.d)))
    ob = Obstacles.build(V, d.blade_faces, axis, N_BLADES, 1)
    asm = ToolAssembly(12.0, ((12.0, 3.0), (30.0, 3.0), (40.0, 6.0), (70.0, 6.0)), 1.0)
    sc = CollisionScene(ob, Cutter.ball(3.0), asm)
    tips, axes = [], []
    for idx in (1, 2):  # blade +1, blade -1
        m = ob.meshes[idx]
        fn = np.cross(m.V[m.F[:, 1]] - m.V[m.F[:, 0]], m.V[m.F[:, 2]] - m.V[m.F[:, 0]])
        fn /= np.linalg.norm(fn, axis=1)[:, None]
        for f in rng.choice(len(m.F), 40, replace=False):
            p = m.V[m.F[f]].mean(0)
            side = rng.choice([-1.0, 1.0])
            n = side * fn[f]
            a = np.cross(n, rng.normal(size=3))
            a /= np.linalg.norm(a)
            zc = rng.uniform(14.0, 65.0)  # beside the shank, the taper or the holder
            reach = 3.0 if zc < 30.0 else (6.0 if zc > 40.0 else 3.0 + 0.3 * (zc - 30.0))
            tips.append(p + n * (reach + rng.uniform(0.02, 1.9)) - zc * a)
            axes.append(a)
    tips, axes = np.array(tips), np.array(axes)
    det = sc.detect(tips, axes)
    ref, who = _brute_force(ob, sc, tips, axes)
    exact = (ref >= 0.0) & (ref < sc.safety + 1.0)
    assert exact.sum() >= 30 and set(who[exact]) == {1, 2}, (exact.sum(), set(who[exact]))
    assert np.allclose(det.clearance[exact], ref[exact], rtol=0.0, atol=1e-9), \
        np.abs(det.clearance - ref)[exact].max()
    assert np.array_equal(det.obstacle[exact], who[exact])
    # never below the truth where it is known (every figure is the distance to a real point)
    assert np.all(det.clearance[ref >= 0] >= ref[ref >= 0] - 1e-9)
    # penetration is reported as penetration (its depth is an estimate)
    assert np.array_equal(det.clearance < 0, ref < 0)
    # the contact point lies on the actual rotated copy, at the reported distance, and the
    # normal is that triangle's (turned toward the tool axis)
    from blisk_cam.core.geometry.closest import closest_on_triangles

    for j in np.nonzero(exact)[0]:
        m = ob.meshes[who[j]]
        T = m.V[m.F]
        q = closest_on_triangles(np.tile(det.point[j], (len(T), 1)), T[:, 0], T[:, 1], T[:, 2])
        q = q[0] if isinstance(q, tuple) else q
        dist = np.linalg.norm(q - det.point[j], axis=1)
        on = dist < 1e-9  # the triangles holding the point (several on an edge or vertex)
        assert on.any()
        tn = np.cross(T[on, 1] - T[on, 0], T[on, 2] - T[on, 0])
        tn /= np.linalg.norm(tn, axis=1)[:, None]
        assert np.min(np.abs(np.abs(tn @ det.normal[j]) - 1.0)) < 1e-9
        # turned toward the tool axis
        foot = tips[j] + float((det.point[j] - tips[j]) @ axes[j]) * axes[j]
        assert float(det.normal[j] @ (foot - det.point[j])) >= 0
    part_sd = []
    for j in np.nonzero(exact)[0]:
        ds_ = [float(np.min(p_.sd_rz(*_rz(det.point[j], tips[j], axes[j]))))
               for p_, _ in sc.parts() if not (p_.kind == 0 and who[j] == 0)]
        part_sd.append(min(ds_))
    assert np.allclose(part_sd, det.clearance[exact], rtol=0.0, atol=1e-9)


def _rz(x, tip, axis):
    v = np.asarray(x) - tip
    z = float(v @ axis)
    return np.array([math.sqrt(max(float(v @ v) - z * z, 0.0))]), np.array([z])
