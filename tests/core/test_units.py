"""Issue 28 row 6 (size and units): a blade mesh in metres or inches is refused with its size
and the fix (``--units m|in``), and ``--units`` scales it to mm."""

from __future__ import annotations

import json

import numpy as np
import pytest

from blisk_cam.cli import main as cli
from blisk_cam.core.errors import MeshError
from blisk_cam.core.geometry.axis import Axis
from blisk_cam.core.geometry.mesh_io import check_blade_size
from tests.support.blades import tube_blade
from tests.support.mesh_files import write_binary_stl


@pytest.fixture(scope="module")
def tube():
    return tube_blade()


@pytest.mark.parametrize("scale, unit", [(0.001, "m"), (1 / 25.4, "in")])
def test_wrong_units_refused_with_the_size_and_the_fix(tube, tmp_path, capsys, scale, unit):
    V, F, mc = tube
    stl = write_binary_stl(tmp_path / "b.stl", V * scale, F)
    out = tmp_path / "p.json"
    args = ["paths", "--mesh", str(stl), "--tool-diameter", "8", "--cusp", "0.2", "--chord",
            "0.2", "--out", str(out)]
    assert cli.main(args) == 1
    err = capsys.readouterr().err.strip().splitlines()
    r = float(np.hypot(V[:, 0], V[:, 1]).max() * scale)
    assert len(err) == 1 and f"--units {unit}" in err[0] and f"{r:.3g}" in err[0]
    assert not out.exists()
    cones = ["--cone1", *map(str, mc.cone1.as_list()), "--cone2", *map(str, mc.cone2.as_list())]
    assert cli.main([*args, *cones, "--units", unit]) == 0
    d = json.loads(out.read_text())
    tips = np.concatenate([c["tip"] for c in d["curves"]])
    assert np.hypot(tips[:, 0], tips[:, 1]).max() > 90  # the path is in mm


def test_a_blade_in_mm_passes(tube):
    V, _, _ = tube
    check_blade_size(V, Axis())
    with pytest.raises(MeshError, match="--units"):
        check_blade_size(V / 1000, Axis())
