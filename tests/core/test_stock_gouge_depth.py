"""A gouge deeper than the stock's tolerance fails the simulation's verdict at a coarse
resolution too (issue #22), and one within it passes.

Before, the deviation map read every gouge deeper than 0.5 mm as −0.5 mm, and at a 0.5 mm
stock the gouge tolerance (chord + resolution, 0.55 mm here) is above that, so a 1.5 mm plunge
into the blade passed: this test fails on that code (run against it: ``assert not
sims[2].summary["passed"]`` failed, max_gouge 0.5) and passes on this one. Gouges are judged
where the grid resolves them (:func:`blisk_cam.core.stock.deviation.resolved_points`: the map
reads, at the tolerance's depth, a ray point of the part that a clean cut leaves); the others
are counted, with their area, as not judged. The job's final verdict
(:func:`blisk_cam.core.process.job_verdict.job_verdict`) judges by the same test: it fails the
deep plunge with a gouge zone at it, and names none on the clean cut.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from blisk_cam.core.geometry.distance import MeshDistance
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.part.model import part_from_demo
from blisk_cam.core.process.blade_finish import PathRequest, plan_paths
from blisk_cam.core.process.job_verdict import OperationContacts, face_frame, job_verdict
from blisk_cam.core.runtime import run_to_end
from blisk_cam.core.stock.blank import stock_from_allowance
from blisk_cam.core.stock.simulation import iter_simulate
from blisk_cam.core.toolpath.types import MOVE_CUT

RES = 0.5
CHORD = 0.05
SHALLOW, DEEP = 0.25, 1.5  # mm, the planted plunges: within the tolerance, and past it



@pytest.fixture(scope="module")
def planted():
    """One blade-finishing path on the demo blade simulated on the part itself (allowance 0)
    at 0.5 mm three times: as planned, and with one cut row mid-blade dipped SHALLOW and DEEP
    into the blade along the blade's normal at the ball's centre."""
    demo = make_demo_blisk(resolution=0.6)
    part = part_from_demo(demo)
    mesh = TriMesh.from_arrays(demo.blade_vertices, demo.blade_faces)
    mc = demo.morphing_cones
    req = PathRequest(axis=demo.axis, cone1=mc.cone_at(0.45), cone2=mc.cone_at(0.5),
                      cusp=0.5, chord=CHORD, axis_mode="radial", radial_tilt=math.radians(75.0))
    path = plan_paths(mesh, req).path
    prog = path.program
    # a cut row of the middle pass half-way between its lowest and highest z: mid-chord on a
    # blade side, away from the thin edges (the rays run nearly along the side there)
    cut = np.flatnonzero(prog.move == MOVE_CUT)
    mid = cut[prog.curve[cut] == np.median(np.unique(prog.curve[cut])).astype(int)]
    z = prog.tip[mid] @ demo.axis.d
    j = int(mid[np.argmin(np.abs(z - 0.5 * (z.min() + z.max())))])
    rho = path.tool.radius
    centre = prog.tip[j] + rho * prog.axis[j]
    q = MeshDistance(mesh).query(centre[None])
    n = (centre - q.point[0]) / np.linalg.norm(centre - q.point[0])
    sims = []
    for depth in (0.0, SHALLOW, DEEP):
        tip = prog.tip.copy()
        tip[j] -= depth * n  # the ball dips `depth` into the blade along its normal
        path.program = type(prog)(tip, prog.axis, prog.move, prog.curve, prog.index, prog.flags)
        stock = stock_from_allowance(part, 0.0, RES)
        sims.append(run_to_end(iter_simulate(part, stock, [path], check_body=False)))
    return sims, q.point[0], rho, part, path


def test_a_clean_cut_passes_and_reports_what_it_does_not_judge(planted):
    sims, *_ = planted
    d = sims[0].summary["deviation_mm"]
    assert d["gouge_tolerance"] == pytest.approx(CHORD + RES)
    assert sims[0].summary["passed"], d
    # the thin edges the rays miss or clip: counted with their area, a small share of it
    assert d["not_judged_vertices"] > 0
    assert 0 < d["not_judged_area_mm2"] < 0.1 * d["area_mm2"]


def test_a_shallow_plunge_passes(planted):
    sims, *_ = planted
    d = sims[1].summary["deviation_mm"]
    assert sims[1].summary["passed"], d
    assert d["max_gouge"] <= d["gouge_tolerance"]


def test_a_deep_plunge_fails_where_it_is(planted):
    sims, contact, rho, *_ = planted
    d = sims[2].summary["deviation_mm"]
    assert not sims[2].summary["passed"], d
    assert abs(d["max_gouge"] - DEEP) <= RES
    # found at the plunge: within the ball's footprint (radius sqrt(2 ρ g) at the depth g)
    # of the blade point under the ball, plus a cell
    at = np.array(d["max_gouge_at_mm"])
    assert np.linalg.norm(at - contact) <= math.sqrt(2 * rho * DEEP) + 2 * RES


def test_the_final_verdict_fails_the_deep_plunge_alone(planted):
    """The final verdict on the deep plunge's stock: failed, by gouge zones at the plunge
    only (none elsewhere on the blade the path cut), the deepest past the plunge's depth less
    a cell."""
    sims, contact, rho, part, path = planted
    contacts = [OperationContacts.from_path(1, "blade", path, "blade_finish")]
    v = job_verdict(part, sims[2].stock, contacts)
    assert v.area_unresolved_mm2 < 0.05 * v.area_surface_mm2
    gouges = [z for z in v.zones if z.what == "gouge"]
    assert v.status == "failed" and gouges
    assert max(z.worst_mm for z in gouges) >= DEEP - RES
    _, _, _, C, _, _ = face_frame(part)
    faces = np.concatenate([z.faces for z in gouges])
    assert np.linalg.norm(C[faces] - contact, axis=1).max() <= math.sqrt(2 * rho * DEEP) + 2 * RES
