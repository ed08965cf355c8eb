"""Issue 28 row 14: the blade count is entered once (``--blade-count``; ``--blades`` is a
deprecated alias that errors when it disagrees), and the collision default of the command
line is the panel's (check: change nothing, report, the NC gate refuses what is unresolved)."""

from __future__ import annotations

import pytest

from blisk_cam.cli.main import build_parser
from blisk_cam.cli.main import main as cli_main
from blisk_cam.cli.paths import _check_paths_args
from blisk_cam.core.collision.options import DEFAULT_CHECK_MODE
from blisk_cam.core.toolpath.paths_io import write_paths_json
from tests.support.nc import demo_path


@pytest.fixture(scope="module")
def paths_json(tmp_path_factory):
    f = tmp_path_factory.mktemp("bc") / "p.json"
    write_paths_json(demo_path(), f)
    return f


def _nc(paths_json, out, *extra):
    return ["nc", "--paths", str(paths_json), "--machine", "ac-trunnion", "--post",
            "linuxcnc", "--out", str(out), *extra]


def test_nc_takes_the_blade_count(paths_json, tmp_path, capsys):
    out = tmp_path / "a.ngc"
    assert cli_main(_nc(paths_json, out, "--blade-count", "3")) == 0
    assert "blades: 3" in out.read_text()
    assert "deprecated" not in capsys.readouterr().err
    # the old name still works, says it is deprecated
    assert cli_main(_nc(paths_json, out, "--blades", "3")) == 0
    assert "blades: 3" in out.read_text() and "deprecated" in capsys.readouterr().err


def test_a_mismatch_is_refused(paths_json, tmp_path, capsys):
    out = tmp_path / "b.ngc"
    assert cli_main(_nc(paths_json, out, "--blades", "22", "--blade-count", "36")) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "22" in err[0] and "36" in err[0] and not out.exists()
    rc = cli_main(["paths", "--mesh", str(tmp_path / "none.stl"), "--out",
                   str(tmp_path / "p.json"), "--blade-count", "36", "--blades", "22", "--nc",
                   str(out), "--machine", "ac-trunnion", "--post", "linuxcnc"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "--blades" in err[0] and "--blade-count" in err[0]


def _paths_args(tmp_path, *extra):
    args = build_parser().parse_args(["paths", "--mesh", "m.stl", "--out",
                                      str(tmp_path / "p.json"), *extra])
    _check_paths_args(args)
    return args


def test_paths_blade_count_serves_collisions_and_nc(tmp_path):
    args = _paths_args(tmp_path, "--blade-count", "24", "--nc", str(tmp_path / "p.ngc"),
                       "--machine", "ac-trunnion", "--post", "linuxcnc")
    from blisk_cam.cli.nc import nc_options

    assert args.collision.blade_count == 24 and nc_options(args).blades == 24
    # the collision default once a blade count is given is the panel's: check
    assert args.collision.mode == DEFAULT_CHECK_MODE == "check"
    assert _paths_args(tmp_path).collision.mode == "off"
