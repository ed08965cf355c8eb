"""Issue 14, item 3: the verifier's figures turned into PASS/FAIL per bound, with where."""

import json
import math
from types import SimpleNamespace

import numpy as np
import pytest

from blisk_cam.core.errors import ToleranceError
from blisk_cam.core.geometry.axis import Axis
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.paths.passes import generate_paths
from blisk_cam.core.tool.cutter import Cutter
from blisk_cam.core.verify.measure import verify_path
from blisk_cam.core.verify.verdict import judge, verdict_dict, verdict_from_dict, verdict_lines
from tests.support.blades import tube_blade


def fake_report(left, gouge, at_left=(1.0, 2.0, 3.0), at_gouge=(4.0, 5.0, 6.0), tool=None):
    return SimpleNamespace(
        max_material_left=left, max_material_left_at=np.array(at_left, float),
        max_gouge=gouge, max_gouge_at=np.array(at_gouge, float),
        pair_s=np.array([[0.0, 0.5], [0.5, 1.0]]), pair_cusp=np.array([left * 0.5, left]),
        tool=tool or {"type": "ball", "radius": 6.0},
    )


def test_bounds_are_cusp_plus_chord_and_chord():
    h, e = 0.05, 0.02
    v = judge(fake_report(h + e, e), h, e)
    assert v.passed and v.status == "PASS" and v.note is None  # a ball: no note
    left, gouge = v.checks
    assert (left.name, left.bound, gouge.name, gouge.bound) == ("material_left", h + e, "gouge", e)
    assert left.between == (0.5, 1.0)  # the worst figure is the second pair's scallop
    assert left.margin == pytest.approx(0.0) and np.allclose(left.at, [1, 2, 3])
    v = judge(fake_report(h + e + 1e-6, 0.0), h, e)
    assert not v.passed and [c.passed for c in v.checks] == [False, True]
    v = judge(fake_report(0.01, e + 1e-6), h, e)
    assert not v.passed and [c.passed for c in v.checks] == [True, False]
    assert v.checks[1].margin == pytest.approx(-1e-6)


def test_not_measured_fails_and_bad_input_is_refused():
    v = judge(fake_report(float("nan"), 0.0), 0.05, 0.05)
    assert not v.passed and not v.checks[0].passed
    assert "not measured" in verdict_lines(v)[1]
    assert verdict_dict(v)["checks"]["material_left"]["value"] is None
    for bad in (0.0, -1.0, float("nan"), "x", None):
        with pytest.raises(ToleranceError, match="cusp"):
            judge(fake_report(0.01, 0.0), bad, 0.05)
        with pytest.raises(ToleranceError, match="chord"):
            judge(fake_report(0.01, 0.0), 0.05, bad)
    with pytest.raises(ToleranceError, match="cutter"):
        judge(fake_report(0.01, 0.0), 0.05, 0.05, cutter=42)


def test_bull_nose_note_explains_why_twice_the_cusp_can_pass():
    """0.0999 mm of material left against a cusp of 0.05 mm is within cusp + chord."""
    bull = Cutter.from_spec("bull", 6.0, 2.0)
    v = judge(fake_report(0.0999, 0.01), 0.05, 0.05, cutter=bull)
    assert v.passed and v.tool["type"] == "bull"
    assert "cusp + chord = 0.1 mm" in v.note and "0.0999" in v.note and "bull-nose" in v.note
    assert verdict_lines(v)[-1] == v.note
    assert verdict_dict(v)["note"] == v.note
    # the cutter defaults to the report's tool dict
    v2 = judge(fake_report(0.0999, 0.01, tool={"type": "flat", "radius": 5.0}), 0.05, 0.05)
    assert "flat end mill" in v2.note and "5 mm" in v2.note


def test_dict_and_lines_name_the_figures():
    v = judge(fake_report(0.2, 0.07), 0.05, 0.05)
    d = verdict_dict(v)
    assert json.loads(json.dumps(d)) == d
    assert d["status"] == "FAIL" and d["checks"]["material_left"]["status"] == "FAIL"
    assert d["checks"]["gouge"] == {"value": 0.07, "bound": 0.05, "status": "FAIL",
                                    "at": [4.0, 5.0, 6.0]}
    lines = verdict_lines(v)
    assert lines[0].startswith("verify: FAIL")
    assert "FAIL material left 0.2000 mm > 0.1000 mm (cusp + chord)" in lines[1]
    assert "between the passes at s = 0.5000 and 1.0000" in lines[1]
    assert "FAIL gouge 0.0700 mm > 0.0500 mm (chord)" in lines[2]
    assert "(4.000, 5.000, 6.000)" in lines[2]


@pytest.fixture(scope="module")
def tube_path():
    V, F, mc = tube_blade()
    mesh = TriMesh.from_arrays(V, F)
    path = generate_paths(mesh, Axis(), mc.cone1, mc.cone2, tool_radius=4.0, cusp=0.1, chord=0.1)
    return mesh, path, verify_path(mesh, path)


def test_real_report_is_judged_and_located(tube_path):
    mesh, path, rep = tube_path
    v = judge(rep, path.cusp, path.chord, path.tool, path=path)
    left, gouge = v.checks
    assert left.value == rep.max_material_left and gouge.value == rep.max_gouge
    assert v.passed == (rep.max_material_left <= 0.2 and rep.max_gouge <= 0.1)
    assert v.passed  # measured on this tube: well inside both bounds
    # the named pose is the cutting pose nearest the worst point
    for c in v.checks:
        cc = path.curves[c.curve].cc[c.pose]
        nearest = min(np.linalg.norm(k.cc - c.at, axis=1).min() for k in path.curves)
        assert np.linalg.norm(cc - c.at) == pytest.approx(nearest)
        assert c.s == path.curves[c.curve].s
    # the worst scallop is between two neighbouring levels, and the pose lies on one of them
    assert left.between is not None and left.between[0] < left.between[1]
    lines = verdict_lines(v)
    assert lines[0].startswith("verify: PASS") and "near pass" in lines[1]
    d = verdict_dict(v)
    assert d["checks"]["material_left"]["curve"] == left.curve
    assert math.isclose(d["checks"]["gouge"]["value"], rep.max_gouge)


def test_dict_round_trip_gives_the_same_lines(tube_path):
    mesh, path, rep = tube_path
    for v in (judge(rep, path.cusp, path.chord, path.tool, path=path),
              judge(fake_report(0.2, float("nan")), 0.05, 0.05,
                    cutter=Cutter.from_spec("bull", 6.0, 2.0))):
        d = json.loads(json.dumps(verdict_dict(v)))
        assert verdict_lines(verdict_from_dict(d)) == verdict_lines(v)
    with pytest.raises(ToleranceError, match="malformed"):
        verdict_from_dict({"status": "PASS"})
