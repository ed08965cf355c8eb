"""The robot cell on Rotor 37: the free angle resolved over the path (feasible with the 45°
head, singular ranges with the head on the flange axis), and every program dialect read back
by our own parsers and turned through forward kinematics onto the path's poses; the
orientation conventions against golden vectors."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from blisk_cam.core.robot import kinematics as K
from blisk_cam.core.robot import programs as P
from blisk_cam.core.robot.description import RobotError, load_robot, robot_from_dict
from blisk_cam.core.robot.free_angle import (
    FreeAngleOptions,
    plan_robot,
    strokes_of,
    tool_frames,
)
from blisk_cam.core.robot.orientation import (
    abc_from_matrix,
    matrix_from_abc,
    matrix_from_zyz,
    quaternion_from_matrix,
    zyz_from_matrix,
)
from blisk_cam.core.robot.readers import decode_joints, read_program
from blisk_cam.core.toolpath.types import Program
from tests.support.nc import rotor37_path

GOLDEN_Q = [0.951549, 0.038135, 0.189308, 0.239298]  # KUKA A30 B20 C10 as ABB quaternion


@pytest.fixture(scope="module")
def path():
    return rotor37_path()


@pytest.fixture(scope="module")
def angled():
    return load_robot("kr120-r2700-angled")


@pytest.fixture(scope="module")
def plan(path, angled):
    return plan_robot(angled, path)


def _poses_by_fk(robot, q):
    """Tool tip (n, 3) and paths' axis (n, 3) in the part frame of joints q (n, 6)."""
    F = robot.pose_of(K.flange_pose(robot, q))
    return F[:, :3, 3], -F[:, :3, 2]


def _sliced(path, n):
    """The path with its linked program cut to the first n poses."""
    p = path.program
    cut = {f.name: (None if getattr(p, f.name) is None else getattr(p, f.name)[:n])
           for f in dataclasses.fields(Program)}
    return dataclasses.replace(path, program=Program(**cut))


# --- the free angle -------------------------------------------------------------------------
def test_rotor37_angled_head_is_feasible_and_within_limits(path, plan, angled):
    assert plan.feasible, [b.text() for b in plan.infeasible]
    assert plan.n_poses == len(path.program)
    opt = plan.options
    for s in plan.strokes:
        # forward kinematics of the chosen joints lands on the path's poses
        a, z = s.start, s.start + len(s.q)
        tip, axis = _poses_by_fk(angled, s.q)
        assert np.abs(tip - path.program.tip[a:z]).max() < 1e-6
        assert np.abs(axis - path.program.axis[a:z]).max() < 1e-9
        # one configuration per stroke, joints inside the limits
        assert np.all(K.configuration(angled, s.q) == s.config)
        assert np.all(K.limit_margin(angled, s.q) >= opt.limit_margin - 1e-12)
        # joint steps and joint speeds at the feed
        d = np.abs(np.diff(s.q, axis=0))[s.feed[1:]]
        if len(d) == 0:
            continue
        assert d.max() <= opt.max_joint_step + 1e-12
        dt = np.linalg.norm(np.diff(tip, axis=0), axis=1)[s.feed[1:]] / (opt.feed / 60.0)
        assert np.all(d <= angled.speeds * dt[:, None] + 1e-12)
    wrist = K.singularity(angled, np.vstack([s.q for s in plan.strokes]))["wrist"]
    assert wrist.min() >= opt.min_wrist
    print(f"\nRotor 37, 45° head: min wrist-singularity margin {math.degrees(wrist.min()):.2f}°, "
          f"max joint step {plan.stats['max_joint_step_deg']:.2f}°")
    assert plan.stats["min_wrist_deg"] == pytest.approx(math.degrees(wrist.min()))


