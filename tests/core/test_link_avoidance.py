"""Re-routing of colliding links (issue 10, :mod:`blisk_cam.core.collision.reroute`): measured
truths only.

Scene: one side of the demo blade (24 blades, its neighbours as obstacles), passes up to
mid-span, every link through the clearance cylinder (``direct_link=0``), a Ø6 shank and a
Ø24 holder. The automatic clearance cylinder then lies inside the blades' span and the
planned rapids from the end of a pass back to the start of the next cross the blade: those
links collide. After avoidance every rerouted pose is re-checked by a brute-force distance
of the sampled obstacle triangles to the posed tool outline (plain geometry written here,
sharing no code with the detection), the routes start and end at the cut poses they connect,
the axis turns by a bounded angle per step, and a floor plate under the blisk that blocks
every retract leaves the links unresolved and named.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from blisk_cam.core.collision.avoid import run_collisions
from blisk_cam.core.collision.obstacles import Obstacles, split_faces
from blisk_cam.core.collision.options import CollisionOptions
from blisk_cam.core.collision.reroute import clearance_surface, link_runs
from blisk_cam.core.geometry.axis import Axis, meridional
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.part.cones import Cone
from blisk_cam.core.paths.linking import Clearance
from blisk_cam.core.process.blade_finish import PathRequest, plan_paths
from blisk_cam.core.toolpath.paths_io import path_from_dict, path_to_dict
from blisk_cam.core.toolpath.types import (
    MOVE_APPROACH,
    MOVE_RAPID,
    MOVE_RETRACT,
    STATUS_CORRECTED,
    STATUS_UNRESOLVED,
    Program,
)

N_BLADES = 24
HOLDER = ((12.0, 3.0), (47.0, 3.0), (47.0, 12.0), (107.0, 12.0))  # Ø6 shank, Ø24 holder
SAFETY = 1.0


def _one_side(d):
    """The faces of the demo blade whose normals point in +θ (one side, open passes)."""
    V, F = d.blade_vertices, d.blade_faces
    T = V[F]
    c = T.mean(axis=1)
    n = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])
    th = np.arctan2(c[:, 1], c[:, 0])
    e_th = np.stack([-np.sin(th), np.cos(th), np.zeros_like(th)], axis=1)
    (Vs, Fs), _ = split_faces(V, F, np.einsum("ij,ij->i", n, e_th) > 0)
    return Vs, Fs


@pytest.fixture(scope="module")
def scene():
    d = make_demo_blisk(resolution=0.3, fillet=False, blade_count=N_BLADES)
    Vs, Fs = _one_side(d)
    mesh = TriMesh.from_arrays(Vs, Fs)
    h, t = d.hub_cone, d.tip_cone
    mid = Cone(0.5 * (h.r1 + t.r1), h.z1, 0.5 * (h.r2 + t.r2), h.z2)
    req = PathRequest(axis=d.axis, cone1=h, cone2=mid, tool_type="ball", tool_radius=3.0,
                      cusp=0.6, chord=0.1, axis_mode="radial", radial_tilt=math.radians(20),
                      direct_link=0.0)
    path = plan_paths(mesh, req).path
    opts = CollisionOptions(mode="avoid", method="rotate", blade_count=N_BLADES, neighbours=1,
                            flute_length=12.0, holder=HOLDER, safety=SAFETY)
    blade = (d.blade_vertices, d.blade_faces)  # the whole blade is the obstacle
    out, rep = run_collisions(blade, path, [], opts)
    return d, blade, path, out, rep, opts


# ----------------------------------------------------------------------------- brute force
def _outline_sd(rho, z, outline):
    """(k,) signed distance of meridional points (ρ, z) to the closed polygon ``outline``
    ((q, 2) of (r, z), revolved about ρ = 0): distance to its edges, negative inside (ray
    casting) — 2-D geometry written here, independent of the module under test."""
    P = np.vstack([outline, outline[:1]])
    best = np.full(len(rho), np.inf)
    inside = np.zeros(len(rho), bool)
    for (r0, z0), (r1, z1) in zip(P[:-1], P[1:], strict=True):
        dr, dz = r1 - r0, z1 - z0
        ll = dr * dr + dz * dz
        t = np.clip(((rho - r0) * dr + (z - z0) * dz) / ll if ll > 0 else 0.0, 0.0, 1.0)
        best = np.minimum(best, np.hypot(rho - r0 - t * dr, z - z0 - t * dz))
        cross = (z0 > z) != (z1 > z)
        xr = r0 + (z - z0) * dr / np.where(dz != 0, dz, 1.0)
        inside ^= cross & (rho < xr)
    return np.where(inside, -best, best)


def _tool_outline(cutter, flute_length):
    """Closed (r, z) polygon of the ball flute (radius ρ) with the holder profile above."""
    rho = cutter.radius
    a = np.linspace(-math.pi / 2, 0.0, 31)
    ball = np.stack([rho * np.cos(a), rho + rho * np.sin(a)], axis=1)  # tip (0,0) → (ρ, ρ)
    body = np.array([[r, z] for z, r in HOLDER])
    return (np.vstack([ball, [[rho, flute_length]], [[0.0, flute_length]]]),
            np.vstack([[[0.0, body[0, 1]]], body, [[0.0, body[-1, 1]]]]))


def _brute(obstacles, cutter, tips, axes, flute_on_target, step=0.05):
    """(k,) clearance of posed tools: the smallest signed distance of points on the obstacle
    triangles to the body outline (all obstacles) and to the flute outline (obstacles other
    than the target blade, or all where ``flute_on_target``). Each triangle near a pose gets
    a lower bound (its centroid's distance less its circumradius: the signed distance is
    1-Lipschitz); where the smallest bound is ds + 2 mm or more, that bound is returned (a
    lower bound of the clearance); else the triangles that can beat the best vertex are
    sampled on a barycentric grid finer than ``step``: an upper bound of the true clearance,
    within ``step`` of it."""
    tris = [(i, m.V[m.F]) for i, m in enumerate(obstacles.meshes)]
    T = np.concatenate([t for _, t in tris])
    owner = np.concatenate([np.full(len(t), i) for i, t in tris])
    cen = T.mean(axis=1)
    rad = np.max(np.linalg.norm(T - cen[:, None], axis=2), axis=1)
    tree = cKDTree(cen)
    flute, body = _tool_outline(cutter, 12.0)
    top = HOLDER[-1][0]
    reach = 12.0 + SAFETY + 6.0 + rad.max()
    out = np.full(len(tips), np.inf)

    def sd(P, own, tp, a, ft):
        rel = P - tp
        z = rel @ a
        rho = np.sqrt(np.maximum(np.einsum("ij,ij->i", rel, rel) - z * z, 0.0))
        d = _outline_sd(rho, z, body)
        fl = (own != 0) | ft
        if fl.any():
            d[fl] = np.minimum(d[fl], _outline_sd(rho[fl], z[fl], flute))
        return d

    for i, (tp, a) in enumerate(zip(tips, axes, strict=True)):
        zs = np.arange(0.0, top + 3.0, 3.0)
        near = tree.query_ball_point(tp + zs[:, None] * a, r=reach)
        tj = np.unique(np.concatenate([np.asarray(x, dtype=np.int64) for x in near]))
        if len(tj) == 0:
            continue
        ft = bool(flute_on_target[i])
        lb = sd(cen[tj], owner[tj], tp, a, ft) - rad[tj]
        if lb.min() >= SAFETY + 2.0:  # certainly clear by 2 mm: that bound will do
            out[i] = float(lb.min())
            continue
        dv = sd(T[tj].reshape(-1, 3), np.repeat(owner[tj], 3), tp, a, ft).reshape(-1, 3)
        tj = tj[lb <= dv.min()]
        edge = np.max(np.linalg.norm(T[tj] - np.roll(T[tj], 1, axis=1), axis=2))
        n = max(1, int(math.ceil(edge / step)))
        uu, vv = np.meshgrid(np.arange(n + 1), np.arange(n + 1))
        keep = uu + vv <= n
        W = np.stack([1 - uu[keep] / n - vv[keep] / n, uu[keep] / n, vv[keep] / n], axis=1)
        P = np.einsum("gk,tkj->tgj", W, T[tj]).reshape(-1, 3)
        out[i] = float(sd(P, np.repeat(owner[tj], len(W)), tp, a, ft).min())
    return out


# ----------------------------------------------------------------------------- tests
def _routes(path, out):
    """[(run in the planned program, first row, stop row in the checked program)] of the
    rerouted runs: the checked program's runs whose rows are re-routed (status 1, new)."""
    P = out.program
    res = []
    for r in link_runs(P):
        st = P.collision_status[r.start:r.stop]
        if np.all(st == STATUS_CORRECTED) and r.stop - r.start > 10:
            res.append(r)
    return res


