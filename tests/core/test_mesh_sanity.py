"""Issue 28, row 6 (the rest after units): a blade mesh with holes in the region and an axis
that is not the blade's.

* Holes: four patches cut out of the demo blade inside the region. The plan warns, naming
  each hole where it is; the holes' areas are the areas of the faces taken out (measured on
  those faces); verify does not PASS a region it could not measure.
* A wrong axis: the blade's loops lie on no cone or profile about the X or Y axis (Rotor 37:
  4.36 mm off, the issue's 4.4 mm) — refused, naming the residual and the fix; the right
  axis still fits.
"""

from __future__ import annotations

import numpy as np
import pytest

from blisk_cam.cli import main as cli
from blisk_cam.core.errors import ConeError
from blisk_cam.core.geometry.axis import Axis
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.part.fitting import AXIS_FIT_LIMIT, fit_cones_to_mesh, region_holes
from blisk_cam.core.part.profiles import morph_between
from blisk_cam.core.process.blade_finish import PathRequest, plan_paths
from blisk_cam.core.verify.measure import verify_path
from blisk_cam.core.verify.verdict import judge, verdict_lines
from tests.support.blades import blade_stl, nasa_blade


@pytest.fixture(scope="module")
def holed():
    """The demo blade (resolution 0.5) with 4 round patches (radius 0.8 mm) cut out of one
    flank at mid-chord (where the blade is thickest: never through it), from hub to tip;
    the punched centres and the area of the faces taken out."""
    d = make_demo_blisk(resolution=0.5)
    mesh = TriMesh.from_arrays(d.blade_vertices, d.blade_faces)
    band = morph_between(d.hub_cone, d.tip_cone)
    s = band.ratio_of_points(mesh.V, d.axis)
    z = (mesh.V - d.axis.o) @ d.axis.d
    around = np.cross(d.axis.d, mesh.V - d.axis.o)  # the circumferential direction
    flank = np.einsum("ij,ij->i", mesh.vertex_normals, around) > 0
    centres, drop = [], np.zeros(len(mesh.F), bool)
    cen = mesh.V[mesh.F].mean(axis=1)
    for lo in (0.3, 0.45, 0.6, 0.75):
        cand = np.nonzero((s > lo) & (s < lo + 0.05) & flank)[0]
        p = mesh.V[cand[np.argmin(np.abs(z[cand] - np.median(z[cand])))]]
        centres.append(p)
        drop |= np.linalg.norm(cen - p, axis=1) < 0.8
    areas = mesh.face_areas
    out = TriMesh.from_arrays(mesh.V, mesh.F[~drop])
    return d, out, np.array(centres), float(areas[drop].sum())


def test_holes_are_named_where_they_are_and_verify_does_not_pass(holed):
    d, mesh, centres, cut_area = holed
    holes = region_holes(mesh, d.axis, d.hub_cone, d.tip_cone)
    assert len(holes) == 4
    found = np.array([h.centre for h in holes])
    # every punched patch is one hole, centred on it; the open area is the faces' area
    assert np.linalg.norm(found[:, None] - centres[None], axis=2).min(axis=0).max() < 0.5
    assert sum(h.area for h in holes) == pytest.approx(cut_area, rel=0.05)
    c1, c2 = (morph_between(d.hub_cone, d.tip_cone).cone_at(s) for s in (0.25, 0.85))
    req = PathRequest(axis=d.axis, cone1=c1, cone2=c2, cusp=0.2, chord=0.1, lead=0.1)
    path = plan_paths(mesh, req).path
    warning = [w for w in path.warnings if "hole" in w]
    assert len(warning) == 1 and "4 hole(s)" in warning[0] and "fill the holes" in warning[0]
    h0 = holes[0]
    assert f"r {h0.r:.1f} z {h0.z:.1f} mm" in warning[0]
    assert path.stats["holes"] == 4
    report = verify_path(mesh, path)
    verdict = judge(report, req.cusp, req.chord, path.tool, path)
    checks = {c.name: c for c in verdict.checks}
    assert not verdict.passed and not checks["uncovered"].passed
    assert checks["uncovered"].value == pytest.approx(cut_area, rel=0.05)
    assert any("not measured" in line for line in verdict_lines(verdict))


def test_a_mesh_without_holes_has_no_uncovered_check():
    d = make_demo_blisk(resolution=0.5)
    mesh = TriMesh.from_arrays(d.blade_vertices, d.blade_faces)
    assert region_holes(mesh, d.axis, d.hub_cone, d.tip_cone) == []


@pytest.mark.parametrize("name", ["rotor37", "rotor67"])
def test_an_axis_the_blade_does_not_turn_about_is_refused(name):
    V, F, _, _ = nasa_blade(name)
    mesh = TriMesh.from_arrays(V, F)
    fit = fit_cones_to_mesh(mesh, Axis(), generatrix="auto")  # the blade's own axis fits
    assert max(fit.residual1, fit.residual2) < AXIS_FIT_LIMIT
    for d in ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0)):
        with pytest.raises(ConeError, match=r"lies up to \d+\.\d\d mm off every cone and "
                                            r"profile about the axis .*--axis"):
            fit_cones_to_mesh(mesh, Axis((0.0, 0.0, 0.0), d), generatrix="cone")


def test_cli_refuses_the_axis_along_x_with_the_residual(tmp_path, capsys):
    rc = cli.main(["paths", "--mesh", str(blade_stl("rotor37")), "--axis", "0", "0", "0",
                   "1", "0", "0", "--out", str(tmp_path / "p.json")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 1 and len(err) == 1, err
    assert "4.36 mm off every cone" in err[0] and "--axis" in err[0]
    assert not (tmp_path / "p.json").exists()