def test_rotor37_inline_head_reports_singular_ranges(path):
    inline = load_robot("kr120-r2700")
    plan = plan_robot(inline, path)
    assert not plan.feasible
    reasons = {b.reason for b in plan.infeasible}
    # near the singularity the wrist also spins too fast between the singular poses
    assert "singularity" in reasons and reasons <= {"singularity", "speed"}
    # the ranges are real: every reported pose has the wrist near-singular at every angle;
    # the free angle only turns A6 (the head on the flange axis), so A5 is fixed by the pose
    b = next(b for b in plan.infeasible if b.reason == "singularity")
    _, tip, axis, _ = strokes_of(path)[b.stroke]
    F = tool_frames(tip, axis)[b.first]
    psi = np.linspace(0, 2 * np.pi, 12, endpoint=False)
    wr = []
    for t in psi:
        Rz = np.eye(4)
        Rz[:2, :2] = [[math.cos(t), -math.sin(t)], [math.sin(t), math.cos(t)]]
        flange = inline.part_in_base() @ F @ Rz @ np.linalg.inv(inline.tool)
        Q, ok = K.inverse(inline, flange[None])
        wr.append(K.singularity(inline, Q[0][ok[0]])["wrist"])
    assert np.concatenate(wr).min() < plan.options.min_wrist
    with pytest.raises(RobotError, match="infeasible"):
        P.robot_program(plan, "krl")


def test_a_part_out_of_reach_is_reported_as_reach(path):
    import tomllib

    from blisk_cam.core.robot.description import ROBOTS_DIR

    d = tomllib.loads((ROBOTS_DIR / "kr120-r2700-angled.toml").read_text())
    d["part"]["origin"] = [6000.0, 0.0, 1800.0]
    plan = plan_robot(robot_from_dict(d), _sliced(path, 60))
    assert not plan.feasible and {b.reason for b in plan.infeasible} == {"reach"}


def test_a_feed_too_fast_for_the_joints_is_reported_as_speed(path, angled):
    """Twenty times the polishing feed: the wrist cannot follow the leading edge's turn of the
    axis (the same poses pass at 600 mm/min above)."""
    plan = plan_robot(angled, _sliced(path, 60), FreeAngleOptions(feed=12000.0, samples=12))
    assert not plan.feasible and {b.reason for b in plan.infeasible} == {"speed"}
    with pytest.raises(RobotError, match="infeasible"):
        P.robot_program(plan, "rapid")


# --- programs read back ------------------------------------------------------------------------
@pytest.mark.parametrize("dialect", P.DIALECTS)
def test_program_read_back_reproduces_every_pose(path, angled, dialect):
    small = _sliced(path, 260)
    plan = plan_robot(angled, small, FreeAngleOptions(samples=24))
    assert plan.feasible
    prog = P.robot_program(plan, dialect, P.ProgramOptions(lines=100, force=20.0), small)
    assert len(prog.files) == 1 + math.ceil(260 / 100)  # main + parts
    assert all(t.isascii() for t in prog.files.values())
    read = read_program(dialect, prog.files, prog.main)
    assert len(read.frames) == 260
    assert np.abs(read.part - angled.base @ angled.part_in_base()).max() < 1e-4
    assert np.abs(read.tool - angled.tool).max() < 1e-4
    q = decode_joints(angled, dialect, read)
    # the configuration written selects the planned joints (turns included)
    assert np.abs(q - prog.joints).max() < 1e-5
    tip, axis = _poses_by_fk(angled, q)
    assert np.abs(tip - small.program.tip).max() <= 1e-3 + 5e-5  # 1 µm + print precision
    cosang = np.clip(np.einsum("ij,ij->i", axis, small.program.axis), -1, 1)
    assert np.arccos(cosang).max() <= 1e-5
    # every part file within the controller's size
    n_moves = [sum(1 for ln in t.splitlines() if any(k in ln for k in
               ("PTP ", "LIN ", "MoveJ ", "MoveL ", "MOVE ", ":J P[", ":L P[")))
               for t in prog.files.values()]
    assert max(n_moves) <= 100


