"""Issue 28 row 5: an output that is an input (or another output) is refused before any work,
the user's file untouched. Compared as resolved paths and by samefile (links)."""

from __future__ import annotations

import os

import pytest

from blisk_cam.cli.main import main as cli_main
from tests.support.mesh_files import write_binary_stl


@pytest.fixture
def stl(tmp_path, tube):
    V, F = tube[:2]
    return write_binary_stl(tmp_path / "my_blade.stl", V, F)


def _paths(stl, out, *extra):
    return ["paths", "--mesh", str(stl), "--cone1", "10", "-1", "10", "1", "--cone2", "20",
            "-1", "20", "1", "--out", str(out), *extra]


def _refused(argv, capsys, *files, words=()):
    before = {f: f.read_bytes() for f in files if f.exists()}
    rc = cli_main(argv)
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1, err
    for w in words:
        assert w in err[0]
    for f, data in before.items():
        assert f.read_bytes() == data  # untouched
    return err[0]


def test_out_equal_to_the_mesh_is_refused(stl, tmp_path, capsys):
    _refused(_paths(stl, stl), capsys, stl, words=("--out", "--mesh"))
    # the same file by another spelling and through a hard link
    other = tmp_path / "sub" / ".." / "my_blade.stl"
    (tmp_path / "sub").mkdir()
    _refused(_paths(stl, other), capsys, stl, words=("--out", "--mesh"))
    link = tmp_path / "link.stl"
    os.link(stl, link)
    _refused(_paths(stl, link), capsys, stl, words=("--out", "--mesh"))


def test_nc_equal_to_out_is_refused(stl, tmp_path, capsys):
    out = tmp_path / "p.json"
    _refused(_paths(stl, out, "--nc", str(out), "--machine", "ac-trunnion", "--post",
                    "linuxcnc"), capsys, words=("--nc", "--out"))
    assert not out.exists()


def test_nc_command_out_equal_to_paths_is_refused(tmp_path, capsys):
    js = tmp_path / "p.json"
    js.write_text("{}")
    _refused(["nc", "--paths", str(js), "--machine", "ac-trunnion", "--post", "linuxcnc",
              "--out", str(js)], capsys, js, words=("--out", "--paths"))
    _refused(["nc", "--paths", str(js), "--machine", "ac-trunnion", "--post", "linuxcnc",
              "--out", str(tmp_path / "a.ngc"), "--report", str(tmp_path / "a.ngc")], capsys,
             words=("--report", "--out"))
