"""The machining error of an NC program measured against the part, independently of the
interpolation's own model (issue 28 row 11): every cut block's joint-linear motion (the joints
as LinuxCNC's interpreter or the block stream gives them) sampled, forward kinematics, the ball
centre's distance to the mesh minus ρ (minus the path's allowance): > 0 material left, < 0
gouge. A ball cutter only (the issue's set-up)."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from blisk_cam.core.machine.description import forward


def ball_clearance(machine, rho, mesh_distance, xyz, deg):
    """(k,) mm: ball centre (tip + ρ axis by forward kinematics of joints xyz (k, 3) mm and
    rotaries deg (k, 2) degrees) to the mesh, minus ρ."""
    tip, ax = forward(machine, xyz, np.radians(deg))
    d = np.abs(mesh_distance.query(tip + rho * ax).signed_distance)
    return d - rho


def block_errors(machine, rho, mesh_distance, xyz, deg, cut, *, samples=24, allowance=0.0):
    """Per cut block (i − 1 → i with ``cut[i]`` and ``cut[i - 1]``): the largest |clearance −
    allowance| over ``samples`` points of the joint-linear motion, ends included.
    xyz (n, 3), deg (n, 2), cut (n,) bool. Returns (B,) mm and the (B,) block end indices."""
    cut = np.asarray(cut, bool)
    ends = np.nonzero(cut[1:] & cut[:-1])[0] + 1
    t = np.linspace(0.0, 1.0, samples)
    q0 = np.hstack([xyz, deg])
    a, b = q0[ends - 1], q0[ends]
    Q = (a[:, None] + t[None, :, None] * (b - a)[:, None]).reshape(-1, 5)
    c = ball_clearance(machine, rho, mesh_distance, Q[:, :3], Q[:, 3:]) - allowance
    return np.abs(c).reshape(len(ends), samples).max(axis=1), ends


def match_motions(motions_xyz, motions_deg, block_xyz, block_deg):
    """Indices of the block stream's poses among the interpreter's motions (nearest in
    joint space; mm and degrees)."""
    tree = cKDTree(np.hstack([motions_xyz, motions_deg]))
    d, j = tree.query(np.hstack([block_xyz, block_deg]))
    return d, j
