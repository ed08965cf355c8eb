"""Forward and closed-form inverse kinematics of an OPW arm, vectorised over poses.

Brandstötter, Angerer, Hofbaur 2014 (the OPW paper, §3): the wrist centre
``c = u − c4 R e_z`` fixes joints 1–3 in closed form (two shoulder × two elbow branches,
Eq. for θ1, θ2, θ3), and the wrist ``R_c^T R = Rz(θ4) Ry(θ5) Rz(θ6)`` gives joints 4–6 (two
wrist branches, θ5 ↔ −θ5): eight configurations. Forward kinematics (§2):

    c_x1 = c2 sin θ2 + k sin(θ2 + θ3 + ψ3) + a1,   c_y1 = b,
    c_z1 = c2 cos θ2 + k cos(θ2 + θ3 + ψ3),        k = √(a2² + c3²), ψ3 = atan2(a2, c3),
    c = Rz(θ1) c_1 + [0, 0, c1],   R = Rz(θ1) Ry(θ2 + θ3) Rz(θ4) Ry(θ5) Rz(θ6),
    u = c + c4 R e_z.

Here θ are the model angles; the controller's joints are ``sign · (θ + offset)``
(:mod:`.description`). Configuration index ``4·shoulder + 2·elbow + wrist`` (bits 0/1):
shoulder 1 when the wrist centre is behind joint 1 (x < 0 in the frame turned by θ1); elbow 1
when θ3 + ψ3 > 0 (the forearm folded one way from the stretched arm); wrist 1 when θ5 < 0.

Singularity measures (radians unless said): wrist — the distance of θ5 from 0 (joint 4 and 6
aligned); elbow — the distance of θ3 + ψ3 from 0 or π (arm stretched or folded);
shoulder — the distance (mm) of the wrist centre from the joint-1 axis.

Lengths mm, angles radians. Poses are (n, 4, 4) flange frames in the robot's base frame.
"""

from __future__ import annotations

import numpy as np

from .description import Robot
from .orientation import _ry, _rz

__all__ = [
    "CONFIG_NAMES",
    "configuration",
    "flange_pose",
    "inverse",
    "joint_frames",
    "joints_to_model",
    "limit_margin",
    "model_to_joints",
    "singularity",
    "wrap",
]

#: configuration index → (shoulder, elbow, wrist) names
CONFIG_NAMES = tuple(
    f"{'back' if s else 'front'}/{'elbow1' if e else 'elbow0'}/{'wrist-' if w else 'wrist+'}"
    for s in (0, 1) for e in (0, 1) for w in (0, 1)
)


def wrap(a):
    """Angles wrapped to (−π, π]."""
    return np.pi - np.mod(np.pi - np.asarray(a), 2.0 * np.pi)


def model_to_joints(robot: Robot, theta) -> np.ndarray:
    """(..., 6) controller joints of model angles θ (radians): ``sign · (θ + offset)``."""
    return robot.signs * (np.asarray(theta) + robot.offsets)


def joints_to_model(robot: Robot, q) -> np.ndarray:
    """(..., 6) model angles θ of controller joints q (radians)."""
    return robot.signs * np.asarray(q) - robot.offsets


def _psi3(p):
    return np.arctan2(p["a2"], p["c3"])


def flange_pose(robot: Robot, q) -> np.ndarray:
    """Forward kinematics: controller joints q (..., 6) radians → flange frames (..., 4, 4) in
    the robot's base frame (module docstring, OPW paper §2)."""
    t = joints_to_model(robot, q)
    p = robot.opw
    k = np.hypot(p["a2"], p["c3"])
    t1, t2, t3, t4, t5, t6 = np.moveaxis(t, -1, 0)
    cx1 = p["c2"] * np.sin(t2) + k * np.sin(t2 + t3 + _psi3(p)) + p["a1"]
    cz1 = p["c2"] * np.cos(t2) + k * np.cos(t2 + t3 + _psi3(p))
    c = np.stack([cx1 * np.cos(t1) - p["b"] * np.sin(t1),
                  cx1 * np.sin(t1) + p["b"] * np.cos(t1), cz1 + p["c1"]], -1)
    R = _rz(t1) @ _ry(t2 + t3) @ _rz(t4) @ _ry(t5) @ _rz(t6)
    T = np.zeros(t.shape[:-1] + (4, 4))
    T[..., :3, :3] = R
    T[..., :3, 3] = c + p["c4"] * R[..., :, 2]
    T[..., 3, 3] = 1.0
    return T


