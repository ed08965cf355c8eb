"""The axis planner of ``--collisions avoid`` (core/collision/axis_plan.py, issue 25) on a small
demo channel: the turn limit per mm holds between every two consecutive poses, every pose is
clear or unresolved and reported in a range, an unresolved pose with "no axis" has no clear
axis on a fine grid within the lean limits, the ball keeps its centre (contact), verify's
figures hold, and the planner leaves no more poses unresolved than paper 004's rotation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from blisk_cam.core.collision.avoid import run_collisions
from blisk_cam.core.collision.axis_plan import REASON_NO_AXIS, turn_limits
from blisk_cam.core.collision.obstacles import Obstacles
from blisk_cam.core.collision.options import CollisionOptions
from blisk_cam.core.collision.scene import CollisionScene
from blisk_cam.core.errors import CollisionError
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.part.cones import Cone
from blisk_cam.core.paths.orientation import lead_tilt_axes, lead_tilt_of, local_frames
from blisk_cam.core.process.blade_finish import PathRequest, plan_paths
from blisk_cam.core.toolpath.types import STATUS_UNRESOLVED
from blisk_cam.core.verify.measure import verify_path

N_BLADES = 24
HOLDER = ((12.0, 3.0), (40.0, 3.0), (40.0, 12.0), (100.0, 12.0))  # Ø6 shank, Ø24 holder


@pytest.fixture(scope="module")
def case():
    d = make_demo_blisk(resolution=0.3, fillet=False, blade_count=N_BLADES)
    mesh = TriMesh.from_arrays(d.blade_vertices, d.blade_faces)
    h, t = d.hub_cone, d.tip_cone
    mid = Cone(0.65 * h.r1 + 0.35 * t.r1, h.z1, 0.65 * h.r2 + 0.35 * t.r2, h.z2)
    req = PathRequest(axis=d.axis, cone1=h, cone2=mid, tool_type="ball", tool_radius=3.0,
                      cusp=0.3, chord=0.05, axis_mode="radial", radial_tilt=math.radians(20))
    path = plan_paths(mesh, req).path
    out = {}
    for method in ("plan", "rotate"):
        opts = CollisionOptions(mode="avoid", method=method, blade_count=N_BLADES, neighbours=1,
                                flute_length=12.0, holder=HOLDER, safety=1.0)
        out[method] = run_collisions(mesh, path, [], opts) + (opts,)
    return d, mesh, path, out


def test_turn_per_mm_holds_between_consecutive_poses(case):
    """Everywhere, unresolved poses included (issue 25: no two consecutive poses turn more
    than the limit); the report counts no turn over it. The limit measured here
    independently: the planned turn + turn_per_mm × the distance the ball's centre (cc +
    R·n, which every axis of a ball keeps) travels, at least the contact's distance and
    0.05 mm, the added part at most 5° per pose (the default cap). The planner uses that
    length of tool path: some turns exceed what the contact's distance alone would allow."""
    _, _, path, out = case
    new, _, opts = out["plan"]
    rho = path.tool.radius
    checked = beyond_contact = 0
    for c0, c1 in zip(path.curves, new.curves, strict=True):
        a, a0 = np.asarray(c1.axis), np.asarray(c0.axis)
        turn = np.arccos(np.clip(np.einsum("ij,ij->i", a[1:], a[:-1]), -1, 1))
        planned = np.arccos(np.clip(np.einsum("ij,ij->i", a0[1:], a0[:-1]), -1, 1))
        d_cc = np.linalg.norm(np.diff(c0.cc, axis=0), axis=1)
        d_centre = np.linalg.norm(np.diff(c0.cc + rho * c0.normal, axis=0), axis=1)
        limit = planned + np.minimum(opts.turn_per_mm * np.maximum(np.maximum(d_cc, d_centre),
                                                                   0.05), math.radians(5.0))
        assert np.all(turn <= limit + 1e-6), np.degrees((turn - limit).max())
        beyond_contact += int(np.sum(turn > planned + np.minimum(
            opts.turn_per_mm * np.maximum(d_cc, 0.05), math.radians(5.0)) + 1e-6))
        st = np.asarray(c1.collision["status"]) == STATUS_UNRESOLVED
        checked += int(np.sum(st[1:] & st[:-1]))
    assert checked  # pairs of unresolved poses are among them: the check is not idle
    assert beyond_contact  # the tool path's length, not the contact's, bounds the turn
    assert not new.collision.get("turns_between_unresolved")
    assert new.collision.get("turn_over_limit", 0) == 0


