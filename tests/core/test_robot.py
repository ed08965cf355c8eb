"""The robot description and the OPW kinematics: FK(IK(T)) = T for all eight configurations,
each configuration index what it says, and agreement with an independent solver (ikpy: its own
link-chain forward kinematics and a numeric inverse)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from blisk_cam.core.robot import kinematics as K
from blisk_cam.core.robot.description import (
    RobotError,
    known_robots,
    load_robot,
    robot_from_dict,
)


@pytest.fixture(scope="module")
def robot():
    return load_robot("kr120-r2700")


def _random_joints(robot, n, seed):
    rng = np.random.default_rng(seed)
    return rng.uniform(robot.limits[:, 0], robot.limits[:, 1], (n, 6))


def test_presets_load_and_the_angled_head_is_angled():
    names = known_robots()
    assert {"kr120-r2700", "kr120-r2700-angled", "kr120-r2700-holds-blisk"} <= set(names)
    assert load_robot("kr120-r2700-holds-blisk").holds_part
    inline, angled = load_robot("kr120-r2700"), load_robot("kr120-r2700-angled")
    assert inline.head_angle == pytest.approx(0.0, abs=1e-9)
    assert math.degrees(angled.head_angle) == pytest.approx(45.0, abs=1e-3)
    # the tool frame is a rotation (orthonormal, right-handed)
    R = angled.tool[:3, :3]
    assert np.allclose(R.T @ R, np.eye(3), atol=1e-6) and np.linalg.det(R) > 0


def test_home_pose_is_the_arm_geometry(robot):
    """KUKA home A1..A6 = 0, −90, 90, 0, 0, 0: upper arm upright, forearm horizontal; the flange
    at x = a1 + c3 + c4, z = c1 + c2 − a2, looking along +x."""
    p = robot.opw
    T = K.flange_pose(robot, np.radians([0, -90, 90, 0, 0, 0]))
    assert T[:3, 3] == pytest.approx([p["a1"] + p["c3"] + p["c4"], 0, p["c1"] + p["c2"] - p["a2"]])
    assert T[:3, 2] == pytest.approx([1, 0, 0], abs=1e-12)


def test_ik_round_trip_all_eight_configurations(robot):
    q = _random_joints(robot, 400, 1)
    T = K.flange_pose(robot, q)
    Q, ok = K.inverse(robot, T)
    assert ok[:, :4].all()  # a pose the arm reached has its four front solutions
    T2 = K.flange_pose(robot, Q)
    err = np.abs(T2 - T[:, None]).max(axis=(2, 3))
    assert err[ok].max() < 1e-7
    # slot c holds configuration c, and the eight reachable solutions are distinct
    assert np.all(K.configuration(robot, Q)[ok] == np.nonzero(ok)[1])
    both = ok.all(axis=1)
    assert both.sum() > 50
    d = np.abs(K.wrap(Q[both, :, None] - Q[both, None, :])).max(-1)
    assert np.all(d[:, ~np.eye(8, dtype=bool)] > 1e-6)
    # the joints the pose came from are one of the solutions
    back = np.abs(K.wrap(Q - q[:, None])).max(-1)
    assert np.where(ok, back, np.inf).min(axis=1).max() < 1e-7


@pytest.mark.parametrize("name", ["kr120-r2700-angled", "kr120-r2700-holds-blisk"])
def test_flange_of_and_pose_of_are_inverse(name):
    robot = load_robot(name)
    q = _random_joints(robot, 50, 7)
    flange = K.flange_pose(robot, q)
    assert np.abs(robot.flange_of(robot.pose_of(flange)) - flange).max() < 1e-9


def test_out_of_reach_has_no_solution(robot):
    T = np.eye(4)
    T[:3, 3] = [5000.0, 0, 500]
    _, ok = K.inverse(robot, T[None])
    assert not ok.any()


def test_singularity_measures(robot):
    q = np.radians([[10, -90, 90, 30, 0, 40], [10, -90, 90, 30, 25, 40]])
    s = K.singularity(robot, q)
    assert s["wrist"] == pytest.approx([0.0, math.radians(25)])
    # the arm stretched: θ3 + ψ3 = 0
    psi3 = math.atan2(robot.opw["a2"], robot.opw["c3"])
    q_str = K.model_to_joints(robot, np.array([0, 0.3, -psi3, 0, 0.5, 0]))
    assert K.singularity(robot, q_str)["elbow"] == pytest.approx(0.0, abs=1e-12)
    m = K.limit_margin(robot, np.radians([0, -90, 90, 0, 0, 0]))
    assert math.degrees(m[1]) == pytest.approx(50.0)  # A2 −90 within [−140, −5]


# --- an independent solver: ikpy ----------------------------------------------------------------
def _ikpy_chain(robot):
    chain_mod = pytest.importorskip("ikpy.chain")
    link = pytest.importorskip("ikpy.link")
    p = robot.opw

    def joint(name, t, axis):
        return link.URDFLink(name=name, origin_translation=np.array(t, float),
                             origin_orientation=np.zeros(3), rotation=np.array(axis, float))

    links = [link.OriginLink(), joint("j1", [0, 0, 0], [0, 0, 1]),
             joint("j2", [p["a1"], p["b"], p["c1"]], [0, 1, 0]),
             joint("j3", [0, 0, p["c2"]], [0, 1, 0]),
             joint("j4", [p["a2"], 0, p["c3"]], [0, 0, 1]), joint("j5", [0, 0, 0], [0, 1, 0]),
             joint("j6", [0, 0, p["c4"]], [0, 0, 1])]
    return chain_mod.Chain(links, active_links_mask=[False] + [True] * 6)


def test_fk_agrees_with_ikpy_link_chain(robot):
    chain = _ikpy_chain(robot)
    q = _random_joints(robot, 30, 2)
    theta = K.joints_to_model(robot, q)
    theirs = np.array([chain.forward_kinematics(np.r_[0.0, t]) for t in theta])
    assert np.abs(theirs - K.flange_pose(robot, q)).max() < 1e-8


def test_ik_agrees_with_ikpy_numeric_solver(robot):
    """ikpy's numeric IK, started near each of our eight solutions, converges to it (every
    configuration); started from random joints, where it converges it lands on one of ours."""
    chain = _ikpy_chain(robot)
    rng = np.random.default_rng(5)
    q = _random_joints(robot, 3, 4)
    T = K.flange_pose(robot, q)
    Q, ok = K.inverse(robot, T)
    checked = 0
    for i in range(len(T)):
        for c in np.nonzero(ok[i])[0]:
            start = K.joints_to_model(robot, Q[i, c]) + rng.normal(0, 0.03, 6)
            sol = chain.inverse_kinematics_frame(T[i], initial_position=np.r_[0.0, start],
                                                 orientation_mode="all")
            assert np.abs(chain.forward_kinematics(sol) - T[i]).max() < 1e-3
            assert np.abs(K.wrap(K.model_to_joints(robot, sol[1:]) - Q[i, c])).max() < 1e-5
            checked += 1
    assert checked >= 12
    landed = 0
    for i in range(len(T)):
        for _ in range(3):
            sol = chain.inverse_kinematics_frame(
                T[i], initial_position=np.r_[0.0, rng.uniform(-1.5, 1.5, 6)],
                orientation_mode="all")
            if np.abs(chain.forward_kinematics(sol) - T[i]).max() > 1e-3:
                continue  # a local minimum of the numeric solver
            d = np.abs(K.wrap(K.model_to_joints(robot, sol[1:]) - Q[i])).max(-1)
            assert np.where(ok[i], d, np.inf).min() < 1e-5
            landed += 1
    assert landed >= 4


# --- bad descriptions -----------------------------------------------------------------------------
def _good():
    import tomllib

    from blisk_cam.core.robot.description import ROBOTS_DIR

    return tomllib.loads((ROBOTS_DIR / "kr120-r2700.toml").read_text())


def test_missing_parameter_is_named():
    d = _good()
    del d["opw"]["c3"]
    with pytest.raises(RobotError, match="missing 'c3'"):
        robot_from_dict(d)


def test_limit_below_its_lower_bound_is_named():
    d = _good()
    d["joints"]["limits"][4] = [125, -125]
    with pytest.raises(RobotError, match="joint 5 limit -125° is not above its lower bound"):
        robot_from_dict(d)


def test_unknown_key_names_the_nearest():
    d = _good()
    d["opw"]["c5"] = 1.0
    with pytest.raises(RobotError, match="unknown key \\[opw\\] 'c5'; did you mean 'c"):
        robot_from_dict(d)
    d = _good()
    d["tool"]["orgin"] = [0, 0, 1]
    with pytest.raises(RobotError, match="did you mean 'origin'"):
        robot_from_dict(d)


def test_setup_is_checked():
    d = _good()
    d["setup"] = "robot-holds-blisk"
    with pytest.raises(RobotError, match="unknown setup"):
        robot_from_dict(d)
    d["setup"] = "robot-holds-part"
    d["rotary"] = {"axis": [0, 0, 1], "speed": 30}
    with pytest.raises(RobotError, match="remove one"):
        robot_from_dict(d)


def test_unknown_preset_lists_the_known():
    with pytest.raises(RobotError, match="kr120-r2700"):
        load_robot("kr999")


# --- polishing process values ---------------------------------------------------------------
def test_preston_depth_is_the_integral_of_any_contact_pressure():
    """Preston's law integrated over a Hertz-like (elliptical) pressure patch of any length,
    swept at the feed, averaged across the contact width, gives K_p F v / (w v_f)."""
    from scipy.integrate import trapezoid

    from blisk_cam.core.robot.polishing import PolishingProcess

    proc = PolishingProcess(force=20.0, head_rpm=3000.0, head_diameter=20.0,
                            contact_width=5.0, preston=4e-6, feed=600.0)
    v = math.pi * 20.0 * 3000.0 / 60.0  # mm/s
    for length in (2.0, 7.0):
        x = np.linspace(-length / 2, length / 2, 801)
        y = np.linspace(-2.5, 2.5, 801)
        X, Y = np.meshgrid(x, y)
        shape = np.sqrt(np.clip(1 - (2 * X / length) ** 2 - (2 * Y / 5.0) ** 2, 0, None))
        p = shape * 20.0 / trapezoid(trapezoid(shape, x, axis=1), y)  # N/mm², total 20 N
        # a surface point at lateral offset y passes under the patch at the feed (10 mm/s)
        depth_y = 4e-6 * v * trapezoid(p, x, axis=1) / 10.0
        assert trapezoid(depth_y, y) / 5.0 == pytest.approx(proc.removal_depth, rel=1e-3)
    assert proc.removal_depth == pytest.approx(4e-6 * 20 * v / (5 * 10))
    with pytest.raises(RobotError, match="contact width must be > 0"):
        PolishingProcess(20.0, 3000.0, 20.0, 0.0, 4e-6, 600.0)


def test_joint_frames_are_the_rigid_links_ending_at_the_flange(robot):
    """The drawing frames of the arm: the last one is the flange of forward kinematics; the
    links between them keep their lengths (the OPW parameters) in every pose; at home (A2 =
    −90°, A3 = 90°) the joint-2 axis is at (a1, 0, c1) and the elbow straight above it."""
    p = robot.opw
    q = _random_joints(robot, 40, 7)
    F = K.joint_frames(robot, q)
    assert F.shape == (40, 7, 4, 4)
    np.testing.assert_allclose(F[:, 6], K.flange_pose(robot, q), atol=1e-9)
    o = F[:, :, :3, 3]
    d = np.linalg.norm(np.diff(o, axis=1), axis=2)
    np.testing.assert_allclose(d[:, 1], math.hypot(p["a1"], p["c1"]), rtol=1e-12)
    np.testing.assert_allclose(d[:, 2], p["c2"], rtol=1e-12)
    np.testing.assert_allclose(d[:, 3], math.sqrt(p["a2"] ** 2 + p["b"] ** 2 + p["c3"] ** 2),
                               rtol=1e-12)
    np.testing.assert_allclose(d[:, 5], p["c4"], rtol=1e-12)
    R = F[:, :, :3, :3]
    np.testing.assert_allclose(np.swapaxes(R, -1, -2) @ R, np.broadcast_to(np.eye(3), R.shape),
                               atol=1e-12)
    home = K.joint_frames(robot, np.radians([0, -90, 90, 0, 0, 0]))
    assert home[2, :3, 3] == pytest.approx([p["a1"], 0, p["c1"]])
    assert home[3, :3, 3] == pytest.approx([p["a1"], 0, p["c1"] + p["c2"]])


def test_link_meshes_are_found_beside_the_toml_or_named(tmp_path):
    """[meshes]: files relative to the TOML (absolute in the Robot), a scale; a missing file,
    a bad scale and an unknown link key are named."""
    d = _good()
    (tmp_path / "upper.stl").write_bytes(b"\0" * 84)
    d["meshes"] = {"link3": "upper.stl", "scale": 1000.0}
    r = robot_from_dict(d, source=str(tmp_path / "arm.toml"))
    assert r.meshes == ((3, str((tmp_path / "upper.stl").resolve())),)
    assert r.mesh_scale == 1000.0
    assert load_robot("kr120-r2700").meshes == ()
    d["meshes"] = {"link2": "lower.stl"}
    with pytest.raises(RobotError, match="link2 mesh 'lower.stl' not found"):
        robot_from_dict(d, source=str(tmp_path / "arm.toml"))
    d["meshes"] = {"link3": "upper.stl", "scale": 0}
    with pytest.raises(RobotError, match="scale must be > 0"):
        robot_from_dict(d, source=str(tmp_path / "arm.toml"))
    d["meshes"] = {"link7": "upper.stl"}
    with pytest.raises(RobotError, match="unknown key \\[meshes\\] 'link7'"):
        robot_from_dict(d, source=str(tmp_path / "arm.toml"))