def joint_frames(robot: Robot, q) -> np.ndarray:
    """The frames of the arm's links for drawing it: controller joints q (..., 6) radians →
    (..., 7, 4, 4) frames in the robot's base frame (mm), each rigid with one link:

    0 the base (identity); 1 the carousel, turned by θ1 about the base z; 2 the lower arm, at
    the joint-2 axis ``Rz(θ1) [a1, 0, c1]``, turned by θ2 about y; 3 the upper arm, at the
    elbow (``c2`` along the lower arm's z), turned by θ2 + θ3; 4 and 5 the wrist, at the wrist
    centre (``[a2, b, c3]`` in the upper arm's frame), turned by θ4 and then θ5; 6 the flange
    (``c4`` along frame 5's z, turned by θ6) — equal to :func:`flange_pose` (module docstring,
    OPW paper §2).
    """
    t = joints_to_model(robot, q)
    p = robot.opw
    t1, t2, t3, t4, t5, t6 = np.moveaxis(t, -1, 0)
    shape = t.shape[:-1]

    def frame(R, o):
        T = np.zeros(shape + (4, 4))
        T[..., :3, :3] = R
        T[..., :3, 3] = o
        T[..., 3, 3] = 1.0
        return T

    R1 = _rz(t1)
    R2 = R1 @ _ry(t2)
    R3 = R1 @ _ry(t2 + t3)
    R4 = R3 @ _rz(t4)
    R5 = R4 @ _ry(t5)
    R6 = R5 @ _rz(t6)
    zero = np.zeros(shape + (3,))
    o2 = R1 @ np.array([p["a1"], 0.0, p["c1"]])
    o3 = o2 + R2[..., :, 2] * p["c2"]
    wc = o3 + R3 @ np.array([p["a2"], p["b"], p["c3"]])
    fl = wc + R5[..., :, 2] * p["c4"]
    eye = np.broadcast_to(np.eye(3), shape + (3, 3))
    return np.stack([frame(eye, zero), frame(R1, zero), frame(R2, o2), frame(R3, o3),
                     frame(R4, wc), frame(R5, wc), frame(R6, fl)], axis=-3)


