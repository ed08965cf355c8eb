"""Ordering, climb/conventional, spiral blending and the linked program
(blisk_cam.core.paths.linking).

The passes are exact mesh ∩ LMC curves of the analytic tube blade (tests.support.blades), so
every figure is checked against the mesh and the cones themselves."""

import math

import numpy as np
import pytest

from blisk_cam.core.errors import LinkError
from blisk_cam.core.geometry.axis import Axis, meridional
from blisk_cam.core.geometry.distance import MeshDistance
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.paths.linking import (
    Clearance,
    LinkOptions,
    SurfaceProjector,
    build_program,
    order_passes,
    ratio_gradient,
)
from blisk_cam.core.paths.orientation import local_frames
from blisk_cam.core.paths.slicing import MeshConeSlicer
from blisk_cam.core.tool.cutter import Cutter
from blisk_cam.core.toolpath.types import (
    MOVE_APPROACH,
    MOVE_CUT,
    MOVE_LINK,
    MOVE_RAPID,
    MOVE_RETRACT,
    PassCurve,
)
from tests.support.blades import tube_blade

AX = Axis()
LEVELS = np.linspace(0.0, 1.0, 9)


@pytest.fixture(scope="module")
def tube_passes():
    V, F, mc = tube_blade()
    mesh = TriMesh.from_arrays(V, F)
    slicer = MeshConeSlicer(mesh, AX, mc)
    curves = []
    for s in LEVELS:
        for c in slicer.slice(float(s)):
            curves.append(
                PassCurve(
                    s=float(s),
                    closed=c.closed,
                    cc=c.points,
                    normal=c.normals,
                    tip=c.points.copy(),
                    axis=c.normals.copy(),
                )
            )
    return mesh, mc, curves, SurfaceProjector(mesh, AX, mc)


def _sense(c, mc, toward_tip=True):
    f, n, k = local_frames(c.cc, c.normal, c.closed)
    g = ratio_gradient(c.cc, mc, AX)
    m = g - np.einsum("ij,ij->i", g, n)[:, None] * n
    m /= np.linalg.norm(m, axis=1)[:, None]
    return float(np.mean(np.einsum("ij,ij->i", m if toward_tip else -m, k)))


@pytest.mark.parametrize("climb", [True, False])
def test_oneway_mills_climb_or_conventional(tube_passes, climb):
    mesh, mc, curves, pj = tube_passes
    out = order_passes(curves, LinkOptions(mode="oneway", climb=climb), mc, AX, pj)
    assert [c.s for c in out] == list(LEVELS)
    senses = np.array([_sense(c, mc) for c in out])
    # climb (M03): the unmachined side (next passes, +s) on the right of the feed, m·k > 0
    assert np.all(senses > 0.5) if climb else np.all(senses < -0.5)
    # each loop starts at the pose nearest the previous start: short steps between loops
    for a, b in zip(out[:-1], out[1:], strict=True):
        assert (
            np.linalg.norm(b.cc[0] - a.cc[0])
            <= np.min(np.linalg.norm(b.cc - a.cc[0], axis=1)) + 1e-12
        )


def test_zigzag_alternates_and_tip_to_hub_reverses(tube_passes):
    mesh, mc, curves, pj = tube_passes
    out = order_passes(curves, LinkOptions(mode="zigzag"), mc, AX, pj)
    senses = np.sign([_sense(c, mc) for c in out])
    assert np.all(senses[::2] > 0) and np.all(senses[1::2] < 0)
    out = order_passes(curves, LinkOptions(mode="oneway", order="tip_to_hub"), mc, AX, pj)
    assert [c.s for c in out] == list(LEVELS[::-1])
    assert all(_sense(c, mc, toward_tip=False) > 0.5 for c in out)