def test_colliding_links_are_rerouted_clear(scene):
    d, blade, path, out, rep, opts = scene
    s = rep.summary()
    assert s["links_colliding"] >= 5, s
    assert s["links_rerouted"] == s["links_colliding"] and s["links_unresolved"] == 0, s
    assert s["link_poses_colliding"] >= s["links_colliding"]
    P, P0 = out.program, path.program
    # no row of a link run collides any more; only pass poses stay unresolved
    assert not np.any((P.curve < 0) & (P.collision_status == STATUS_UNRESOLVED))
    # the summary counts the final program's rows
    assert s["checked_poses"] == len(P) == len(P.clearance) == len(P.rotation_deg)
    assert s["corrected"] == int(np.sum(P.collision_status == STATUS_CORRECTED))
    assert s["unresolved"] == int(np.sum(P.collision_status == STATUS_UNRESOLVED))
    assert np.all(P.clearance[P.collision_status != STATUS_UNRESOLVED] >= SAFETY - 1e-12)
    # the pass rows are the same poses in the same order (only links were replaced)
    on, on0 = P.curve >= 0, P0.curve >= 0
    assert np.array_equal(P.curve[on], P0.curve[on0]) and np.array_equal(P.index[on],
                                                                         P0.index[on0])
    routes = _routes(path, out)
    assert len(routes) == s["links_rerouted"]
    assert sum(r.stop - r.start for r in routes) == s["link_poses_rerouted"]


