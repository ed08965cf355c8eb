"""The simulated stock against verify (issue #22's acceptance, at a cheap scale): on the demo
blisk, stock = part + 0.1 mm, a finishing program of a few passes near the tip (a radial
axis tilted 75°: its body clears the neighbouring blade — checked: no crash), the deviation
on the blade is ≥ −(chord + resolution) everywhere, ≤ cusp + chord + resolution where the path
reaches (where verify measures), and agrees with verify's material left (the distance from
the surface to the swept cutter, an independent measurement) within resolution + 2 µm —
verify's figure of the whole program: the stock is cut by the links too, so where a link
passes nearer than the cuts its figure counts (:func:`link_material_left`)."""

from __future__ import annotations

import math

import numpy as np

from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.part.model import part_from_demo
from blisk_cam.core.process.blade_finish import PathRequest, plan_paths
from blisk_cam.core.stock.blank import stock_from_allowance
from blisk_cam.core.stock.deviation import deviation_map, vertex_normals
from blisk_cam.core.stock.removal import remove_program
from blisk_cam.core.verify.links import link_material_left
from blisk_cam.core.verify.measure import verify_path

RES = 0.1
CUSP = CHORD = 0.05


def test_deviation_agrees_with_verify_on_the_demo_finishing_passes():
    demo = make_demo_blisk(resolution=0.4)
    part = part_from_demo(demo)
    mesh = TriMesh.from_arrays(demo.blade_vertices, demo.blade_faces)
    mc = demo.morphing_cones
    req = PathRequest(axis=demo.axis, cone1=mc.cone_at(0.85), cone2=mc.cone_at(0.9),
                      cusp=CUSP, chord=CHORD, axis_mode="radial",
                      radial_tilt=math.radians(75.0))
    path = plan_paths(mesh, req).path
    stock = stock_from_allowance(part, 0.1, RES)
    res = remove_program(stock, path.program, path.tool)
    assert res.crashes == []
    assert res.removed["cut"] > 0
    report = verify_path(mesh, path)
    dev = deviation_map(stock, mesh.V, vertex_normals(mesh.V, mesh.F))
    reached = np.isfinite(report.vertex_values)
    assert reached.sum() > 100 and (~reached).sum() > 100
    assert dev.min() >= -(CHORD + RES)
    assert dev[reached].max() <= CUSP + CHORD + RES
    whole = np.fmin(report.vertex_values, link_material_left(path.program, path.tool, mesh.V))
    gap = np.abs(dev[reached] - whole[reached])
    assert gap.max() <= RES + 2e-3
    # away from the passes the allowance stays (the stock was not cut there)
    far = ~reached & (np.abs(dev - 0.1) <= RES)
    assert far.sum() > 0.5 * (~reached).sum()
