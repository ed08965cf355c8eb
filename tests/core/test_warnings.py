"""Issue 14, item 2: a path cutting at zero speed says so.

With the default lead = tilt = 0 a ball touches the surface at its tip, on the tool axis,
where the cutting speed is zero (``FLAG_ZERO_SPEED``); on Rotor 37 every pose. The planner now
adds a warning to ``PlanResult.warnings`` / ``ToolPath.warnings`` and the paths JSON's
top-level ``"warnings"`` (absent when empty) once 10 % or more of the poses do."""

import json
import math

import numpy as np
import pytest

from blisk_cam.core.errors import BliskCamError
from blisk_cam.core.geometry.axis import Axis
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.process.blade_finish import (
    ZERO_SPEED_WARN_SHARE,
    PathRequest,
    plan_paths,
    zero_speed_warning,
)
from blisk_cam.core.toolpath.paths_io import (
    path_from_dict,
    path_to_dict,
    read_paths_json,
    write_paths_json,
)
from blisk_cam.core.toolpath.types import FLAG_ZERO_SPEED


@pytest.fixture(scope="module")
def r37_mesh(rotor37):
    V, F, c1, c2 = rotor37
    return TriMesh.from_arrays(V, F), c1, c2


def _plan(r37_mesh, **kw):
    mesh, c1, c2 = r37_mesh
    return plan_paths(mesh, PathRequest(axis=Axis(), cone1=c1, cone2=c2, cusp=0.1, chord=0.1, **kw))


def test_zero_speed_warning_text_and_threshold():
    assert ZERO_SPEED_WARN_SHARE == 0.10
    assert zero_speed_warning(0, 100) is None
    assert zero_speed_warning(9, 100) is None  # below 10 %
    w = zero_speed_warning(10, 100)
    assert w is not None and "10 of 100 poses (10 %)" in w and "--lead 10" in w
    assert "zero" in w
    assert zero_speed_warning(0, 0) is None


def test_default_ball_path_on_rotor37_warns(r37_mesh, tmp_path):
    res = _plan(r37_mesh)  # lead = tilt = 0, the defaults
    path = res.path
    zero = sum(int(np.count_nonzero(c.flags & FLAG_ZERO_SPEED)) for c in path.curves)
    assert zero == path.stats["zero_speed_poses"] == path.stats["poses"] > 0
    assert len(path.warnings) == 1
    w = path.warnings[0]
    assert f"{zero} of {zero} poses (100 %)" in w and "--lead 10" in w
    assert w in res.warnings  # with the generator's own (stats["warnings"]) if any
    d = path_to_dict(path)
    assert d["warnings"] == [w]
    assert list(d)[-1] == "warnings"  # appended: every other key as before
    f = write_paths_json(path, tmp_path / "p.json")
    assert json.loads(open(f).read())["warnings"] == [w]
    assert read_paths_json(f).warnings == [w]


def test_lead_clears_the_warning_and_the_key(r37_mesh):
    res = _plan(r37_mesh, lead=math.radians(10.0))
    assert res.path.stats["zero_speed_poses"] == 0
    assert res.path.warnings == [] and "warnings" not in path_to_dict(res.path)
    assert path_from_dict(path_to_dict(res.path)).warnings == []


def test_bad_warnings_in_a_paths_file_are_refused(r37_mesh):
    d = path_to_dict(_plan(r37_mesh, lead=math.radians(10.0)).path)
    for bad in ("one string", [1, 2], {"a": "b"}):
        d["warnings"] = bad
        with pytest.raises(BliskCamError, match="warnings"):
            path_from_dict(d)