def test_routes_start_and_end_at_their_cut_poses_and_turn_smoothly(scene):
    d, blade, path, out, rep, opts = scene
    P = out.program
    ax = P.axis / np.linalg.norm(P.axis, axis=1)[:, None]
    clear = clearance_surface(path.program, path.axis)
    step = max(SAFETY, 0.5)
    height = math.hypot(HOLDER[-1][0], 12.0)
    for r in _routes(path, out):
        a, b = r.before, r.after
        assert P.curve[a] >= 0 and P.curve[b] >= 0  # between two pass poses
        rows = np.arange(a, b + 1)  # A, the route, B
        mv = P.move[r.start:r.stop]
        # retract, then rapids on the surface, then approach (B reached by an approach)
        kinds = [int(x) for x in mv[np.r_[True, mv[1:] != mv[:-1]]]]
        assert kinds == [MOVE_RETRACT, MOVE_RAPID, MOVE_APPROACH], kinds
        assert P.move[b] == MOVE_APPROACH
        assert np.all(P.curve[r.start:r.stop] == -1) and np.all(P.index[r.start:r.stop] == -1)
        # the retract leaves A along A's axis, the approach reaches B along B's axis
        ret = np.nonzero(mv == MOVE_RETRACT)[0] + r.start
        app = np.nonzero(mv == MOVE_APPROACH)[0] + r.start
        for rr, end in ((ret, a), (app, b)):
            rel = P.tip[rr] - P.tip[end]
            along = rel @ ax[end]
            assert np.all(along > 0)
            assert np.abs(rel - along[:, None] * ax[end]).max() <= 1e-9
            assert np.abs(ax[rr] - ax[end]).max() <= 1e-12
        # the rapids run on the clearance surface (raised by one constant)
        rap = np.nonzero(mv == MOVE_RAPID)[0] + r.start
        rad, z = meridional(P.tip[rap], path.axis)
        lift = rad - clear.r_at(z)
        assert lift.min() >= -1e-6 and lift.max() - lift.min() <= 1e-6
        # the last retract row and the first approach row's start are on it too
        r_top, z_top = meridional(P.tip[[ret[-1]]], path.axis)
        assert abs(r_top[0] - clear.r_at(z_top[0]) - lift[0]) <= 1e-6
        # bounded per step: the axis turn, and the motion of the tool's farthest point
        turn = np.arccos(np.clip(np.einsum("ij,ij->i", ax[rows[:-1]], ax[rows[1:]]), -1, 1))
        move = np.linalg.norm(np.diff(P.tip[rows], axis=0), axis=1)
        assert turn.max() <= math.radians(2.0) + 1e-9, math.degrees(turn.max())
        assert np.max(move + height * turn) <= step + 1e-9
        # rotation from the planned axis: A's on the retract, B's on the approach
        for rr, end in ((ret, a), (app, b)):
            assert np.allclose(P.rotation_deg[rr], P.rotation_deg[end], atol=1e-9)


