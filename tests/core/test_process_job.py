"""The job and ``python -m blisk_cam process`` (issue 24 item 3): two blade-finishing operations
with two tools on the demo blisk, end to end and coarse (cheap), checked from the outputs only:
LinuxCNC's interpreter runs the program, one tool change per tool, the spindle speeds follow
n = 1000·vc/(π·D_eff) at the effective diameter measured on the written paths, every
operation's poses come back through forward kinematics of the interpreted program, and the
second operation started from the stock the first one left. Then the bad inputs."""

from __future__ import annotations

import json
import math
import re
import subprocess

import numpy as np
import pytest

from blisk_cam.cli.main import main
from blisk_cam.cli.process import _replace_folder
from blisk_cam.core.errors import BliskCamError
from blisk_cam.core.geometry.vectors import rotate_about
from blisk_cam.core.machine.description import forward, load_machine
from blisk_cam.core.process.cutting_data import MATERIALS, cutting_data, effective_diameter
from blisk_cam.core.process.job import load_job, stock_digest
from blisk_cam.core.stock.dexels import RadialDexels
from blisk_cam.core.tool.cutter import Cutter
from blisk_cam.core.toolpath.paths_io import read_paths_json
from blisk_cam.core.toolpath.types import MOVE_CUT
from tests.support.jobs import demo_job_head
from tests.support.nc import RS274, parse_canon

TIP_TOL = 1e-3 + 1e-4  # mm: 4 printed decimals
AXIS_TOL = 1e-4  # rad

CONES = """cone1 = [170.0, -25.0, 185.0, 35.0]
cone2 = [215.0, -25.0, 225.0, 35.0]"""

JOB = f"""{demo_job_head(resolution=2.0)}
[[tool]]
number = 3
type = "ball"
diameter = 16
flutes = 2
stick_out = 70

[[tool]]
number = 7
type = "ball"
diameter = 10
flutes = 4
stick_out = 60
coolant = "off"

[[operation]]
name = "semi-finish"
kind = "blade_finish"
tool = 3
{CONES}
cusp = 1.0
chord = 0.5
axis_mode = "radial"
radial_tilt = 75
depth = 0.4

[[operation]]
name = "finish"
kind = "blade_finish"
tool = 7
{CONES}
cusp = 1.0
chord = 0.5
axis_mode = "radial"
radial_tilt = 75
lead = 5
vc = 90
fz = 0.04
"""


@pytest.fixture(scope="module")
def processed(tmp_path_factory):
    root = tmp_path_factory.mktemp("job")
    job = root / "blisk.toml"
    job.write_text(JOB)
    out = root / "out"
    rc = main(["process", str(job), "--out", str(out), "--quiet"])
    return rc, job, out


def _subsequence(fk_tip, fk_axis, tips, axes) -> bool:
    """Every (tip, axis) of ``tips``/``axes`` is found, in order, among the interpreted
    motions (linearization may insert blocks in between)."""
    j = 0
    for t, a in zip(tips, axes, strict=True):
        while True:
            if j >= len(fk_tip):
                return False
            if (np.linalg.norm(fk_tip[j] - t) < TIP_TOL
                    and math.acos(min(1.0, float(fk_axis[j] @ a))) < AXIS_TOL):
                j += 1
                break
            j += 1
    return True


def _tilt(path) -> float:
    """Median angle (rad) between tool axis and surface normal over the cut poses, from the
    paths JSON."""
    ang = []
    for c in path.curves:
        cut = np.asarray(c.move) == MOVE_CUT
        ang.append(np.arccos(np.clip(np.einsum("ij,ij->i", c.axis[cut], c.normal[cut]), -1, 1)))
    return float(np.median(np.concatenate(ang)))


def _d_eff_ball(D: float, ap: float, beta: float) -> float:
    """Tool makers' effective diameter of a ball nose (Sandvik Coromant)."""
    ang = beta + math.acos((D - 2 * ap) / D)
    return D if ang >= math.pi / 2 else D * math.sin(ang)


