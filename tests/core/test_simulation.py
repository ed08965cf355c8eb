"""Blender-as-simulator transforms: in both views the tool's tip and axis land on the part's
programmed tip and axis (through forward kinematics)."""

import math

import numpy as np

from blisk_cam.core.machine.description import forward, load_machine
from blisk_cam.core.machine.motion import align_z, machine_view, part_view


def test_align_z_is_a_rotation_taking_z_to_the_axis():
    rng = np.random.default_rng(1)
    a = rng.normal(size=(200, 3))
    a = np.vstack([a / np.linalg.norm(a, axis=1, keepdims=True), [[0, 0, 1], [0, 0, -1]]])
    R = align_z(a)
    np.testing.assert_allclose(R @ [0, 0, 1], a, atol=1e-12)
    np.testing.assert_allclose(R @ np.transpose(R, (0, 2, 1)), np.broadcast_to(np.eye(3), R.shape),
                               atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-12)


def _relative_tool_pose(part, tool):
    """The tool's tip and axis in the part's own frame."""
    inv = np.linalg.inv(part)
    rel = inv @ tool
    return rel[:, :3, 3], rel[:, :3, 2]


def test_machine_view_puts_the_tool_on_the_programmed_pose():
    for name in ("ac-trunnion", "bc-trunnion", "bc-head-table"):
        m = load_machine(name)
        rng = np.random.default_rng(7)
        q = np.column_stack([rng.uniform(0.2, 1.2, 50), rng.uniform(-3, 3, 50)])
        xyz = rng.uniform(-100, 100, (50, 3))
        tip, axis = forward(m, xyz, q)  # what the program means in the part frame
        part, tool = machine_view(m, xyz, q)
        t, a = _relative_tool_pose(part, tool)
        np.testing.assert_allclose(t, tip, atol=1e-9)
        np.testing.assert_allclose(a, axis, atol=1e-12)
        # the part moves rigidly
        np.testing.assert_allclose(np.linalg.det(part[:, :3, :3]), 1.0, atol=1e-12)
        p2, t2 = part_view(tip, axis)
        np.testing.assert_allclose(_relative_tool_pose(p2, t2)[0], tip, atol=1e-9)
    assert math.isfinite(float(part.sum()))
