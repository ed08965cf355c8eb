"""Paths JSON: the fields added for cutters, moves, flags and the linked program round-trip,
and version-1 files and readers keep working."""

import json
import math

import numpy as np
import pytest

from blisk_cam.core.errors import BliskCamError
from blisk_cam.core.geometry.axis import Axis
from blisk_cam.core.part.cones import Cone
from blisk_cam.core.tool.cutter import Cutter
from blisk_cam.core.toolpath.paths_io import (
    path_from_dict,
    path_to_dict,
    read_paths_json,
    write_paths_json,
)
from blisk_cam.core.toolpath.types import (
    FLAG_LOCAL_GOUGE,
    FLAG_ZERO_SPEED,
    MOVE_APPROACH,
    MOVE_CUT,
    MOVE_RAPID,
    MOVE_RETRACT,
    BallTool,
    PassCurve,
    Program,
    ToolPath,
)


def _path(tool, with_program=True):
    rng = np.random.default_rng(7)
    curves = []
    for i, s in enumerate((0.0, 0.5, 1.0)):
        k = 5 + i
        cc = rng.normal(size=(k, 3)) * 10 + [150, 0, 0]
        n = rng.normal(size=(k, 3))
        n /= np.linalg.norm(n, axis=1)[:, None]
        flags = np.zeros(k, np.uint8)
        flags[0] = FLAG_LOCAL_GOUGE | FLAG_ZERO_SPEED
        curves.append(
            PassCurve(
                s=s,
                closed=i != 1,
                cc=cc,
                normal=n,
                tip=cc + 0.1,
                axis=n,
                flags=flags,
                ratio=np.linspace(s, s + 0.1, k) if i == 1 else None,
            )
        )
    prog = None
    if with_program:
        m = 7
        prog = Program(
            tip=rng.normal(size=(m, 3)),
            axis=np.tile([0, 0, 1.0], (m, 1)),
            move=np.array(
                [MOVE_RAPID, MOVE_APPROACH, MOVE_CUT, MOVE_CUT, MOVE_CUT, MOVE_RETRACT, MOVE_RAPID],
                np.int8,
            ),
            curve=np.array([-1, 0, 0, 0, 0, -1, -1]),
            index=np.array([-1, 0, 1, 2, 0, -1, -1]),
            flags=np.array([0, 3, 0, 0, 3, 0, 0], np.uint8),
        )
    return ToolPath(
        Axis(),
        Cone(100, 0, 100, 30),
        Cone(150, 0, 150, 30),
        tool,
        0.05,
        0.05,
        curves,
        stats={"passes": 3},
        program=prog,
    )


@pytest.mark.parametrize(
    "tool", [Cutter.ball(6), Cutter.bull(6, 2), Cutter.flat(5), Cutter.taper(3, math.radians(4))]
)
def test_round_trip(tmp_path, tool):
    path = _path(tool)
    f = write_paths_json(path, tmp_path / "p.json")
    back = read_paths_json(f)
    assert back.tool == tool
    for a, b in zip(path.curves, back.curves, strict=True):
        assert np.array_equal(a.cc, b.cc) and np.array_equal(a.tip, b.tip)  # full precision
        assert np.array_equal(a.move, b.move) and np.array_equal(a.flags, b.flags)
        assert (a.ratio is None) == (b.ratio is None)
        if a.ratio is not None:
            assert np.array_equal(a.ratio, b.ratio)
    for key in ("tip", "axis", "move", "curve", "index", "flags"):
        assert np.array_equal(getattr(path.program, key), getattr(back.program, key))
    d = json.loads((tmp_path / "p.json").read_text())
    assert d["program"]["move"][:2] == ["rapid", "approach"]
    assert d["program"]["rapid"] == [True, False, False, False, False, False, True]
    assert d["curves"][0]["move"] == ["cut"] * 5 and d["curves"][0]["flags"][0] == 3
    assert d["tool"]["type"] == tool.type and d["tool"]["radius"] == tool.radius
    assert d["flag_bits"] == {
        "local_gouge": 1,
        "zero_speed": 2,
        "gouge_fixed": 4,
        "axis_smoothed": 8,
    }


def test_version1_fields_unchanged_and_version1_files_read():
    d = path_to_dict(_path(BallTool(6.0), with_program=False))
    assert d["version"] == 1 and d["format"] == "blisk_cam.paths" and d["units"] == "mm"
    for c in d["curves"]:
        assert set(c) >= {"s", "closed", "cc", "normal", "tip", "axis"}
    assert "program" not in d
    # a version-1 file as written before this change: no move/flags, a short tool
    old = {k: d[k] for k in ("format", "version", "units", "axis", "cone1", "cone2", "tolerances")}
    old["tool"] = {"type": "ball", "radius": 6.0}
    old["curves"] = [
        {k: c[k] for k in ("s", "closed", "cc", "normal", "tip", "axis")} for c in d["curves"]
    ]
    back = path_from_dict(old)
    assert back.tool == Cutter.ball(6.0) and back.program is None
    assert all(np.all(c.move == MOVE_CUT) and np.all(c.flags == 0) for c in back.curves)


def test_malformed_additions_are_refused():
    d = path_to_dict(_path(Cutter.bull(6, 2)))
    d["curves"][0]["move"] = ["cut", "fly"] + ["cut"] * 3
    with pytest.raises(BliskCamError, match="fly"):
        path_from_dict(d)
    d = path_to_dict(_path(Cutter.bull(6, 2)))
    d["program"]["axis"] = d["program"]["axis"][:-1]
    with pytest.raises(BliskCamError, match="program"):
        path_from_dict(d)
    d = path_to_dict(_path(Cutter.bull(6, 2)))
    d["tool"] = {"type": "bull", "radius": 6.0, "corner_radius": 7.0}
    with pytest.raises(BliskCamError, match="corner radius"):
        path_from_dict(d)


def test_non_finite_stats_are_left_out_of_the_strict_json(tmp_path):
    # JSON has no infinity: a stats figure that is ∞ (e.g. no concave region) must not make
    # the write fail, and is not written
    path = _path(Cutter.ball(6.0))
    path.stats.update({"concave_radius": math.inf, "nan_figure": math.nan, "edge_radius": 0.3})
    out = tmp_path / "p.json"
    write_paths_json(path, out)
    stats = json.loads(out.read_text())["stats"]
    assert stats["edge_radius"] == 0.3
    assert "concave_radius" not in stats and "nan_figure" not in stats
