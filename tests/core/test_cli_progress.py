"""Issue 28 row 13: the long stages of ``paths`` (planning, verify, NC posting) print
percentage lines on stderr while they run, ``--quiet`` silences them, and the printed wall time
includes the NC posting."""

from __future__ import annotations

import re

import pytest

from blisk_cam.cli import main as cli
from blisk_cam.core.part.blisk import make_demo_blisk
from tests.support.mesh_files import write_binary_stl


@pytest.fixture(scope="module")
def blade(tmp_path_factory):
    d = make_demo_blisk(resolution=0.3, fillet=True, fillet_radius=10.0)
    stl = str(write_binary_stl(tmp_path_factory.mktemp("blade") / "blade.stl",
                               d.blade_vertices, d.blade_faces))
    return stl, ["170", "-25", "185", "35"], [str(x) for x in d.tip_cone.as_list()]


def _args(blade, tmp_path, *extra):
    stl, c1, c2 = blade
    return ["paths", "--mesh", stl, "--cone1", *c1, "--cone2", *c2, "--tool-diameter", "12",
            "--cusp", "0.5", "--chord", "0.2", "--axis-mode", "radial", "--radial-tilt", "75",
            "--out", str(tmp_path / "p.json"), *extra]


PCT = re.compile(r"^blisk_cam: (\w+) +(\d+)%")


def test_progress_lines_and_the_wall_time_with_nc(blade, tmp_path, capsys):
    rc = cli.main(_args(blade, tmp_path, "--verify", "--nc", str(tmp_path / "p.ngc"),
                        "--machine", "ac-trunnion", "--post", "linuxcnc"))
    cap = capsys.readouterr()
    assert rc == 0
    lines = [PCT.match(x) for x in cap.err.splitlines()]
    stages = {}
    for m in lines:
        if m:
            stages.setdefault(m.group(1), []).append(int(m.group(2)))
    # every long stage reports, percentages rise to 100
    for stage in ("plan", "verify", "nc"):
        assert stage in stages, cap.err
        assert stages[stage][-1] == 100 and stages[stage] == sorted(stages[stage])
    assert len(stages["plan"]) >= 3
    line = next(x for x in cap.out.splitlines() if x.startswith("time: "))
    figures = dict((k, float(v)) for k, v in re.findall(r"(\w+) ([\d.]+) s", line))
    assert "nc" in figures and figures["nc"] > 0
    assert figures["wall"] >= sum(v for k, v in figures.items() if k != "wall") - 0.02
    # the time line is printed after the NC summary (it includes it)
    out = cap.out.splitlines()
    assert out.index(line) > max(i for i, x in enumerate(out) if "blocks" in x)


def test_quiet_silences_the_progress(blade, tmp_path, capsys):
    rc = cli.main(_args(blade, tmp_path, "--quiet"))
    cap = capsys.readouterr()
    assert rc == 0 and not any(PCT.match(x) for x in cap.err.splitlines()), cap.err
