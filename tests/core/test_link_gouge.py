"""On-surface links never cut the part beyond the chord tolerance (issue 28, row 16).

A concave corner (two planes meeting at 100°, the material below) with a Ø12 ball pass ending
on each wall 6 mm from the corner: the passes themselves clear the other wall, and the walls'
normals differ by 80°, so linking keeps the link on the surface — and a ball tangent to one wall
near the corner cuts deep into the other. The link is measured independently: ball centres
sampled every 0.01 mm along every non-cut move, their exact distance to the mesh minus ρ."""

import math

import numpy as np
import pytest

from blisk_cam.core.collision.reroute import clearance_surface
from blisk_cam.core.geometry.axis import Axis
from blisk_cam.core.geometry.distance import MeshDistance
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.part.cones import Cone, MorphingCones
from blisk_cam.core.paths.link_check import SweptLinkCheck
from blisk_cam.core.paths.linking import LinkOptions, SurfaceProjector, build_program
from blisk_cam.core.tool.cutter import Cutter
from blisk_cam.core.toolpath.types import MOVE_CUT, MOVE_LINK, PassCurve

AX = Axis()
RHO = 6.0
CHORD = 0.01
X0 = 100.0  # the corner line: x = 100, z = 0, along y
ANGLE = math.radians(100.0)  # the walls' angle (in the air)