def test_outputs_program_and_stock_chain(processed, tmp_path):
    rc, job, out = processed
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    ops = summary["operations"]
    final = summary["final_verdict"]["status"]
    assert rc == (5 if not all(o["passed"] for o in ops) or final == "failed" else
                  6 if final == "incomplete" else 0)
    assert [o["tool"] for o in ops] == [3, 7]
    names = sorted(p.name for p in out.iterdir())
    # no row of either program moves the body or a rapid through the stock (the radial
    # rapid down to the first pass once crashed 14 mm into the semi-finishing stock)
    for stem in ("01-semi-finish", "02-finish"):
        sim = json.loads((out / f"{stem}.simulation.json").read_text(encoding="utf-8"))
        assert sim["crashes"] == [], (stem, sim["crashes"])
        assert sim["volume_removed_mm3"]["by_move"]["rapid"] == 0.0, stem
    for stem in ("01-semi-finish", "02-finish"):
        for ext in ("paths.json", "stock.npz", "deviation.ply", "simulation.json"):
            assert f"{stem}.{ext}" in names
    assert {"job.linuxcnc.ngc", "job.linuxcnc.tbl", "setup_sheet.md", "summary.json",
            "job.toml"} <= set(names)
    assert not [p for p in out.parent.iterdir() if p.name.startswith(".blisk_")]

    text = (out / "job.linuxcnc.ngc").read_text()
    # one tool change per tool: T3 then T7, each once
    changes = re.findall(r"^T(\d+) M6$", text, re.M)
    assert changes == ["3", "7"]
    # spindle speeds: n = 1000 vc / (π D_eff), D_eff at the measured axis angle and the depth
    speeds = [float(s) for s in re.findall(r"^S(\d+(?:\.\d*)?) M3$", text, re.M)]
    paths = [read_paths_json(out / f) for f in ("01-semi-finish.paths.json",
                                                "02-finish.paths.json")]
    vcs = [MATERIALS["Ti-6Al-4V"]["ball"].vc_mid, 90.0]
    for s, p, vc, ap, D in zip(speeds, paths, vcs, (0.4, 0.2), (16.0, 10.0), strict=True):
        d_eff = _d_eff_ball(D, ap, _tilt(p))
        assert s == round(1000.0 * vc / (math.pi * d_eff))
    assert ops[1]["cutting"]["feed_mm_min"] == pytest.approx(speeds[1] * 4 * 0.04)
    # coolant per tool: T3 flood (M8), T7 off (M9) right after their spindle start
    assert re.findall(r"^S\d+ M3\n(M[89])$", text, re.M) == ["M8", "M9"]

    # the stock chain: operation 2 started from the state operation 1 saved
    saved = RadialDexels.load(out / "01-semi-finish.stock.npz")
    assert stock_digest(saved) == ops[0]["stock_out"]["digest"] == ops[1]["stock_in"]["digest"]
    assert saved.volume() == pytest.approx(ops[1]["stock_in"]["volume_mm3"])
    assert ops[1]["stock_in"]["volume_mm3"] < ops[0]["stock_in"]["volume_mm3"]

    # the collision check ran (the default) with each tool's holder from its stick-out
    assert "COLLISIONS NOT CHECKED" not in text
    for p in paths:
        assert p.collision is not None
    sheet = (out / "setup_sheet.md").read_text(encoding="utf-8")
    assert "| T3 | Ø16 ball |" in sheet and "| T7 | Ø10 ball |" in sheet
    assert sheet.count("| blade_finish |") == 2

    if RS274 is None:
        pytest.skip("rs274 (LinuxCNC, linuxcnc-uspace) is not installed")
    canon_file = tmp_path / "job.canon"
    cp = subprocess.run([RS274, "-t", str(out / "job.linuxcnc.tbl"), "-g",
                         str(out / "job.linuxcnc.ngc"), str(canon_file)],
                        stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=120)
    canon = canon_file.read_text()
    assert cp.returncode == 0, cp.stdout[-300:] + canon[-300:]
    # the interpreter selects T3 then T7 and changes tools twice
    assert [int(t) for t in re.findall(r"SELECT_TOOL\((\d+)\)", canon)] == [3, 7]
    assert canon.count("CHANGE_TOOL(") == 2
    machine = load_machine("ac-trunnion")
    xyz, rot, _ = parse_canon(canon, machine.axis_names)
    fk_tip, fk_axis = forward(machine, xyz, np.radians(rot))
    blades = summary["blades"]
    exp_tip, exp_axis = [], []
    for p in paths:  # every operation, every blade (turned about the blisk axis), in order
        for k in range(blades):
            turn = 2 * math.pi * k / blades
            exp_tip.append(rotate_about(p.program.tip, p.axis.d, turn, p.axis.o))
            exp_axis.append(rotate_about(p.program.axis, p.axis.d, turn))
    assert _subsequence(fk_tip, fk_axis, np.concatenate(exp_tip), np.concatenate(exp_axis))