def test_rerouted_poses_clear_by_brute_force(scene):
    d, blade, path, out, rep, opts = scene
    P = out.program
    rows = np.concatenate([np.arange(r.start, r.stop) for r in _routes(path, out)])
    ob = Obstacles.build(*blade, d.axis, N_BLADES, 1)
    ax = P.axis[rows] / np.linalg.norm(P.axis[rows], axis=1)[:, None]
    brute = _brute(ob, out.tool, P.tip[rows], ax, P.move[rows] == MOVE_RAPID)
    assert np.all(brute >= SAFETY - 1e-6), (brute.min(), rows[np.argmin(brute)])
    # and the detection agrees with it within the sampling step where it is exact (below
    # ds + 1 mm); above, both say "clear by more than 1 mm"
    clr = P.clearance[rows]
    near = clr < SAFETY + 1.0
    assert np.all(brute[near] >= clr[near] - 1e-6)
    assert np.all(brute[near] <= clr[near] + 0.05 + 1e-6)
    assert np.all(brute[~near] >= SAFETY + 1.0 - 1e-6)
    # the routes do pass close to the blades (the rapids just outside their tips)
    assert np.min(brute) < SAFETY + 5.0, np.min(brute)


def test_json_round_trip_of_rerouted_program(scene):
    d, blade, path, out, rep, opts = scene
    raw = json.loads(json.dumps(path_to_dict(out), allow_nan=False))
    assert raw["version"] == 1
    prog = raw["program"]
    assert len(prog["rotation_deg"]) == len(prog["tip"]) == len(prog["collision_status"])
    col = raw["collision"]
    assert col["links_rerouted"] == rep.links["links_rerouted"] and col["unresolved_links"] == []
    back = path_from_dict(raw)
    assert np.array_equal(back.program.rotation_deg, out.program.rotation_deg)
    assert path_to_dict(back) == path_to_dict(out)


def test_check_mode_reports_colliding_links_and_changes_nothing(scene):
    d, blade, path, out, rep, opts = scene
    chk = CollisionOptions(mode="check", blade_count=N_BLADES, neighbours=1,
                           flute_length=12.0, holder=HOLDER, safety=SAFETY)
    p2, r2 = run_collisions(blade, path, [], chk)
    s = r2.summary()
    assert s["links_rerouted"] == 0 and s["links_unresolved"] == s["links_colliding"] > 0
    assert np.array_equal(p2.program.tip, path.program.tip)
    assert np.array_equal(p2.program.move, path.program.move)
    assert all(u["reason"].startswith("not re-routed") for u in s["unresolved_links"])


