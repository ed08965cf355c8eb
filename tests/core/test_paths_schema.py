"""Issue 28 row 3: the paths JSON is validated when it is read (finite numbers, shapes,
version), the error naming the field and row; no post ever writes nan or inf."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest

from blisk_cam.cli.main import main as cli_main
from blisk_cam.core.errors import BliskCamError, PostError
from blisk_cam.core.post import common
from blisk_cam.core.post.export import POSTS, export_nc
from blisk_cam.core.toolpath.paths_io import path_to_dict, read_paths_json
from tests.support.nc import demo_path


@pytest.fixture(scope="module")
def demo():
    return demo_path()


@pytest.fixture(scope="module")
def good(demo):
    return path_to_dict(demo)


def _set(d, keys, value):
    d = copy.deepcopy(d)
    node = d
    for k in keys[:-1]:
        node = node[k]
    node[keys[-1]] = value
    return d


def _read(tmp_path, d):
    f = tmp_path / "p.json"
    f.write_text(json.dumps(d))  # json writes NaN/Infinity tokens, as a hand edit can
    return read_paths_json(f)


@pytest.mark.parametrize("keys, value, words", [
    (("curves", 1, "tip", 5, 0), float("nan"), ["curves[1].tip", "row 5", "finite"]),
    (("curves", 0, "axis", 2, 2), float("inf"), ["curves[0].axis", "row 2", "finite"]),
    (("curves", 2, "cc", 0), [1.0, 2.0], ["curves[2].cc", "3"]),
    (("program", "tip", 7, 1), float("nan"), ["program.tip", "row 7", "finite"]),
    (("program", "axis", 3), [0.0, 0.0, float("-inf")], ["program.axis", "row 3"]),
    (("curves", 0, "s"), float("nan"), ["curves[0].s", "finite"]),
    (("axis",), [0, 0, 0, 0, 1], ["axis", "6"]),
    (("cone1",), [170, -25, float("nan"), 35], ["cone1", "finite"]),
    (("tolerances", "chord"), float("nan"), ["chord"]),
    (("version",), "1", ["version"]),
    (("version",), 0, ["version"]),
])
def test_bad_paths_json_names_the_field_and_row(good, tmp_path, keys, value, words):
    with pytest.raises(BliskCamError) as err:
        _read(tmp_path, _set(good, keys, value))
    for w in words:
        assert w in str(err.value)


def test_a_good_file_reads_back(good, tmp_path, demo):
    p = _read(tmp_path, good)
    assert np.array_equal(p.program.tip, demo.program.tip)


def test_nc_refuses_a_nan_paths_json_with_one_line(good, tmp_path, capsys):
    f = tmp_path / "p.json"
    f.write_text(json.dumps(_set(good, ("program", "tip", 11, 0), float("nan"))))
    out = tmp_path / "p.ngc"
    rc = cli_main(["nc", "--paths", str(f), "--machine", "ac-trunnion", "--post", "linuxcnc",
                   "--out", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 1 and len(err) == 1 and "program.tip row 11" in err[0] and not out.exists()


def test_no_post_writes_nan(demo, tmp_path):
    """An in-memory path with a NaN (the API, not the file) is refused by every post, naming
    the program row; the number formatter never prints nan/inf."""
    for bad in (float("nan"), float("inf"), -float("inf")):
        with pytest.raises(PostError):
            common.fmt(bad)
    p = copy.deepcopy(demo)
    p.program.tip[9, 2] = np.nan
    for post in POSTS:
        out = tmp_path / f"x.{post}"
        with pytest.raises(PostError, match="row 9"):
            export_nc(p, "bc-trunnion" if post in ("heidenhain", "apt") else "ac-trunnion",
                      post, None, out)
        assert not out.exists()