def test_effective_diameter_and_cutting_data():
    ball = Cutter.ball(6.0)
    beta = math.radians(10.0)
    assert effective_diameter(ball, 0.2, beta) == pytest.approx(_d_eff_ball(12.0, 0.2, beta))
    assert effective_diameter(ball, 0.2, 0.0) == pytest.approx(2 * math.sqrt(0.2 * 11.8))
    bull = Cutter.bull(6.0, 2.0)  # Ø12 R2, axis on the normal: D − 2r + 2√(ap(2r − ap))
    assert effective_diameter(bull, 0.5, 0.0) == pytest.approx(12 - 4 + 2 * math.sqrt(0.5 * 3.5))
    assert effective_diameter(Cutter.flat(6.0), 0.5, 0.3) == 12.0
    cd = cutting_data(ball, 2, "ti64", 0.2, beta)
    rng = MATERIALS["Ti-6Al-4V"]["ball"]
    assert rng.vc[0] <= cd.vc <= rng.vc[1] and rng.fz[0] <= cd.fz <= rng.fz[1]
    assert cd.spindle == round(1000 * cd.vc / (math.pi * cd.d_eff))
    assert cd.feed == pytest.approx(cd.spindle * 2 * cd.fz)
    capped = cutting_data(ball, 2, "Al 7075", 0.05, 0.0, max_spindle=18000)
    assert capped.spindle == 18000 and "above the spindle" in capped.limited
    with pytest.raises(BliskCamError, match="unknown material 'unobtainium'"):
        cutting_data(ball, 2, "unobtainium", 0.2, beta)


def test_a_planned_kind_missing_from_the_build_is_refused_not_skipped(tmp_path, monkeypatch):
    from blisk_cam.core.process import operation_kinds

    monkeypatch.delitem(operation_kinds.OPERATION_KINDS, "rough")
    text = JOB.replace('kind = "blade_finish"\ntool = 7', 'kind = "rough"\ntool = 7', 1)
    with pytest.raises(BliskCamError, match=r"operation 2 \('finish'\): operation kind 'rough' "
                                            r"is not available in this build"):
        load_job(_job(tmp_path, text))


def _job(tmp_path, text: str):
    f = tmp_path / "bad.toml"
    f.write_text(text)
    return f


