"""``python -m blisk_cam robot``: a program written for the 45° head (read back onto the path),
the singular ranges listed and nothing written for the inline head, bad input in one line."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from blisk_cam.cli.main import main
from blisk_cam.core.robot import kinematics as K
from blisk_cam.core.robot.description import ROBOTS_DIR, load_robot
from blisk_cam.core.robot.readers import decode_joints, read_program
from blisk_cam.core.toolpath.paths_io import write_paths_json
from blisk_cam.core.toolpath.types import Program
from tests.support.nc import rotor37_path


@pytest.fixture(scope="module")
def small_paths(tmp_path_factory):
    """Rotor 37's linked program cut to its first 260 poses, as a paths JSON."""
    path = rotor37_path()
    p = path.program
    cut = {f.name: (None if getattr(p, f.name) is None else getattr(p, f.name)[:260])
           for f in dataclasses.fields(Program)}
    small = dataclasses.replace(path, program=Program(**cut))
    out = tmp_path_factory.mktemp("robot") / "r37.json"
    write_paths_json(small, out)
    return out, small


def test_robot_writes_a_program_that_reads_back_onto_the_path(small_paths, tmp_path, capsys):
    paths, small = small_paths
    out = tmp_path / "krl"
    rc = main(["robot", "--paths", str(paths), "--robot", "kr120-r2700-angled", "--post", "krl",
               "--out", str(out), "--lines", "100", "--force", "25", "--samples", "24"])
    cap = capsys.readouterr()
    assert rc == 0, cap.err
    assert "min wrist-singularity margin" in cap.out
    assert "free angle: stroke" in cap.err  # progress on stderr
    files = {f.name: f.read_text() for f in out.iterdir()}
    assert "blisk_main.src" in files and len(files) == 4  # main + 3 parts of ≤ 100
    assert "contact force setpoint: 25 N" in files["blisk_main.src"]
    robot = load_robot("kr120-r2700-angled")
    read = read_program("krl", files, "blisk_main.src")
    q = decode_joints(robot, "krl", read)
    F = robot.pose_of(K.flange_pose(robot, q))
    assert np.abs(F[:, :3, 3] - small.program.tip).max() < 1e-3 + 5e-5
    # run again into the same directory: our own files are replaced
    assert main(["robot", "--paths", str(paths), "--robot", "kr120-r2700-angled", "--post",
                 "krl", "--out", str(out), "--lines", "100", "--samples", "24"]) == 0


def test_inline_head_lists_singular_ranges_and_writes_nothing(small_paths, tmp_path, capsys):
    paths, _ = small_paths
    out = tmp_path / "none"
    rc = main(["robot", "--paths", str(paths), "--robot", "kr120-r2700", "--post", "rapid",
               "--out", str(out), "--samples", "24"])
    err = capsys.readouterr().err
    assert rc == 1
    assert "cannot run stroke" in err and "singularity" in err
    assert err.strip().splitlines()[-1].startswith("blisk_cam: error:")
    assert not out.exists()


def test_bad_robot_and_foreign_files_are_one_line_errors(small_paths, tmp_path, capsys):
    paths, _ = small_paths
    bad = tmp_path / "bad.toml"
    bad.write_text((ROBOTS_DIR / "kr120-r2700.toml").read_text().replace("c3 = 1200.0\n", ""))
    rc = main(["robot", "--paths", str(paths), "--robot", str(bad), "--post", "krl",
               "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 1 and len(err) == 1 and "missing 'c3'" in err[0]
    out = tmp_path / "mine"
    out.mkdir()
    (out / "blisk_main.src").write_text("my own program\n")
    rc = main(["robot", "--paths", str(paths), "--robot", "kr120-r2700-angled", "--post", "krl",
               "--out", str(out), "--samples", "12"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 1 and "was not written by Blisk CAM" in err[-1]
    assert (out / "blisk_main.src").read_text() == "my own program\n"


def test_polishing_process_values_and_removal_per_pose(small_paths, tmp_path, capsys):
    paths, small = small_paths
    csv = tmp_path / "removal.csv"
    rc = main(["robot", "--paths", str(paths), "--robot", "kr120-r2700-angled", "--post",
               "pdl2", "--out", str(tmp_path / "pdl"), "--samples", "12", "--force", "20",
               "--head-rpm", "3000", "--head-diameter", "20", "--contact-width", "5",
               "--preston", "4e-6", "--removal", str(csv)])
    cap = capsys.readouterr()
    assert rc == 0, cap.err
    assert "Preston removal 5.03 µm per pass" in cap.out
    rows = np.loadtxt(csv, delimiter=",", skiprows=1)
    assert len(rows) == len(small.program)
    contact = np.isin(small.program.move, (0, 1))  # cut, link
    assert np.all(rows[contact, 4] > 5.0) and np.all(rows[~contact, 4] == 0.0)
    assert "Preston removal" in (tmp_path / "pdl" / "blisk_main.pdl").read_text()
    rc = main(["robot", "--paths", str(paths), "--robot", "kr120-r2700-angled", "--post",
               "pdl2", "--out", str(tmp_path / "p2"), "--head-rpm", "3000"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "--force, --head-diameter" in err[0]


def test_robot_goes_through_the_collision_gate(small_paths, tmp_path, capsys):
    """Issue 28's one gate covers the robot posts too: unresolved collisions are refused
    (nothing written) unless allowed, and then the program header says how many and where."""
    _, small = small_paths
    path = dataclasses.replace(small, program=dataclasses.replace(small.program))
    m = len(path.program)
    status = np.zeros(m, np.int8)
    status[[30, 31, 32]] = 2
    path.program.collision_status = status
    path.program.clearance = np.where(status == 2, -0.5, 5.0)
    path.program.rotation_deg = np.zeros(m)
    path.collision = {"mode": "check", "checked_poses": m, "colliding_before": 3,
                      "corrected": 0, "unresolved": 3, "min_clearance": -0.5}
    bad = tmp_path / "colliding.json"
    write_paths_json(path, bad)
    c, i = int(path.program.curve[30]), int(path.program.index[30])
    args = ["robot", "--paths", str(bad), "--robot", "kr120-r2700-angled", "--post", "krl",
            "--samples", "24"]
    refused = tmp_path / "refused"
    assert main(args + ["--out", str(refused)]) == 1
    err = capsys.readouterr().err
    assert "3" in err and f"pass {c} poses {i}-{i + 2}" in err and "--allow-collisions" in err
    assert not refused.exists()
    allowed = tmp_path / "allowed"
    assert main(args + ["--out", str(allowed), "--allow-collisions"]) == 0
    capsys.readouterr()
    header = (allowed / "blisk_main.src").read_text()
    assert f"pass {c} poses {i}-{i + 2}" in header
    # a path never checked: written, with the header line and a warning
    unchecked = tmp_path / "unchecked"
    assert small.collision is None
    assert main(["robot", "--paths", str(small_paths[0]), "--robot", "kr120-r2700-angled",
                 "--post", "krl", "--samples", "24", "--out", str(unchecked)]) == 0
    assert "warning" in capsys.readouterr().err
    assert "COLLISIONS NOT CHECKED" in (unchecked / "blisk_main.src").read_text()