def _grid(origin, du, dv, n_u, n_v):
    i, j = np.meshgrid(np.arange(n_u + 1), np.arange(n_v + 1), indexing="ij")
    V = origin + (i.ravel() / n_u)[:, None] * du + (j.ravel() / n_v)[:, None] * dv
    idx = np.arange(len(V)).reshape(n_u + 1, n_v + 1)
    a, b, c, d = idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]
    F = np.vstack([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    return V, F


def _corner():
    """Wall 1: z = 0, x ∈ [100, 120]; wall 2: from the corner up at 100° to +x; y ∈ [−10, 10].
    Returns the mesh and the walls' unit normals (into the air)."""
    w2 = np.array([math.cos(ANGLE), 0.0, math.sin(ANGLE)])
    V1, F1 = _grid(np.array([X0, -10.0, 0.0]), np.array([20.0, 0, 0]), np.array([0, 20.0, 0]),
                   40, 40)
    V2, F2 = _grid(np.array([X0, -10.0, 0.0]), np.array([0, 20.0, 0]), 20.0 * w2, 40, 40)
    mesh = TriMesh.from_arrays(np.vstack([V1, V2]), np.vstack([F1, F2 + len(V1)]))
    n1 = np.array([0.0, 0.0, 1.0])
    n2 = np.array([math.sin(ANGLE), 0.0, -math.cos(ANGLE)])
    return mesh, w2, n1, n2


def _pass(cc, n, cutter):
    N = np.broadcast_to(n, cc.shape).copy()
    return PassCurve(s=0.0, closed=False, cc=cc, normal=N, tip=cutter.cl_points(cc, N, N),
                     axis=N.copy())


def _swept_depth(md, prog, rows, spacing=0.01):
    """Largest depth (mm) of the ball swept along the moves ending at ``rows``."""
    worst = 0.0
    for j in rows:
        L = np.linalg.norm(prog.tip[j] - prog.tip[j - 1])
        t = np.linspace(0.0, 1.0, max(2, int(math.ceil(L / spacing)) + 1))[:, None]
        T = prog.tip[j - 1] * (1 - t) + prog.tip[j] * t
        A = prog.axis[j - 1] * (1 - t) + prog.axis[j] * t
        A /= np.linalg.norm(A, axis=1)[:, None]
        worst = max(worst, float(np.max(RHO - md.query(T + RHO * A).distance)))
    return worst


@pytest.fixture(scope="module")
def corner_program():
    mesh, w2, n1, n2 = _corner()
    cutter = Cutter.ball(RHO)
    y = np.linspace(-5.0, 0.0, 6)
    a = _pass(np.stack([np.full(6, X0 + 6.0), y, np.zeros(6)], 1), n1, cutter)
    b = _pass(np.array([X0, 0.0, 0.0]) + 6.0 * w2 + np.outer(-y[::-1], [0, 1.0, 0]), n2, cutter)
    mc = MorphingCones(Cone(50.0, -20.0, 50.0, 20.0), Cone(150.0, -20.0, 150.0, 20.0))
    pj = SurfaceProjector(mesh, AX, mc)
    opts = LinkOptions(chord=CHORD, tool_radius=RHO)
    md = MeshDistance(mesh)

    def program(check):
        return build_program([a, b], opts, AX, tool_radius=RHO, projector=pj,
                             cl_points=cutter.cl_points, link_check=check)

    return md, mesh, cutter, program


def test_an_unchecked_surface_link_cuts_the_corner(corner_program):
    md, _, _, program = corner_program
    prog = program(None)
    links = np.flatnonzero(prog.move == MOVE_LINK)
    assert len(links) > 1  # kept on the surface
    cuts = np.flatnonzero(prog.move[1:] == MOVE_CUT) + 1
    assert _swept_depth(md, prog, cuts) <= CHORD  # the passes clear the corner
    assert _swept_depth(md, prog, links) > 1.0  # the link cuts millimetres deep


def test_a_gouging_link_is_rerouted_through_the_air(corner_program):
    md, mesh, cutter, program = corner_program
    check = SweptLinkCheck(mesh, cutter, CHORD, distance=md)
    prog = program(check)
    assert not np.any(prog.move == MOVE_LINK)
    moves = np.flatnonzero(prog.move[1:] != MOVE_CUT) + 1
    assert _swept_depth(md, prog, moves) <= CHORD
    assert check.rerouted == 1
    # the depth it reports is the independent figure of the surface link (to the sampling)
    unchecked = program(None)
    truth = _swept_depth(md, unchecked, np.flatnonzero(unchecked.move == MOVE_LINK))
    assert abs(check.worst - truth) <= 0.25 * CHORD
    assert "1 link re-routed through the air" in check.warning()
    # collision avoidance reads the same clearance surface back from the program
    assert clearance_surface(prog, AX) == clearance_surface(unchecked, AX)


def test_a_clear_link_is_kept(corner_program):
    """A check with a tolerance above the corner's cut keeps the same program, bit for bit."""
    md, mesh, cutter, program = corner_program
    check = SweptLinkCheck(mesh, cutter, 100.0, distance=md)
    a, b = program(None), program(check)
    assert check.rerouted == 0 and check.warning() is None
    for f in ("tip", "axis", "move", "curve", "index", "flags"):
        assert np.array_equal(getattr(a, f), getattr(b, f))


def test_a_clearance_route_through_the_part_is_reported():
    """With no surface links (direct link 0), the planned route via the clearance surface
    leaves pass A radially at the height of its approach point, over a ridge 1 mm higher
    than the ball's bottom there (x ∈ [112, 116]): the route is kept (collision avoidance
    re-routes rapids) and reported with its cut; without the ridge nothing is reported. The
    program is the same, bit for bit, with the check or without."""
    mesh, w2, n1, n2 = _corner()
    cutter = Cutter.ball(RHO)
    ridge_V = np.array([[112.0, -10, 0], [112.0, 10, 0], [114.0, -10, 3.0], [114.0, 10, 3.0],
                        [116.0, -10, 0], [116.0, 10, 0]])
    ridge_F = np.array([[0, 2, 1], [1, 2, 3], [2, 4, 3], [3, 4, 5]])
    both = TriMesh.from_arrays(np.vstack([mesh.V, ridge_V]),
                               np.vstack([mesh.F, ridge_F + len(mesh.V)]))
    y = np.linspace(-5.0, 0.0, 6)
    a = _pass(np.stack([np.full(6, X0 + 6.0), y, np.zeros(6)], 1), n1, cutter)
    b = _pass(np.array([X0, 0.0, 0.0]) + 6.0 * w2 + np.outer(-y[::-1], [0, 1.0, 0]), n2, cutter)
    opts = LinkOptions(chord=CHORD, tool_radius=RHO, direct_link=0.0)
    plain = build_program([a, b], opts, AX, tool_radius=RHO)
    rows = np.arange(int(np.flatnonzero(plain.curve == 0)[-1]) + 1,
                     int(np.flatnonzero(plain.curve == 1)[0]) + 1)
    truth = _swept_depth(MeshDistance(both), plain, rows)
    assert truth > 0.5  # the planned route cuts the ridge
    for m, count in ((both, 1), (mesh, 0)):
        check = SweptLinkCheck(m, cutter, CHORD)
        prog = build_program([a, b], opts, AX, tool_radius=RHO, link_check=check)
        for f in ("tip", "axis", "move", "curve", "index", "flags"):
            assert np.array_equal(getattr(plain, f), getattr(prog, f))
        # every planned route via the clearance surface is measured: the program's entry, the
        # route between the passes and its exit (over the ridge each cuts, independently)
        c0, c1 = np.flatnonzero(prog.curve == 0), np.flatnonzero(prog.curve == 1)
        routes = (np.arange(1, c0[0] + 1), rows, np.arange(c1[-1] + 1, len(prog.tip)))
        cut = sum(_swept_depth(MeshDistance(m), prog, r) > CHORD for r in routes)
        assert check.rapids == cut and (cut >= 1) == bool(count) and check.rerouted == 0
        if count:
            # at least the independent figure (more here: the mesh is open, and the check's
            # signed distance reads a ball centre beyond a wall's free edge as inside)
            assert check.rapids_worst >= truth - 0.25 * CHORD
            assert "run collision avoidance" in check.warnings()[0]
        else:
            assert check.warnings() == []