def _busiest(path, planned, k=3):
    """``path`` with only its ``k`` passes whose axes ``planned`` turned most often (no
    program): a cheap sub-case where avoidance has work to do."""
    moved = [int(np.sum(np.einsum("ij,ij->i", np.asarray(c0.axis), np.asarray(c1.axis))
                        < 1 - 1e-9)) for c0, c1 in zip(path.curves, planned.curves, strict=True)]
    keep = sorted(np.argsort(moved)[-k:])
    return type(path)(**{**path.__dict__, "curves": [path.curves[i] for i in keep],
                         "program": None})


def _added_turn(before, after):
    """The largest turn (rad) between consecutive poses of ``after`` beyond the planned turn
    of ``before`` there."""
    worst = 0.0
    for c0, c1 in zip(before.curves, after.curves, strict=True):
        a, a0 = np.asarray(c1.axis), np.asarray(c0.axis)
        turn = np.arccos(np.clip(np.einsum("ij,ij->i", a[1:], a[:-1]), -1, 1))
        planned = np.arccos(np.clip(np.einsum("ij,ij->i", a0[1:], a0[:-1]), -1, 1))
        worst = max(worst, float((turn - planned).max(initial=0.0)))
    return worst


def test_the_users_cap_per_pose_holds(case):
    """``--max-turn-per-pose 2`` (CollisionOptions.max_turn): the turn avoidance adds to the
    planned one stays ≤ 2° between any two consecutive poses (the limit per mm still
    applies), measured on the axes; the default 5° cap lets some pairs past 2°."""
    _, mesh, path, out = case
    cap = math.radians(2.0)
    sub = _busiest(path, out["plan"][0])
    opts = CollisionOptions(mode="avoid", blade_count=N_BLADES, neighbours=1, flute_length=12.0,
                            holder=HOLDER, safety=1.0, max_turn=cap)
    new = run_collisions(mesh, sub, [], opts)[0]
    assert _added_turn(sub, new) <= cap + 1e-6
    assert _added_turn(path, out["plan"][0]) > cap  # the default allows more
    assert new.collision["planner"]["max_turn_per_pose_deg"] == pytest.approx(2.0)


def _mean_angle_to(path, planned, direction, mask):
    """Mean angle (rad) of the axes of ``path`` at the poses ``mask`` (over all passes) from
    ``direction`` (3,), or (None) from each pass's mean planned axis (``planned``)."""
    out = []
    for c0, c1 in zip(planned.curves, path.curves, strict=True):
        a, a0 = np.asarray(c1.axis), np.asarray(c0.axis)
        ref = direction if direction is not None else a0.sum(0) / np.linalg.norm(a0.sum(0))
        out.append(np.arccos(np.clip(a @ ref, -1, 1)))
    return float(np.concatenate(out)[mask].mean())


def test_fixed_and_per_pass_references_pull_the_axes_toward_them(case):
    """``--axis-reference fixed --reference-direction X Y Z`` (here the blade's radial
    direction, within the lean limits of most poses) keeps the axes avoidance chooses closer
    to that direction than the planned reference does; ``pass`` closer to each pass's mean
    planned axis (the rotaries move less); the turn limit holds for both. A fixed reference
    without a direction is refused by name."""
    d, mesh, path, out = case
    sub = _busiest(path, out["plan"][0])
    base = dict(mode="avoid", blade_count=N_BLADES, neighbours=1, flute_length=12.0,
                holder=HOLDER, safety=1.0)
    planned = run_collisions(mesh, sub, [], CollisionOptions(**base))[0]
    ax0 = np.vstack([c.axis for c in sub.curves])
    cc = np.vstack([c.cc for c in sub.curves]).mean(0)
    radial = cc - (cc @ np.array(d.axis.d)) * np.array(d.axis.d)
    radial /= np.linalg.norm(radial)
    for reference, direction in (("fixed", radial), ("pass", None)):
        opts = CollisionOptions(**base, axis_reference=reference,
                                reference_direction=None if direction is None
                                else tuple(direction))
        new = run_collisions(mesh, sub, [], opts)[0]
        ax = np.vstack([c.axis for c in new.curves])
        moved = (np.einsum("ij,ij->i", ax, ax0) < 1 - 1e-9) | (
            np.einsum("ij,ij->i", np.vstack([c.axis for c in planned.curves]), ax0) < 1 - 1e-9)
        assert moved.any()
        mine = _mean_angle_to(new, sub, direction, moved)
        theirs = _mean_angle_to(planned, sub, direction, moved)
        assert mine < theirs - math.radians(2), (reference, math.degrees(mine),
                                                 math.degrees(theirs))
        assert new.collision.get("turn_over_limit", 0) == 0
        assert new.collision["planner"]["axis_reference"] == reference
    with pytest.raises(CollisionError, match="Reference Direction"):
        CollisionOptions(**base, axis_reference="fixed")