def test_no_route_keeps_the_link_unresolved_and_names_it(scene):
    """A floor plate 150 mm under the blisk (a fixture): clear of every cut pose, but every
    retract along the tool axes at the pass ends — which lean down the blisk axis — runs
    into it, on every clearance surface tried. The links stay as planned and are named."""
    d, blade, path, out, rep, opts = scene
    half = 1000.0
    zf = -150.0
    Vp = np.array([[-half, -half, zf], [half, -half, zf], [half, half, zf], [-half, half, zf]])
    plate = ("floor", Vp, np.array([[0, 1, 2], [0, 2, 3]]))
    p3, r3 = run_collisions(blade, path, [plate], opts)
    s = r3.summary()
    assert s["links_colliding"] == rep.links["links_colliding"]
    assert s["links_rerouted"] == 0 and s["links_unresolved"] == s["links_colliding"], s
    P = p3.program
    # nothing dropped: the planned rows, one for one
    assert len(P) == len(path.program)
    assert np.array_equal(P.move, path.program.move)
    st = P.collision_status
    for u in s["unresolved_links"]:
        j = u["row"]
        assert st[j] == STATUS_UNRESOLVED and P.curve[j] == -1
        assert np.allclose(u["tip"], P.tip[j])
        a, b = u["rows"]
        assert a <= j < b and P.curve[a - 1] >= 0
        assert u["from"] == {"curve": int(P.curve[a - 1]), "index": int(P.index[a - 1])}
        assert u["to"] == {"curve": int(P.curve[b]), "index": int(P.index[b])}
        assert "'floor'" in u["reason"] and "retract" in u["reason"], u["reason"]
    # the unresolved rows are counted in the summary (the CLI exits with status 4)
    assert s["unresolved"] == int(np.sum(st == STATUS_UNRESOLVED)) > 0
    # the floor plate itself is far from the cut poses: their statuses are unchanged
    for c3, c1 in zip(p3.curves, out.curves, strict=True):
        assert np.array_equal(c3.collision["status"], c1.collision["status"])


def test_clearance_surface_read_back_from_the_program():
    """A cone clearance surface given to the linking is recovered exactly from the program's
    rows on it; a program with no rows on a surface gets a cylinder 5 mm outside."""
    d = make_demo_blisk(resolution=0.3, fillet=False)
    mesh = TriMesh.from_arrays(d.blade_vertices, d.blade_faces)
    h, t = d.hub_cone, d.tip_cone
    mid = Cone(0.5 * (h.r1 + t.r1), h.z1, 0.5 * (h.r2 + t.r2), h.z2)
    req = PathRequest(axis=d.axis, cone1=h, cone2=mid, tool_type="ball", tool_radius=3.0,
                      cusp=0.8, chord=0.1, direct_link=0.0, clearance_radius=260.0,
                      clearance_z0=5.0, clearance_slope=0.2)
    path = plan_paths(mesh, req).path
    c = clearance_surface(path.program, path.axis)
    z = np.array([-30.0, 0.0, 40.0])
    assert np.allclose(c.r_at(z), Clearance(260.0, 5.0, 0.2).r_at(z), atol=1e-9)
    P = path.program
    cyl = clearance_surface(Program(P.tip[2:5], P.axis[2:5], np.zeros(3, np.int8),
                                    np.zeros(3, np.int64), np.zeros(3, np.int64),
                                    np.zeros(3, np.uint8)), Axis())
    r, _ = meridional(P.tip[2:5], Axis())
    assert cyl.slope == 0 and cyl.radius == pytest.approx(r.max() + 5.0)


def test_rerouted_path_checked_again_keeps_its_routes(scene):
    """The checked path, checked again (as the Blender operator does with a stored path): its
    routes collide nowhere, so nothing is re-routed and the rows stay."""
    d, blade, path, out, rep, opts = scene
    chk = CollisionOptions(mode="check", blade_count=N_BLADES, neighbours=1,
                           flute_length=12.0, holder=HOLDER, safety=SAFETY)
    p2, r2 = run_collisions(blade, out, [], chk)
    s = r2.summary()
    assert s["link_runs"] == rep.links["link_runs"] and s["links_colliding"] == 0, s
    P, P2 = out.program, p2.program
    assert np.array_equal(P2.tip, P.tip) and np.array_equal(P2.move, P.move)
    link = P.curve < 0
    assert not np.any(P2.collision_status[link] == STATUS_UNRESOLVED)
    # the same detection on the retract and approach rows; on the rapids the re-routing
    # counted the flute against the target blade too, so it measured no more than the
    # plain check does (exact below ds + 1 mm)
    rap = P.move == MOVE_RAPID
    assert np.array_equal(P2.clearance[link & ~rap], P.clearance[link & ~rap])
    near = link & rap & (P.clearance < SAFETY + 1.0)
    assert np.all(P2.clearance[near] >= P.clearance[near] - 1e-9)
