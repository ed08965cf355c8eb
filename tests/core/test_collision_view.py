"""The core helpers behind the Blender collision view: the whole tool's outline and mesh,
per-pose statuses, the worst pose, the next unresolved pose, splitting a mesh by faces."""

import math

import numpy as np
import pytest

from blisk_cam.core.collision.avoid import run_collisions
from blisk_cam.core.collision.obstacles import split_faces
from blisk_cam.core.collision.options import CollisionOptions
from blisk_cam.core.collision.report import (
    collision_rows,
    next_unresolved,
    pose_collision_status,
    unresolved_rows,
    worst_pose,
)
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.part.cones import Cone
from blisk_cam.core.process.blade_finish import PathRequest, plan_paths
from blisk_cam.core.tool.assembly import ToolAssembly, assembly_mesh
from blisk_cam.core.tool.cutter import Cutter
from blisk_cam.core.toolpath.types import STATUS_UNRESOLVED

HOLDER = ((36.0, 6.0), (60.0, 6.0), (60.0, 16.0), (120.0, 16.0))


def test_assembly_outline_and_mesh():
    cutter = Cutter.ball(6.0)
    asm = ToolAssembly(36.0, HOLDER)
    rz = asm.outline(cutter)
    assert tuple(rz[0]) == (0.0, 0.0) and tuple(rz[-1]) == (0.0, 120.0)
    assert rz[:, 1].max() == 120.0 and rz[:, 0].max() == 16.0
    assert np.all(np.diff(rz[:, 1]) >= -1e-12)  # up the tool, never down
    V, F = assembly_mesh(asm, cutter, segments=32)
    assert np.all(V[:32] == 0.0)  # the tip, exactly
    r = np.hypot(V[:, 0], V[:, 1])
    assert np.allclose(np.sort(np.unique(np.round(r[V[:, 2] == 120.0], 9))), [0.0, 16.0])
    assert F.shape[1] == 4 and F.max() == len(V) - 1


def test_split_faces():
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [2, 2, 0]], float)
    F = np.array([[0, 1, 2], [1, 3, 2], [3, 4, 2]])
    (Vb, Fb), (Vr, Fr) = split_faces(V, F, [True, False, False])
    assert np.array_equal(Vb[Fb], V[F[:1]]) and np.array_equal(Vr[Fr], V[F[1:]])
    assert len(Vb) == 3 and len(Vr) == 4
    assert split_faces(V, F, [True] * 3)[1] is None


@pytest.fixture(scope="module")
def checked():
    d = make_demo_blisk(resolution=0.3)
    req = PathRequest(axis=d.axis, cone1=Cone.from_list([170, -25, 185, 35]), cone2=d.tip_cone,
                      tool_diameter=12.0, cusp=0.5, chord=0.1, axis_mode="radial",
                      radial_tilt=math.radians(75))
    path = plan_paths(TriMesh.from_arrays(d.blade_vertices, d.blade_faces), req).path
    opts = CollisionOptions(mode="check", blade_count=24, holder=HOLDER)
    return path, run_collisions((d.blade_vertices, d.blade_faces), path, (), opts)


def test_statuses_worst_and_next_unresolved(checked):
    path, (out, report) = checked
    assert pose_collision_status(path) is None and worst_pose(path) is None
    assert next_unresolved(path) is None
    st = pose_collision_status(out)
    assert len(st) == out.n_poses and np.array_equal(np.concatenate(report.curve_status), st)
    tips, axes, status, clr = collision_rows(out)
    assert np.array_equal(status, report.program_status)
    tip, axis, c, row = worst_pose(out)
    assert c == report.min_clearance == clr.min() and np.array_equal(tip, tips[row])
    assert np.linalg.norm(axis) == pytest.approx(1.0)
    idx = unresolved_rows(out)
    assert len(idx) == report.n_unresolved > 0 and np.all(status[idx] == STATUS_UNRESOLVED)
    first = next_unresolved(out, [0.0, 0.0, 0.0])
    assert first[2] == idx[0] and np.array_equal(first[0], tips[idx[0]])
    second = next_unresolved(out, first[0])
    assert second[3] == (1 % second[4])
    if second[4] > 1:
        assert np.linalg.norm(second[0] - first[0]) > 1e-3