def test_every_pose_clear_or_in_a_reported_range(case):
    d, mesh, path, out = case
    new, rep, opts = out["plan"]
    ob = Obstacles.build(mesh.V, mesh.F, path.axis, N_BLADES, 1, [])
    scene = CollisionScene(ob, path.tool, opts.assembly(path.tool))
    ranges = new.collision.get("unresolved_ranges", [])
    in_range = set()
    for r in ranges:
        assert r["to"] >= r["from"] and r["why"]
        in_range.update((r["pass"], i) for i in range(r["from"], r["to"] + 1))
    for ci, c in enumerate(new.curves):
        clr = scene.detect(c.tip, c.axis).clearance  # measured again, not read from the path
        st = np.asarray(c.collision["status"])
        for i in np.nonzero(clr < opts.safety)[0]:
            assert st[i] == STATUS_UNRESOLVED and (ci, int(i)) in in_range
        for i in np.nonzero(st == STATUS_UNRESOLVED)[0]:
            assert (ci, int(i)) in in_range


def test_no_axis_means_no_witness_on_a_fine_grid(case):
    """Every pose reported as having no axis within the limits: a 2.5° grid over the whole
    lean box (|lead| ≤ max_lead, |tilt| ≤ max_tilt, or the pose's own lean where planned
    further; the ball's centre kept) holds no clear axis, measured by the detection itself."""
    _, mesh, path, out = case
    new, _, opts = out["plan"]
    ob = Obstacles.build(mesh.V, mesh.F, path.axis, N_BLADES, 1, [])
    scene = CollisionScene(ob, path.tool, opts.assembly(path.tool))
    picked = []
    for r in new.collision.get("unresolved_ranges", []):
        if r["why"] == REASON_NO_AXIS:
            picked += [(r["pass"], i) for i in {r["from"], (r["from"] + r["to"]) // 2, r["to"]}]
    assert picked, "the case has poses no axis clears (the Ø24 holder in a 24-blade channel)"
    rho = path.tool.radius
    for ci, i in picked[:8]:
        c = path.curves[ci]
        f, n, k = local_frames(c.cc, c.normal, c.closed)
        l0, t0 = lead_tilt_of(c.axis[i:i + 1], f[i:i + 1], n[i:i + 1], k[i:i + 1])
        lim_l = max(opts.max_lead, abs(l0[0]))
        lim_t = max(opts.max_tilt, abs(t0[0]))
        L, T = np.meshgrid(np.r_[np.arange(-lim_l, lim_l, math.radians(2.5)), lim_l],
                           np.r_[np.arange(-lim_t, lim_t, math.radians(2.5)), lim_t],
                           indexing="ij")
        lead, tilt = L.ravel(), T.ravel()
        m = len(lead)
        ax = lead_tilt_axes(np.repeat(f[i:i + 1], m, 0), np.repeat(n[i:i + 1], m, 0),
                            np.repeat(k[i:i + 1], m, 0), lead, tilt)
        centre = c.tip[i] + rho * c.axis[i]  # the ball's centre stays (its contact)
        clr = scene.detect(centre - rho * ax, ax).clearance
        assert clr.max() < opts.safety, (ci, i, clr.max())


def test_ball_centre_kept(case):
    _, _, path, out = case
    new = out["plan"][0]
    rho = path.tool.radius
    for c0, c1 in zip(path.curves, new.curves, strict=True):
        c_old = np.asarray(c0.tip) + rho * np.asarray(c0.axis)
        c_new = np.asarray(c1.tip) + rho * np.asarray(c1.axis)
        assert np.abs(c_new - c_old).max() < 1e-9


def test_verify_after_planning(case):
    _, mesh, path, out = case
    new = out["plan"][0]
    rep = verify_path(mesh, new)
    assert rep.max_material_left <= path.cusp + path.chord
    assert rep.max_gouge <= path.chord


def test_no_more_unresolved_than_per_pose_rotation(case):
    _, _, _, out = case

    def unresolved(p):
        return sum(int(np.sum(np.asarray(c.collision["status"]) == STATUS_UNRESOLVED))
                   for c in p.curves)

    assert unresolved(out["plan"][0]) <= unresolved(out["rotate"][0])


def test_reachable_axes_agrees_with_the_joint_solution():
    from dataclasses import replace

    from blisk_cam.core.errors import ReachError
    from blisk_cam.core.machine.description import load_machine
    from blisk_cam.core.machine.kinematics import reachable_axes, solve_poses

    m = load_machine("ac-trunnion")
    A, C = m.rotaries
    m = replace(m, rotaries=(replace(A, limits=(math.radians(20), math.radians(60))), C))
    rng = np.random.default_rng(3)
    ax = rng.normal(size=(300, 3))
    ax /= np.linalg.norm(ax, axis=1)[:, None]
    got = reachable_axes(m, ax)
    for a, ok in zip(ax, got, strict=True):
        try:
            solve_poses(m, np.zeros((1, 3)), a[None])
            want = True
        except ReachError:
            want = False
        assert ok == want, a
    assert got.any() and not got.all()  # the sample has both kinds


def test_avoidance_stays_inside_the_machines_reach(case):
    """Issue 28 row 8: with a machine given, a corrected axis never leaves the rotaries'
    limits (the A range narrowed to the planned axes' own, ± 2°)."""
    from dataclasses import replace

    from blisk_cam.core.machine.description import load_machine
    from blisk_cam.core.machine.kinematics import reachable_axes, solve_poses

    _, mesh, path, out = case
    sub = type(path)(**{**path.__dict__, "curves": path.curves[:2], "program": None})
    ax0 = np.vstack([c.axis for c in sub.curves])
    m = load_machine("ac-trunnion")
    A, C = m.rotaries
    m = replace(m, rotaries=(replace(A, limits=None), C))  # A free to find the planned range
    a = solve_poses(m, np.vstack([c.tip for c in sub.curves]), ax0).angles[:, 0]
    m = replace(m, rotaries=(replace(A, limits=(float(a.min()) - math.radians(2),
                                                float(a.max()) + math.radians(2))), C))
    opts = replace(out["plan"][2], machine=m)
    new, rep = run_collisions(mesh, sub, [], opts)
    ax = np.vstack([c.axis for c in new.curves])
    changed = np.linalg.norm(ax - ax0, axis=1) > 1e-12
    assert changed.any()
    assert reachable_axes(m, ax[changed]).all()


def test_channel_reference_is_the_mid_plane_radial():
    from blisk_cam.core.collision.axis_plan import channel_reference
    from blisk_cam.core.geometry.axis import Axis

    n_blades = 12
    th = np.radians([0.0, 40.0, 200.0])
    cc = np.stack([150 * np.cos(th), 150 * np.sin(th), [5.0, -3.0, 10.0]], 1)
    tangent = np.stack([-np.sin(th), np.cos(th), np.zeros(3)], 1)
    normal = np.array([1.0, -1.0, 1.0])[:, None] * tangent  # facing ±θ
    ref = channel_reference(cc, normal, Axis(), n_blades)
    mid = th + np.array([1.0, -1.0, 1.0]) * math.pi / n_blades
    want = np.stack([np.cos(mid), np.sin(mid), np.zeros(3)], 1)
    assert np.allclose(ref, want, atol=1e-12)


def test_cli_names_the_unresolved_ranges_and_the_hint(case, capsys):
    """The CLI's collision lines read the ranges and the hint from the JSON summary."""
    from types import SimpleNamespace

    from blisk_cam.cli.paths import _collision_lines

    _, _, _, out = case
    new, rep, _ = out["plan"]
    ranges = new.collision["unresolved_ranges"]
    assert ranges and new.collision["tool_hint"]
    got = _collision_lines(SimpleNamespace(collision=rep, path=new))
    text = capsys.readouterr().out
    r = ranges[0]
    assert f"unresolved pass poses in {len(ranges)} range(s): pass {r['pass']} poses " \
        f"{r['from']}–{r['to']} ({r['why']})" in text
    assert f"hint: {new.collision['tool_hint']}" in text
    assert got[0] == rep.n_unresolved


def test_closed_pass_closing_cut_and_motions(case):
    """A closed pass ends with the closing cut back onto its first pose (the program repeats
    pose 0): the turn into it is within the turn limit like any other, its motion is clear or
    a pose at either end reported; and no pose is reported for "the motion from the pose
    before" while both it and the pose before clear and a clear motion between them exists (a
    witness searched on a 5° grid of axes about the planned lean at both poses)."""
    from blisk_cam.core.collision.axis_plan import REASON_MOTION, sample_motion

    _, mesh, path, out = case
    new, _, opts = out["plan"]
    ob = Obstacles.build(mesh.V, mesh.F, path.axis, N_BLADES, 1, [])
    scene = CollisionScene(ob, path.tool, opts.assembly(path.tool))
    closed = [ci for ci, c in enumerate(new.curves) if c.closed and len(c) > 2]
    assert closed
    status = {ci: np.asarray(new.curves[ci].collision["status"]) for ci in closed}
    changed_ends = 0
    tq = np.array([0.25, 0.5, 0.75])
    for ci in closed:
        c0, c1 = path.curves[ci], new.curves[ci]
        a, tip = np.asarray(c1.axis), np.asarray(c1.tip)
        ends = [len(c0) - 1, 0]
        limit = turn_limits(c0.cc[ends], c0.normal[ends], c0.axis[ends],
                            path.tool.corner_radius, opts.turn_per_mm, opts.plan_max_turn)[0]
        turn = math.acos(np.clip(a[-1] @ a[0], -1.0, 1.0))
        assert turn <= limit + 1e-6, (ci, math.degrees(turn), math.degrees(limit))
        mt, ma = sample_motion(tip[-1:], a[-1:], tip[:1], a[:1], tq)
        if scene.detect(mt, ma).clearance.min() < opts.safety:  # reported with either end
            assert STATUS_UNRESOLVED in (status[ci][0], status[ci][-1])
        changed_ends += int(np.linalg.norm(a[[0, -1]] - np.asarray(c0.axis)[[0, -1]]) > 1e-9)
    assert changed_ends  # the case turns axes at the closing cut: the check is not idle
    rho = path.tool.radius
    grid = np.radians(np.arange(-30.0, 30.01, 5.0))
    L, T = (x.ravel() for x in np.meshgrid(grid, grid, indexing="ij"))
    picked = []
    for r in new.collision.get("unresolved_ranges", []):
        if r["why"] == REASON_MOTION and r["from"] > 0:
            picked += [(r["pass"], i) for i in range(r["from"], r["to"] + 1)
                       if new.curves[r["pass"]].collision["status"][i - 1] != STATUS_UNRESOLVED]
    for ci, i in picked[:4]:
        c = path.curves[ci]
        f, n, k = local_frames(c.cc, c.normal, c.closed)
        states = []
        for j in (i - 1, i):
            l0, t0 = lead_tilt_of(c.axis[j:j + 1], f[j:j + 1], n[j:j + 1], k[j:j + 1])
            lim_l, lim_t = max(opts.max_lead, abs(l0[0])), max(opts.max_tilt, abs(t0[0]))
            m = len(L)
            ax = lead_tilt_axes(np.repeat(f[j:j + 1], m, 0), np.repeat(n[j:j + 1], m, 0),
                                np.repeat(k[j:j + 1], m, 0), np.clip(l0[0] + L, -lim_l, lim_l),
                                np.clip(t0[0] + T, -lim_t, lim_t))
            tp = c.tip[j] + rho * c.axis[j] - rho * ax  # the ball's centre stays
            ok = scene.detect(tp, ax).clearance >= opts.safety
            states.append((tp[ok], ax[ok]))
        (tp0, ax0), (tp1, ax1) = states
        lim = turn_limits(c.cc[i - 1:i + 1], c.normal[i - 1:i + 1], c.axis[i - 1:i + 1], rho,
                          opts.turn_per_mm, opts.plan_max_turn)[0]
        ok = ax0 @ ax1.T >= math.cos(lim)
        # the turn limit holds everywhere: a witness must also turn within it from the
        # planned pose before and into the planned pose after the pair
        a_new = np.asarray(new.curves[ci].axis)
        lims = turn_limits(c.cc, c.normal, c.axis, rho, opts.turn_per_mm, opts.plan_max_turn)
        if i >= 2:
            ok &= (ax0 @ a_new[i - 2] >= math.cos(lims[i - 2]))[:, None]
        if i + 1 < len(a_new):
            ok &= (ax1 @ a_new[i + 1] >= math.cos(lims[i]))[None, :]
        p, q = np.nonzero(ok)
        if len(p) == 0:
            continue
        mt, ma = sample_motion(tp0[p], ax0[p], tp1[q], ax1[q], tq)
        motion = scene.detect(mt, ma).clearance.reshape(-1, len(tq)).min(axis=1)
        assert motion.max() < opts.safety, (ci, i, "a clear motion exists")


def test_jumps_and_motions_stay_inside_unresolved_stretches(case):
    """With ``turn_jumps`` the planner may leave the turn limit, but only between two
    consecutive poses that both collide (measured again here), each counted in
    ``turns_between_unresolved``, and it leaves no more poses unresolved than the bounded
    plan; and (either way) a pose is reported for "the motion from the pose before" only when
    that pose before is clear (the motion out of a colliding pose belongs to that pose's
    range)."""
    from dataclasses import replace

    from blisk_cam.core.collision.axis_plan import REASON_MOTION

    _, mesh, path, out = case
    bounded, _, opts = out["plan"]
    # the three passes the bounded plan leaves most poses unresolved on
    worst = np.argsort([-int(np.sum(np.asarray(c.collision["status"]) == STATUS_UNRESOLVED))
                        for c in bounded.curves], kind="stable")[:3]
    sub = type(path)(**{**path.__dict__, "curves": [path.curves[i] for i in worst],
                        "program": None})
    bounded_sub = [bounded.curves[i] for i in worst]
    new, _ = run_collisions(mesh, sub, [], replace(opts, turn_jumps=True))
    ob = Obstacles.build(mesh.V, mesh.F, path.axis, N_BLADES, 1, [])
    scene = CollisionScene(ob, path.tool, opts.assembly(path.tool))
    jumps = 0
    for c0, c1 in zip(sub.curves, new.curves, strict=True):
        a = np.asarray(c1.axis)
        turn = np.arccos(np.clip(np.einsum("ij,ij->i", a[1:], a[:-1]), -1, 1))
        lim = turn_limits(c0.cc, c0.normal, c0.axis, path.tool.corner_radius, opts.turn_per_mm,
                          opts.plan_max_turn)
        over = np.nonzero(turn > lim + 1e-6)[0]
        if len(over):
            clr = scene.detect(c1.tip, c1.axis).clearance
            assert np.all(clr[over] < opts.safety) and np.all(clr[over + 1] < opts.safety)
        jumps += len(over)
    assert jumps  # the case jumps: the check is not idle
    assert new.collision.get("turns_between_unresolved", 0) == jumps

    def unresolved(curves):
        return sum(int(np.sum(np.asarray(c.collision["status"]) == STATUS_UNRESOLVED))
                   for c in curves)

    assert unresolved(new.curves) <= unresolved(bounded_sub)
    for p in (new, bounded):
        for r in p.collision.get("unresolved_ranges", []):
            if r["why"] == REASON_MOTION and r["from"] > 0:
                c = p.curves[r["pass"]]
                i = r["from"] - 1
                assert scene.detect(c.tip[i:i + 1], c.axis[i:i + 1]).clearance[0] >= opts.safety


def test_route_rows_left_out_only_next_to_an_unresolved_pass_end():
    """The rows a route may leave out: the colliding retract rows right after an unresolved
    pass end and the colliding approach rows right before one — nothing else."""
    from blisk_cam.core.collision.reroute import _out_of_lost_ends
    from blisk_cam.core.toolpath.types import MOVE_APPROACH, MOVE_RAPID, MOVE_RETRACT

    mv = np.array([MOVE_RETRACT] * 3 + [MOVE_RAPID] * 3 + [MOVE_APPROACH] * 3)
    clear = np.array([0, 0, 1, 1, 1, 1, 1, 0, 0], bool)
    assert _out_of_lost_ends(clear, mv, (False, False)) is None
    assert _out_of_lost_ends(clear, mv, (True, False)) is None
    keep = _out_of_lost_ends(clear, mv, (True, True))
    assert keep.tolist() == [False, False, True, True, True, True, True, False, False]
    hole = clear.copy()
    hole[4] = False  # a colliding rapid: no route, whatever the ends
    assert _out_of_lost_ends(hole, mv, (True, True)) is None
    late = np.array([1, 0, 1, 1, 1, 1, 1, 1, 1], bool)  # colliding after a clear row
    assert _out_of_lost_ends(late, mv, (True, True)) is None
