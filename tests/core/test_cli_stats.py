"""The run's own timings are honest: the stage times in the paths JSON add up to the wall
time it reports (which counts from the process start, as the user waits), and every stage
the CLI runs has its figure."""

import hashlib
import json
import os
import sys

import pytest

from blisk_cam.cli import main as cli
from blisk_cam.cli import paths as cli_paths
from blisk_cam.core.part.blisk import make_demo_blisk
from tests.support.mesh_files import write_binary_stl


@pytest.fixture(scope="module")
def blade(tmp_path_factory):
    d = make_demo_blisk(resolution=0.5)
    path = str(write_binary_stl(tmp_path_factory.mktemp("blade") / "blade.stl", d.blade_vertices,
                                d.blade_faces))
    return path, [str(x) for x in d.hub_cone.as_list()], [str(x) for x in d.tip_cone.as_list()]


@pytest.mark.skipif(sys.platform == "darwin", reason="macOS: no /proc, no process times read")
def test_process_age_counts_the_interpreter():
    age = cli_paths.process_age()
    assert age is not None and age > 0.0  # this pytest process has run for a while


def test_stage_times_add_up_to_the_wall_time(blade, tmp_path, capsys):
    stl, cone1, cone2 = blade
    out = tmp_path / "p.json"
    rc = cli.main(["paths", "--mesh", stl, "--cone1", *cone1, "--cone2", *cone2,
                   "--tool-diameter", "12", "--cusp", "0.5", "--chord", "0.2", "--lead", "10",
                   "--verify", "--out", str(out)])
    printed = capsys.readouterr().out
    assert rc == 0
    st = json.loads(out.read_text())["stats"]
    stages = ("load", "weld", "plan", "verify")
    if cli_paths.process_age() is not None:  # Linux, Windows
        stages = ("startup", *stages)
    assert all(f"seconds_{k}" in st for k in stages)
    total = sum(st[f"seconds_{k}"] for k in ("startup", "load", "weld", "fit", "plan",
                                               "collision", "verify") if f"seconds_{k}" in st)
    # the JSON is written after its figures: what is left out is argument checks and the
    # verdict, which must stay small against the wall time
    assert total <= st["seconds_wall"] + 1e-6
    assert total >= 0.95 * st["seconds_wall"] - 0.05
    # the mesh planned on, for nc's constant-error budget (tests/core/test_interpolation_part)
    assert st["mesh_file"] == os.path.abspath(stl) and st["mesh_units"] == "mm"
    assert st["mesh_sha256"] == hashlib.sha256(open(stl, "rb").read()).hexdigest()
    line = next(x for x in printed.splitlines() if x.startswith("time: "))
    assert "startup" in line and "write" in line and "wall" in line