def test_robot_holding_the_blisk_at_a_fixed_spindle(path):
    """The robot-holds-part set-up: the flange carries the part; RAPID's robhold work object
    and stationary tool read back onto the path's poses; other dialects refuse clearly."""
    robot = load_robot("kr120-r2700-holds-blisk")
    small = _sliced(path, 120)
    plan = plan_robot(robot, small, FreeAngleOptions(samples=12))
    assert plan.feasible
    q = np.vstack([s.q for s in plan.strokes])
    F = robot.pose_of(K.flange_pose(robot, q))
    assert np.abs(F[:, :3, 3] - small.program.tip).max() < 1e-6
    assert np.abs(-F[:, :3, 2] - small.program.axis).max() < 1e-9
    # the tool stands still in the cell: base · flange · part · pose is the fixed tool frame
    fixed = robot.base @ K.flange_pose(robot, q) @ robot.part @ np.concatenate(
        [s.frame for s in plan.strokes])
    assert np.abs(fixed - robot.tool).max() < 1e-6
    prog = P.robot_program(plan, "rapid", path=small)
    assert "PERS wobjdata wBlisk := [TRUE, TRUE" in prog.files[prog.main]
    assert "PERS tooldata tPolish := [FALSE" in prog.files[prog.main]
    read = read_program("rapid", prog.files, prog.main)
    qd = decode_joints(robot, "rapid", read)
    assert np.abs(qd - prog.joints).max() < 1e-5
    Fd = robot.pose_of(K.flange_pose(robot, qd))
    assert np.abs(Fd[:, :3, 3] - small.program.tip).max() <= 1e-3 + 5e-5
    with pytest.raises(RobotError, match="RAPID"):
        P.robot_program(plan, "krl")


def test_external_rotary_turns_the_part_frame(path):
    """The blisk on a rotary about its own axis, parked at 8°, plans exactly as a part frame
    turned by 8° (built by hand); KRL carries E1 and reads back."""
    import tomllib

    from blisk_cam.core.robot.description import ROBOTS_DIR, with_rotary_angle

    d = tomllib.loads((ROBOTS_DIR / "kr120-r2700-angled.toml").read_text())
    d["rotary"] = {"name": "E1", "axis": [0, 0, 1], "point": [2200, 0, 1800],
                   "limits": [-180, 180], "speed": 60}
    on_rotary = with_rotary_angle(robot_from_dict(d), math.radians(8.0))
    t = math.radians(8.0)
    d2 = {k: v for k, v in d.items() if k != "rotary"}
    d2["part"] = dict(d["part"], x=[-math.cos(t), -math.sin(t), 0.0])
    turned = robot_from_dict(d2)
    small = _sliced(path, 60)
    opt = FreeAngleOptions(samples=12)
    a, b = plan_robot(on_rotary, small, opt), plan_robot(turned, small, opt)
    assert a.feasible and b.feasible
    qa, qb = (np.vstack([s.q for s in x.strokes]) for x in (a, b))
    assert np.abs(qa - qb).max() < 1e-9
    prog = P.robot_program(a, "krl", path=small)
    assert ", E1 8.00000, S '" in prog.files["blisk_p001.src"]
    q = decode_joints(on_rotary, "krl", read_program("krl", prog.files, prog.main))
    assert np.abs(q - prog.joints).max() < 1e-5
    with pytest.raises(RobotError, match="outside its limits"):
        with_rotary_angle(on_rotary, math.radians(200.0))


def test_program_over_the_controller_size_is_an_error(path, angled, monkeypatch):
    plan = plan_robot(angled, _sliced(path, 40), FreeAngleOptions(samples=12))
    monkeypatch.setattr(P, "MAX_PARTS", 5)
    with pytest.raises(RobotError, match="part files"):
        P.robot_program(plan, "krl", P.ProgramOptions(lines=5))