def test_spiral_is_one_continuous_cut_on_the_mesh_and_the_lmcs(tube_passes):
    mesh, mc, curves, pj = tube_passes
    opts = LinkOptions(mode="spiral", chord=0.05, tool_radius=6.0)
    out = order_passes(curves, opts, mc, AX, pj)
    assert len(out) == 1
    sp = out[0]
    assert not sp.closed and sp.ratio is not None
    # measured: every CC point on the mesh and on the LMC of its own ratio
    d = MeshDistance(mesh).query(sp.cc).distance
    assert d.max() <= 1e-9
    r, z = meridional(sp.cc, AX)
    on_cone = np.array([mc.f(float(s), ri, zi) for s, ri, zi in zip(sp.ratio, r, z, strict=True)])
    blend = ~np.isin(sp.ratio, LEVELS)
    assert blend.sum() > len(sp.cc) / 2 and np.abs(on_cone[blend]).max() <= 1e-6
    assert np.abs(on_cone).max() <= 1e-4  # loop poses: the slicer's boundary tolerance
    # from the first level to the last, never going back, and with no jump: every step no
    # longer than the longest step of the loops it blends
    assert sp.ratio[0] == 0.0 and sp.ratio[-1] == 1.0
    assert np.all(np.diff(sp.ratio) >= -1e-9)
    loop_step = max(
        np.linalg.norm(np.diff(np.vstack([c.cc, c.cc[:1]]), axis=0), axis=1).max() for c in curves
    )
    assert np.linalg.norm(np.diff(sp.cc, axis=0), axis=1).max() <= loop_step * 1.01
    # the program: approach, one run of cut moves through the whole spiral, retract
    cutter = Cutter.ball(6.0)
    sp.axis = sp.normal.copy()
    sp.tip = cutter.cl_points(sp.cc, sp.normal, sp.axis)
    prog = build_program(
        out,
        LinkOptions(mode="spiral"),
        AX,
        tool_radius=6.0,
        projector=pj,
        cl_points=cutter.cl_points,
    )
    inside = prog.curve == 0
    first, last = np.nonzero(inside)[0][[0, -1]]
    assert prog.move[first] == MOVE_APPROACH
    assert np.all(prog.move[first + 1 : last + 1] == MOVE_CUT)
    assert last - first + 1 == len(sp.cc)


def _program(tube_passes, mode, **kw):
    mesh, mc, curves, pj = tube_passes
    out = order_passes(curves, LinkOptions(mode=mode), mc, AX, pj)
    cutter = Cutter.bull(6.0, 2.0)
    for c in out:
        f, n, k = local_frames(c.cc, c.normal, c.closed)
        c.axis = (n + math.tan(math.radians(8)) * f) / math.hypot(1, math.tan(math.radians(8)))
        c.tip = cutter.cl_points(c.cc, c.normal, c.axis)
    opts = LinkOptions(mode=mode, **kw)
    return (
        out,
        build_program(out, opts, AX, tool_radius=6.0, projector=pj, cl_points=cutter.cl_points),
        opts,
    )


def test_program_with_clearance_links(tube_passes):
    out, prog, opts = _program(
        tube_passes, "oneway", direct_link=0.0, approach=3.0, clearance=Clearance(170.0, 0.0, 0.1)
    )
    assert set(np.unique(prog.move)) == {MOVE_CUT, MOVE_APPROACH, MOVE_RETRACT, MOVE_RAPID}
    # every pass pose appears once, in order (closed loops end with their first pose again)
    for i, c in enumerate(out):
        idx = prog.index[prog.curve == i]
        assert np.array_equal(idx, np.append(np.arange(len(c.cc)), 0))
        assert np.allclose(prog.tip[prog.curve == i], c.tip[idx])
    # approaches and retracts run along the tool axis, to a point the approach distance off
    # the surface (along the 8° lead axis: 3 / cos 8° mm)
    def normal_at(row):
        return out[prog.curve[row]].normal[prog.index[row]]

    for j in np.nonzero(prog.move == MOVE_APPROACH)[0]:
        d = prog.tip[j - 1] - prog.tip[j]
        L = np.linalg.norm(d)
        assert np.allclose(d / L, prog.axis[j]) and np.isclose(d @ normal_at(j), 3.0)
        assert np.isclose(L, 3.0 / math.cos(math.radians(8)), rtol=1e-3)
    for j in np.nonzero(prog.move == MOVE_RETRACT)[0]:
        d = prog.tip[j] - prog.tip[j - 1]
        L = np.linalg.norm(d)
        assert np.allclose(d / L, prog.axis[j - 1]) and np.isclose(d @ normal_at(j - 1), 3.0)
    # rapids between retract and approach travel on the clearance cone r = 170 + 0.1 z
    r, z = meridional(prog.tip, AX)
    on = (prog.move == MOVE_RAPID) & np.roll(prog.move == MOVE_RAPID, -1)
    assert np.allclose(r[on], 170.0 + 0.1 * z[on])
    assert np.all(r[prog.curve < 0] <= 170.0 + 0.1 * z[prog.curve < 0] + 1e-9)
    assert prog.move[0] == MOVE_RAPID and prog.move[-1] == MOVE_RAPID
    _no_repeated_poses(prog)