@pytest.mark.parametrize("old, new, words", [
    ("cusp = 1.0\nchord = 0.5\naxis_mode = \"radial\"\nradial_tilt = 75\nlead = 5",
     "cusp_height = 1.0\nchord = 0.5\naxis_mode = \"radial\"\nradial_tilt = 75\nlead = 5",
     r"bad.toml operation 2 \('finish'\): unknown key 'cusp_height'; did you mean 'cusp'"),
    ('kind = "blade_finish"\ntool = 7', 'kind = "blade_finsh"\ntool = 7',
     r"operation 2 \('finish'\): unknown operation kind 'blade_finsh'; did you mean "
     r"'blade_finish'"),
    ("number = 7", "number = 3", r"bad.toml tool 2 key 'number': tool number T3 is used twice"),
    ('kind = "blade_finish"\ntool = 7', 'kind = "blade_finish"\ntool = 9',
     r"operation 2 \('finish'\) key 'tool': tool T9 is not in the tool table"),
    ('material = "Ti-6Al-4V"', 'material = "Ti-6Al-4W"',
     r"\[part\] key 'material': unknown material 'Ti-6Al-4W'; did you mean 'Ti-6Al-4V'"),
    ('posts = ["linuxcnc"]', 'posts = ["haas"]',
     r"\[machine\] key 'posts': unknown post 'haas'; known: linuxcnc"),
    ('name = "ac-trunnion"', 'name = "bc-head-table"',
     r"\[machine\] key 'posts': post linuxcnc writes joint programs for table-table machines"),
    ("[stock]", "[stok]", r"bad.toml: unknown key 'stok'; did you mean 'stock'"),
    ("flutes = 4", "flutes = 4\nflute = 30",
     r"bad.toml tool 2 \(T7\): unknown key 'flute'; did you mean 'flutes'"),
])
def test_bad_job_errors_name_file_operation_key(tmp_path, old, new, words):
    assert old in JOB
    with pytest.raises(BliskCamError, match=words):
        load_job(_job(tmp_path, JOB.replace(old, new, 1)))


def test_cli_bad_input_leaves_nothing(tmp_path, capsys):
    # a bad option value found when the operations are prepared (inside the run): exit 1,
    # one line naming the operation and the key, no output folder, no temporary folder
    bad = _job(tmp_path, JOB.replace("cusp = 1.0", "cusp = -1.0", 1))
    out = tmp_path / "out"
    assert main(["process", str(bad), "--out", str(out), "--quiet"]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "operation 1 ('semi-finish') key 'cusp'" in err
    assert not out.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".blisk_")]
    # a tool that does not fit the gap between the blades (measured on the part: > 31 mm
    # between the demo's blades above the hub cone)
    wide = _job(tmp_path, JOB.replace("diameter = 10", "diameter = 50", 1))
    assert main(["process", str(wide), "--out", str(out), "--quiet"]) == 1
    err = capsys.readouterr().err
    assert "operation 2 ('finish') key 'tool': tool T7 (Ø50) does not fit the gap" in err
    assert not out.exists()
    # a stock that does not hold the part
    (tmp_path / "small.csv").write_text("100, -30\n120, -30\n120, 40\n100, 40\n")
    small = _job(tmp_path, JOB.replace('blank = "allowance:0.6"', 'blank = "small.csv"'))
    assert main(["process", str(small), "--out", str(out), "--quiet"]) == 1
    assert "does not hold the part" in capsys.readouterr().err
    assert not out.exists()
    # a non-empty output folder is the user's: refused without --force, untouched
    out.mkdir()
    (out / "mine.txt").write_text("keep")
    assert main(["process", str(bad), "--out", str(out)]) == 2
    assert "not empty" in capsys.readouterr().err
    assert (out / "mine.txt").read_text() == "keep"


def test_replace_folder(tmp_path):
    out, new = tmp_path / "out", tmp_path / "new"
    out.mkdir()
    (out / "old.txt").write_text("old")
    new.mkdir()
    (new / "a.txt").write_text("a")
    _replace_folder(new, out)
    assert sorted(p.name for p in out.iterdir()) == ["a.txt"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_ctrl_c_mid_run_leaves_nothing(tmp_path, monkeypatch, capsys):
    # Ctrl-C while operation 1 runs on the stock: exit 130, no output folder, no temporary
    # folder (the first operation's files were already in the temporary folder)
    import blisk_cam.core.process.job as job_module

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt
        yield  # a generator, like the real one

    monkeypatch.setattr(job_module, "iter_simulate", interrupted)
    job = _job(tmp_path, JOB)
    out = tmp_path / "out"
    assert main(["process", str(job), "--out", str(out), "--quiet"]) == 130
    assert "interrupted" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.toml"]