# --- golden vectors through our parsers ---------------------------------------------------
def _one_motion(dialect, pose_text):
    """A minimal program of one joint move, as the writers lay it out."""
    if dialect == "krl":
        main = ("DEF B_MAIN( )\n$BASE = {FRAME: X 0, Y 0, Z 0, A 0, B 0, C 0}\n"
                "$TOOL = {FRAME: X 0, Y 0, Z 0, A 0, B 0, C 0}\nB_P001( )\nEND\n")
        part = f"DEF B_P001( )\n{pose_text}\nEND\n"
        return {"b_main.src": main, "b_p001.src": part}, "b_main.src"
    if dialect == "rapid":
        main = ("MODULE B_MAIN\n  PERS tooldata tPolish := [TRUE, [[0, 0, 0], [1, 0, 0, 0]], "
                "[1, [0, 0, 0], [1, 0, 0, 0], 0, 0, 0]];\n  PERS wobjdata wBlisk := [FALSE, "
                "TRUE, \"\", [[0, 0, 0], [1, 0, 0, 0]], [[0, 0, 0], [1, 0, 0, 0]]];\n"
                "    b_p001;\nENDMODULE\n")
        return {"b_main.mod": main, "b_p001.mod": f"{pose_text}\n"}, "b_main.mod"
    main = ("/MN\n   1:  ! UFRAME 1 = X 0 Y 0 Z 0 W 0 P 0 R 0 ;\n"
            "   2:  ! UTOOL 1 = X 0 Y 0 Z 0 W 0 P 0 R 0 ;\n   3:  CALL B001 ;\n/END\n")
    return {"bmain.ls": main, "b001.ls": pose_text}, "bmain.ls"


def test_golden_orientations_agree_across_dialects():
    krl = _one_motion("krl", "PTP {E6POS: X 1, Y 2, Z 3, A 30, B 20, C 10, S 'B010', T 'B000000'}")
    q = ", ".join(f"{v:.6f}" for v in GOLDEN_Q)
    rapid = _one_motion("rapid", f"    MoveJ [[1, 2, 3], [{q}], [0, 0, 0, 2], [9E9]], v, z, t;")
    fanuc = _one_motion("fanuc-ls", "   1:J P[1] 20% FINE ;\n/POS\nP[1]{\n   GP1:\n\tUF : 1, "
                        "UT : 1,\t\tCONFIG : 'N U T, 0, 0, 0',\n\tX = 1 mm,\tY = 2 mm,\tZ = 3 mm,"
                        "\n\tW = 10 deg,\tP = 20 deg,\tR = 30 deg\n};\n")
    R = [read_program(d, *f).frames[0, :3, :3]
         for d, f in (("krl", krl), ("rapid", rapid), ("fanuc-ls", fanuc))]
    assert np.abs(R[0] - R[1]).max() < 2e-6 and np.abs(R[0] - R[2]).max() < 1e-12
    assert quaternion_from_matrix(R[0]) == pytest.approx(GOLDEN_Q, abs=1e-6)
    # tool straight down ≡ ABB [0, 0, 1, 0]
    down = _one_motion("rapid",
                       "    MoveJ [[0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 0], [9E9]], v, z, t;")
    Rd = read_program("rapid", *down).frames[0, :3, :3]
    assert Rd[:, 2] == pytest.approx([0, 0, -1])
    assert quaternion_from_matrix(np.diag([-1.0, 1.0, -1.0])) == pytest.approx([0, 0, 1, 0])


def test_zyz_tool_down_representation_singularity():
    """Tool straight down (E2 = 180°) spun about z: Comau's E1 and E3 are not separable; the
    writer puts the whole spin in E1 (E3 = 0) and the matrix comes back."""
    for spin in np.radians([0.0, 37.0, -150.0, 180.0]):
        R = matrix_from_abc(spin, 0.0, math.pi)  # z down
        e = zyz_from_matrix(R)
        assert math.degrees(e[1]) == pytest.approx(180.0) and e[2] == 0.0
        assert np.abs(matrix_from_zyz(*e) - R).max() < 1e-12
    rng = np.random.default_rng(0)
    abc = rng.uniform(-math.pi, math.pi, (500, 3)) * [1, 0.5, 1]
    R = matrix_from_abc(*abc.T)
    assert np.abs(matrix_from_zyz(*zyz_from_matrix(R).T) - R).max() < 1e-12
    assert np.abs(matrix_from_abc(*abc_from_matrix(R).T) - R).max() < 1e-12