def inverse(robot: Robot, pose) -> tuple[np.ndarray, np.ndarray]:
    """Closed-form inverse kinematics of flange frames, all eight configurations.

    Parameters
    ----------
    pose : (n, 4, 4) flange frames in the robot's base frame, mm

    Returns
    -------
    q : (n, 8, 6) controller joints, radians, each wrapped to (−π, π] (a joint whose range
        spans more than a turn may take q ± 2π: the caller picks the turn)
    ok : (n, 8) bool — the configuration reaches the pose (the arm is long enough)

    Configuration index as in the module docstring. OPW paper §3 (θ1 Eq. 4–5, θ2 Eq. 6–9,
    θ3 Eq. 10–13, the wrist Eq. 14–16).
    """
    T = np.asarray(pose, dtype=np.float64).reshape(-1, 4, 4)
    p = robot.opw
    a1, a2, b, c1, c2, c3, c4 = (p[k] for k in ("a1", "a2", "b", "c1", "c2", "c3", "c4"))
    R = T[:, :3, :3]
    c = T[:, :3, 3] - c4 * R[:, :, 2]
    cx, cy, cz = c[:, 0], c[:, 1], c[:, 2]
    r2 = cx * cx + cy * cy - b * b
    ok_r = r2 >= 0.0
    nx1 = np.sqrt(np.maximum(r2, 0.0)) - a1
    h = cz - c1
    k2 = a2 * a2 + c3 * c3
    k = np.sqrt(k2)
    psi3 = np.arctan2(a2, c3)
    s1sq = nx1 * nx1 + h * h
    s2sq = (nx1 + 2.0 * a1) ** 2 + h * h
    s1, s2 = np.sqrt(s1sq), np.sqrt(s2sq)
    cos_a = (s1sq + c2 * c2 - k2) / (2.0 * s1 * c2)
    cos_b = (s2sq + c2 * c2 - k2) / (2.0 * s2 * c2)
    cos_c = (s1sq - c2 * c2 - k2) / (2.0 * c2 * k)
    cos_d = (s2sq - c2 * c2 - k2) / (2.0 * c2 * k)
    ok_front = ok_r & (np.abs(cos_c) <= 1.0 + 1e-12)
    ok_back = ok_r & (np.abs(cos_d) <= 1.0 + 1e-12)
    acos_a = np.arccos(np.clip(cos_a, -1, 1))
    acos_b = np.arccos(np.clip(cos_b, -1, 1))
    acos_c = np.arccos(np.clip(cos_c, -1, 1))
    acos_d = np.arccos(np.clip(cos_d, -1, 1))
    base1 = np.arctan2(cy, cx)
    off1 = np.arctan2(b, nx1 + a1)
    th1 = [base1 - off1, base1 - off1, base1 + off1 - np.pi, base1 + off1 - np.pi]
    at_f = np.arctan2(nx1, h)
    at_b = np.arctan2(nx1 + 2.0 * a1, h)
    th2 = [-acos_a + at_f, acos_a + at_f, -acos_b - at_b, acos_b - at_b]
    th3 = [acos_c - psi3, -acos_c - psi3, acos_d - psi3, -acos_d - psi3]
    ok3 = [ok_front, ok_front, ok_back, ok_back]
    n = len(T)
    theta = np.empty((n, 8, 6))
    ok = np.empty((n, 8), dtype=bool)
    for i in range(4):
        t1, t23 = th1[i], th2[i] + th3[i]
        Rc = _rz(t1) @ _ry(t23)
        W = np.swapaxes(Rc, -1, -2) @ R  # = Rz(θ4) Ry(θ5) Rz(θ6)
        t5 = np.arctan2(np.hypot(W[:, 0, 2], W[:, 1, 2]), W[:, 2, 2])
        t4 = np.arctan2(W[:, 1, 2], W[:, 0, 2])
        t6 = np.arctan2(W[:, 2, 1], -W[:, 2, 0])
        for w, (a4, a5, a6) in enumerate(((t4, t5, t6), (t4 + np.pi, -t5, t6 + np.pi))):
            theta[:, 2 * i + w] = np.stack([t1, th2[i], th3[i], a4, a5, a6], -1)
            ok[:, 2 * i + w] = ok3[i]
    q = wrap(model_to_joints(robot, theta))
    order = _config_order(robot, q, ok)
    return np.take_along_axis(q, order[:, :, None], 1), np.take_along_axis(ok, order, 1)


def _config_order(robot, q, ok):
    """Permutation (n, 8) sorting the eight solutions by configuration index."""
    cfg = configuration(robot, q)
    cfg = np.where(ok, cfg, 8 + np.arange(8))  # unreachable ones keep a slot at the end
    order = np.argsort(cfg, axis=1, kind="stable")
    return order


def configuration(robot: Robot, q) -> np.ndarray:
    """(...,) configuration index 4·shoulder + 2·elbow + wrist of joints q (..., 6) radians
    (module docstring)."""
    t = joints_to_model(robot, q)
    p = robot.opw
    k = np.hypot(p["a2"], p["c3"])
    t2, t3, t5 = t[..., 1], t[..., 2], t[..., 4]
    cx1 = p["c2"] * np.sin(t2) + k * np.sin(t2 + t3 + _psi3(p)) + p["a1"]
    shoulder = cx1 < 0.0
    elbow = wrap(t3 + _psi3(p)) > 0.0
    wrist = wrap(t5) < 0.0
    return 4 * shoulder.astype(int) + 2 * elbow.astype(int) + wrist.astype(int)


def singularity(robot: Robot, q) -> dict:
    """Singularity measures of joints q (..., 6) radians (module docstring): ``wrist`` and
    ``elbow`` radians, ``shoulder`` mm, each (...,)."""
    t = joints_to_model(robot, q)
    p = robot.opw
    k = np.hypot(p["a2"], p["c3"])
    t2, t3, t5 = t[..., 1], t[..., 2], t[..., 4]
    e = np.abs(wrap(t3 + _psi3(p)))
    cx1 = p["c2"] * np.sin(t2) + k * np.sin(t2 + t3 + _psi3(p)) + p["a1"]
    return {
        "wrist": np.abs(wrap(t5)),
        "elbow": np.minimum(e, np.pi - e),
        "shoulder": np.hypot(cx1, p["b"]),
    }


def limit_margin(robot: Robot, q) -> np.ndarray:
    """(..., 6) distance (radians) of each joint to its nearer limit; negative outside."""
    q = np.asarray(q)
    return np.minimum(q - robot.limits[:, 0], robot.limits[:, 1] - q)