def _no_repeated_poses(prog):
    """No pose repeats the one before it (the program used to start with two identical
    rapid poses: the clearance point above the first pass, twice)."""
    same = np.all(prog.tip[1:] == prog.tip[:-1], axis=1) & np.all(
        prog.axis[1:] == prog.axis[:-1], axis=1
    )
    assert not np.any(same), np.nonzero(same)[0]
    # the program starts at the clearance above the first pass, then drops to its approach
    # point, then approaches: rapid, rapid, approach
    assert list(prog.move[:3]) == [MOVE_RAPID, MOVE_RAPID, MOVE_APPROACH]


def test_program_with_surface_links(tube_passes):
    mesh, mc, curves, pj = tube_passes
    out, prog, _ = _program(tube_passes, "zigzag")
    runs = prog.runs()
    kinds = [m for m, _, _ in runs]
    # consecutive loops are a side step apart: linked on the surface, one approach, one retract
    assert kinds.count(MOVE_APPROACH) == 1 and kinds.count(MOVE_RETRACT) == 1
    assert kinds.count(MOVE_LINK) == len(out) - 1
    _no_repeated_poses(prog)
    # link poses keep the cutter on the surface: no mesh vertex inside it beyond 0.05 mm, and
    # the nearest one within 0.05 mm of it (the cutter touches the projected point)
    inner = (prog.curve < 0) & (prog.move == MOVE_LINK)
    assert np.count_nonzero(inner) >= len(out) - 1
    cutter = Cutter.bull(6.0, 2.0)
    for j in np.nonzero(inner)[0]:
        near = mesh.V[np.linalg.norm(mesh.V - prog.tip[j], axis=1) < 15.0]
        d = cutter.signed_distance(near, prog.tip[j], prog.axis[j])
        assert d.min() >= -0.05 and d.min() <= 0.5


def test_open_curves_need_links_even_in_spiral_mode():
    # three open arcs (one blade side): each is its own pass, linked through the clearance
    t = np.linspace(0, 1, 30)
    curves = []
    for s in (0.0, 0.5, 1.0):
        cc = np.stack([100 + 20 * t, 5 * np.sin(t), np.full(30, 10 * s)], 1)
        n = np.tile([0.0, 1.0, 0.0], (30, 1))
        curves.append(PassCurve(s=s, closed=False, cc=cc, normal=n, tip=cc.copy(), axis=n.copy()))
    from blisk_cam.core.part.cones import Cone, MorphingCones

    mc = MorphingCones(Cone(90, 0, 140, 0), Cone(90, 10, 140, 10))
    out = order_passes(curves, LinkOptions(mode="spiral"), mc, AX, None)
    assert len(out) == 3
    prog = build_program(out, LinkOptions(mode="spiral"), AX, tool_radius=6.0)
    assert np.count_nonzero(prog.move == MOVE_APPROACH) == 3


def test_bad_link_options(tube_passes):
    with pytest.raises(LinkError, match="unknown link mode"):
        LinkOptions(mode="helix")
    with pytest.raises(LinkError, match="approach"):
        LinkOptions(approach=-1)
    with pytest.raises(LinkError, match="clearance radius"):
        Clearance(0.0)
    with pytest.raises(LinkError, match="order"):
        LinkOptions(order="outside_in")
    with pytest.raises(LinkError, match="raise its radius"):
        _program(tube_passes, "oneway", clearance=Clearance(120.0))
