"""Issue 28 row 1 (and row 9's mark): one collision gate for every NC export. A path with
unresolved collisions is refused by ``export_nc``, ``nc`` and ``paths --nc`` alike unless the
user allows it, and then the header says how many and where; a path never checked for
collisions is posted with a header line and a warning on stderr."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest

from blisk_cam.cli.main import main as cli_main
from blisk_cam.core.errors import PostError
from blisk_cam.core.post.blocks import NcOptions
from blisk_cam.core.post.export import export_nc
from blisk_cam.core.post.gate import unresolved_ranges
from blisk_cam.core.toolpath.paths_io import write_paths_json
from tests.support.nc import demo_path


@pytest.fixture(scope="module")
def demo():
    return demo_path()


def checked(path, rows=()):
    """``path`` as a collision check would leave it: every program row clear except ``rows``
    (unresolved)."""
    p = copy.deepcopy(path)
    m = len(p.program)
    status = np.zeros(m, np.int8)
    status[list(rows)] = 2
    p.program.collision_status = status
    p.program.clearance = np.where(status == 2, -0.5, 5.0)
    p.program.rotation_deg = np.zeros(m)
    p.collision = {"mode": "check", "checked_poses": m, "colliding_before": len(rows),
                   "corrected": 0, "unresolved": len(rows), "min_clearance": -0.5}
    return p


def cut_rows(path, curve, k):
    """k consecutive program rows of pass ``curve``: (rows, first pose index, last)."""
    rows = np.flatnonzero(np.asarray(path.program.curve) == curve)[2:2 + k]
    return rows, int(path.program.index[rows[0]]), int(path.program.index[rows[-1]])


def test_export_refuses_unresolved_collisions_naming_where(demo, tmp_path):
    rows, i0, i1 = cut_rows(demo, 1, 3)
    p = checked(demo, rows)
    out = tmp_path / "p.ngc"
    with pytest.raises(PostError, match=rf"3 pose\(s\).*pass 1 poses {i0}-{i1}"):
        export_nc(p, "ac-trunnion", "linuxcnc", None, out)
    assert not out.exists()


def test_allowed_collisions_are_marked_in_the_header(demo, tmp_path):
    rows, i0, i1 = cut_rows(demo, 1, 3)
    p = checked(demo, list(rows) + [len(demo.program) - 1])
    for post, ext in (("linuxcnc", "ngc"), ("fanuc", "nc")):
        out = tmp_path / f"p.{ext}"
        rep = export_nc(p, "ac-trunnion", post, NcOptions(allow_collisions=True), out)
        head = out.read_text().upper().split("G1" if post == "linuxcnc" else "G90")[0]
        assert "4 UNRESOLVED COLLISION" in head
        assert f"PASS 1 POSES {i0}-{i1}" in head
        last = len(demo.program) - 1
        assert (f"LINK ROW {last}" in head) == (int(demo.program.curve[last]) < 0)
        assert rep.gate.unresolved == 4 and "NOT CHECKED" not in head


def test_unchecked_path_is_marked_and_checked_clean_path_is_not(demo, tmp_path):
    a, b = tmp_path / "a.ngc", tmp_path / "b.ngc"
    rep = export_nc(demo, "ac-trunnion", "linuxcnc", None, a)
    assert "COLLISIONS NOT CHECKED" in a.read_text().upper() and rep.gate.warning
    rep = export_nc(checked(demo), "ac-trunnion", "linuxcnc", None, b)
    assert "COLLISION" not in b.read_text().upper() and rep.gate.warning is None


def test_nc_command_goes_through_the_same_gate(demo, tmp_path, capsys):
    rows, i0, i1 = cut_rows(demo, 2, 5)
    js = tmp_path / "r.json"
    write_paths_json(checked(demo, rows), js)
    out = tmp_path / "p.ngc"
    base = ["nc", "--paths", str(js), "--machine", "ac-trunnion", "--post", "linuxcnc",
            "--out", str(out)]
    assert cli_main(base) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "5 pose(s)" in err[0] and "--allow-collisions" in err[0]
    assert not out.exists()
    assert cli_main([*base, "--allow-collisions"]) == 0
    err = capsys.readouterr().err
    assert "warning" in err and f"pass 2 poses {i0}-{i1}" in err
    assert f"pass 2 poses {i0}-{i1}" in out.read_text()
    # never checked: posted, with the header line and a warning on stderr
    write_paths_json(demo, js)
    assert cli_main(base) == 0
    assert "never checked for collisions" in capsys.readouterr().err
    assert "COLLISIONS NOT CHECKED" in out.read_text()
    d = json.loads(js.read_text())
    assert "collision" not in d


def test_a_closed_pass_run_through_its_closing_pose_is_named_so(demo):
    """A closed pass ends on its first pose again (index 0): the range to it reads 'poses a-b
    and its closing pose', not 'poses a-0'."""
    prog = demo.program
    curve, index = np.asarray(prog.curve), np.asarray(prog.index)
    ends = np.flatnonzero((curve[:-1] >= 0) & (curve[1:] == curve[:-1])
                          & (index[1:] < index[:-1]))
    assert len(ends), "the demo has a closed pass"
    last = int(ends[0]) + 1  # the closing row
    rows = [last - 2, last - 1, last]
    text = unresolved_ranges(checked(demo, rows))
    c = int(curve[last])
    assert text == [f"pass {c} poses {int(index[last - 2])}-{int(index[last - 1])} and its "
                    "closing pose"]
