"""The machine's motion along a program, as poses to animate (Blender as the simulator).

From the block stream of the NC export (:func:`.post.blocks.build_blocks`: the joint values
X, Y, Z, θ1, θ2 of every block) this module gives, per block, the 4 × 4 rigid transforms of
the tool and of the part:

* **part view** — the part stands still (identity); the tool's tip and axis are the
  programmed ones in the part frame;
* **machine view** — what the machine does: the part moves with its tables
  (``machine.tip_to_machine``, paper 002 Eq. 4 read the other way) and the tool stands at the
  programmed X, Y, Z with its axis turned by the head rotaries (``machine.machine_axis``).

Between blocks the machine moves its joints linearly; one keyframe per block with linear
interpolation of the joint-driven transforms is what a scrub through the timeline shows.
Matrices map local coordinates (mm) to the scene's frame (mm); the tool's local frame has the
tip at the origin and the tool axis along +z.
"""

from __future__ import annotations

import numpy as np

from .description import Machine, machine_axis, tip_to_machine

__all__ = ["align_z", "machine_view", "part_view"]


def align_z(axis) -> np.ndarray:
    """(n, 3, 3) rotations taking +z to the unit vectors ``axis`` (n, 3) by the shortest turn
    (a half turn about x for −z)."""
    a = np.asarray(axis, dtype=np.float64).reshape(-1, 3)
    a = a / np.linalg.norm(a, axis=1, keepdims=True)
    z = np.array([0.0, 0.0, 1.0])
    v = np.cross(z, a)  # sin θ · k
    c = a[:, 2]  # cos θ
    K = np.zeros((len(a), 3, 3))
    K[:, 0, 1], K[:, 0, 2], K[:, 1, 2] = -v[:, 2], v[:, 1], -v[:, 0]
    K[:, 1, 0], K[:, 2, 0], K[:, 2, 1] = v[:, 2], -v[:, 1], v[:, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        f = np.where(c > -1.0 + 1e-12, 1.0 / (1.0 + c), 0.0)
    R = np.eye(3) + K + (K @ K) * f[:, None, None]
    flip = c <= -1.0 + 1e-12
    R[flip] = np.diag([1.0, -1.0, -1.0])
    return R


def _rigid(R, t) -> np.ndarray:
    M = np.zeros((len(t), 4, 4))
    M[:, :3, :3] = R
    M[:, :3, 3] = t
    M[:, 3, 3] = 1.0
    return M


def part_view(tip, axis) -> tuple[np.ndarray, np.ndarray]:
    """(part (n, 4, 4), tool (n, 4, 4)): the part at rest, the tool at its tips (n, 3) mm
    with its axes (n, 3)."""
    tip = np.asarray(tip, dtype=np.float64).reshape(-1, 3)
    part = np.broadcast_to(np.eye(4), (len(tip), 4, 4)).copy()
    return part, _rigid(align_z(axis), tip)


def machine_view(machine: Machine, xyz, angles) -> tuple[np.ndarray, np.ndarray]:
    """(part (n, 4, 4), tool (n, 4, 4)) in machine coordinates for joint values ``xyz``
    (n, 3) mm and ``angles`` (n, 2) radians: the part's transform is fitted exactly from the
    images of its origin and unit vectors under the tables' motion."""
    xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    q = np.asarray(angles, dtype=np.float64).reshape(-1, 2)
    n = len(q)
    basis = np.vstack([np.zeros(3), np.eye(3)])  # origin, e_x, e_y, e_z of the part
    imgs = np.stack([tip_to_machine(machine, np.broadcast_to(b, (n, 3)), q) for b in basis], 1)
    part = _rigid(np.transpose(imgs[:, 1:] - imgs[:, :1], (0, 2, 1)), imgs[:, 0])
    return part, _rigid(align_z(machine_axis(machine, q)), xyz)
