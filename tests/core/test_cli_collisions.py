"""``paths`` with collision checking, through the core API only (no bpy): the flags come
from the CollisionOptions declaration, unresolved poses give exit status 4 with one line, the
JSON carries the per-pose status, and bad collision input is refused with a clear line."""

import json

import numpy as np
import pytest

from blisk_cam.cli import main as cli
from blisk_cam.core.part.blisk import make_demo_blisk
from tests.support.mesh_files import write_binary_stl


@pytest.fixture(scope="module")
def blade(tmp_path_factory):
    d = make_demo_blisk(resolution=0.3, fillet=True, fillet_radius=10.0)
    stl = str(write_binary_stl(tmp_path_factory.mktemp("blade") / "blade.stl", d.blade_vertices,
                               d.blade_faces))
    return stl, [str(x) for x in d.tip_cone.as_list()]


def _args(blade, out, *extra):
    stl, cone2 = blade
    return ["paths", "--mesh", stl, "--cone1", "170", "-25", "185", "35", "--cone2", *cone2,
            "--tool-diameter", "12", "--cusp", "0.5", "--chord", "0.2", "--axis-mode",
            "radial", "--radial-tilt", "75", "--out", str(out), *extra]


def test_unresolved_collisions_exit_4_with_outputs_written(blade, tmp_path, capsys):
    out = tmp_path / "p.json"
    nc = tmp_path / "p.ngc"
    # a Ø60 holder from 45 mm: the neighbours leave poses no axis within the limits clears
    rc = cli.main(_args(blade, out, "--blade-count", "24", "--collisions", "avoid", "--holder",
                        "36 6 45 6 45 30 120 30", "--nc", str(nc), "--machine",
                        "ac-trunnion", "--post", "linuxcnc", "--quiet"))
    captured = capsys.readouterr()
    err = captured.err.strip().splitlines()
    d = json.loads(out.read_text())
    status = np.concatenate([c["collision"]["status"] for c in d["curves"]])
    unresolved = d["collision"]["unresolved"]
    assert d["collision"]["mode"] == "avoid"
    ranges = d["collision"].get("unresolved_ranges", [])
    in_ranges = sum(r["to"] - r["from"] + 1 for r in ranges)
    assert in_ranges == int(np.sum(status == 2))  # every unresolved pass pose in a range
    assert unresolved > 0 and ranges
    # the CLI names them, with the reason, and says which holder would clear
    assert f"unresolved pass poses in {len(ranges)} range(s): pass {ranges[0]['pass']} " \
        f"poses {ranges[0]['from']}–{ranges[0]['to']} ({ranges[0]['why']})" in captured.out
    assert "hint: " in captured.out
    assert len(d["program"]["collision_status"]) == len(d["program"]["tip"])
    assert rc == 4 and len(err) == 1 and f"{unresolved} pose(s)" in err[0]  # --quiet: 1 line
    assert "first: program row" in err[0] and not nc.exists()
    assert set(np.unique(status)) <= {0, 1, 2}
    # the clearance reported per program row is below ds exactly where the status says so
    clr = np.asarray(d["program"]["clearance"], dtype=float)
    st = np.asarray(d["program"]["collision_status"])
    assert np.all(clr[st != 2] >= d["collision"]["safety"] - 1e-9)


def test_check_mode_changes_nothing(blade, tmp_path, capsys):
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    assert cli.main(_args(blade, a)) == 0
    rc = cli.main(_args(blade, b, "--collisions", "check", "--blade-count", "24"))
    da, db = json.loads(a.read_text()), json.loads(b.read_text())
    assert rc in (0, 4)
    for ca, cb in zip(da["curves"], db["curves"], strict=True):
        assert ca["tip"] == cb["tip"] and ca["axis"] == cb["axis"]
        assert set(cb["collision"]["status"]) <= {0, 2}


@pytest.mark.parametrize(("extra", "words"), [
    (["--blade-count", "1"], ["blade count", "≥ 2"]),
    (["--collisions", "check"], ["--blade-count"]),
    (["--blade-count", "24", "--holder", "36 6 30 8"], ["holder"]),
    (["--blade-count", "24", "--holder", "36 6 60 -1"], ["holder"]),
    (["--blade-count", "24", "--safety", "-1"], ["safety", "≥ 0"]),
    (["--blade-count", "24", "--holder", "36 6 60"], ["--holder", "pairs"]),
    (["--blade-count", "24", "--max-turn-per-pose", "95"], ["--max-turn-per-pose", "89"]),
    (["--blade-count", "24", "--collisions", "avoid", "--axis-reference", "fixed"],
     ["reference direction", "--reference-direction"]),
])
def test_bad_collision_input_one_line(blade, tmp_path, capsys, extra, words):
    out = tmp_path / "p.json"
    rc = cli.main(_args(blade, out, *extra))
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and not out.exists()
    for w in words:
        assert w.lower() in err[0].lower(), (w, err[0])


def test_unreadable_obstacle_is_bad_input(blade, tmp_path, capsys):
    bad = tmp_path / "hub.stl"
    bad.write_text("not a mesh at all")
    out = tmp_path / "p.json"
    rc = cli.main(_args(blade, out, "--blade-count", "24", "--obstacle", str(bad)))
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 1 and len(err) == 1 and "hub.stl" in err[0] and not out.exists()
