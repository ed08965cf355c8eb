"""Issue 28 row 16: verify judges every row of the program, links, approaches, retracts and
rapids as well as the cuts: a move between passes that cuts into the blade fails the verdict,
named by its program row, even when every cut move is within the chord."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.toolpath.types import MOVE_CUT
from blisk_cam.core.verify.measure import verify_path
from blisk_cam.core.verify.verdict import judge, verdict_dict, verdict_lines
from tests.support.nc import demo_path


@pytest.fixture(scope="module")
def demo():
    d = make_demo_blisk(resolution=0.5, fillet=True, fillet_radius=10.0)
    return TriMesh.from_arrays(d.blade_vertices, d.blade_faces), demo_path()


def test_link_rows_are_measured(demo):
    mesh, path = demo
    rep = verify_path(mesh, path)
    prog = path.program
    assert np.isfinite(rep.link_gouge) and rep.link_gouge >= 0.0
    assert rep.link_rows == int(np.count_nonzero(np.asarray(prog.move)[1:] != MOVE_CUT))
    v = judge(rep, path.cusp, path.chord, path.tool, path=path)
    names = [c.name for c in v.checks]
    assert "link_gouge" in names


def test_a_link_into_the_blade_fails_the_verdict(demo):
    mesh, path = demo
    p = copy.deepcopy(path)
    prog = p.program
    move = np.asarray(prog.move)
    # a link row, and the cut pose it leaves from: put the link's pose 0.2 mm into the blade
    # there (ball centre at ρ − 0.2 from the surface along the normal)
    j = next(k for k in range(1, len(move)) if move[k] != MOVE_CUT and move[k - 1] == MOVE_CUT
             and prog.curve[k - 1] >= 0)
    c = p.curves[int(prog.curve[j - 1])]
    i = int(prog.index[j - 1]) % len(c.cc)
    rho = p.tool.radius
    n = np.asarray(c.normal[i]) / np.linalg.norm(c.normal[i])
    centre = np.asarray(c.cc[i]) + (rho - 0.2) * n
    prog.tip[j], prog.axis[j] = centre - rho * n, n
    base = verify_path(mesh, path)
    rep = verify_path(mesh, p)
    assert rep.link_gouge >= 0.2 - 1e-3  # at least the planted depth (the row is sampled)
    assert rep.max_gouge == base.max_gouge  # the cut moves are measured as before
    v = judge(rep, p.cusp, p.chord, p.tool, path=p)
    link = next(c for c in v.checks if c.name == "link_gouge")
    assert not link.passed and not v.passed and link.row is not None
    assert abs(link.row - j) <= 1  # the row reaching, or leaving, the planted pose
    assert verdict_dict(v)["checks"]["link_gouge"]["row"] == link.row
    assert any("program row" in line and "FAIL" in line for line in verdict_lines(v))
