"""Issue 28 row 10 on a held-out set-up: an A/C trunnion whose A and C axes do not meet (the
A pivot 150 mm below the machine zero, the C axis 12.5 mm off it in Y) with the part 20 mm
above the C axis point. Every program is read back from its text and turned back to the part
frame by forward kinematics:

* TCP posts (Fanuc G43.4, Siemens TRAORI, Heidenhain M128): a stand-in control built from the
  program header ALONE (the work offset it says to set, the rotary axis lines it says the
  kinematic data must hold) places the programmed tip on the machine; the machine's own forward
  kinematics (the TOML) must then land every block on the planned path in the part frame.
  A header that stated a wrong work offset or wrong axis lines fails here.
* The joint program (LinuxCNC), its part origin given by ``--part-origin`` instead of a copied
  machine file, through rs274 and forward kinematics.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from blisk_cam.cli.main import main as cli_main
from blisk_cam.core.geometry.vectors import rotate, rotate_about
from blisk_cam.core.machine.description import forward, load_machine
from blisk_cam.core.post.blocks import NcOptions
from blisk_cam.core.post.export import export_nc, nc_program
from blisk_cam.core.toolpath.paths_io import write_paths_json
from tests.support.nc import (
    RS274,
    demo_path,
    parse_canon,
    parse_fanuc,
    parse_siemens_program,
    parse_words,
    run_rs274,
)

HELD_OUT = """
name = "held-out AC trunnion"
kinematics = "table-table"
spindle = [0, 0, 1]
[[rotary]]
name = "A"
axis = [1, 0, 0]
point = [0, 0, -150]
limits = [-10.0, 110.0]
[[rotary]]
name = "C"
axis = [0, 0, 1]
point = [0, 12.5, -60]
[linear]
X = [-600, 600]
Y = [-600, 600]
Z = [-600, 600]
[part]
origin = [{origin}]
"""
PART = (0.0, 12.5, -40.0)  # 20 mm above the C axis point, on the C axis
TIP_TOL = 1e-3 + 1e-4      # linearization is exact at the poses; 4 printed decimals
AXIS_TOL = 1e-5
_NUM = r"[-+]?\d+(?:\.\d*)?"


@pytest.fixture(scope="module")
def demo():
    return demo_path()


def _machine(tmp_path, origin=PART):
    f = tmp_path / "held-out.toml"
    f.write_text(HELD_OUT.format(origin=", ".join(f"{v:g}" for v in origin)))
    return load_machine(f)


def _xyz(text):
    w = dict(re.findall(r"([XYZ])(" + _NUM + ")", text))
    return np.array([float(w[k]) for k in "XYZ"])


def _control_from_header(text: str, names):
    """(work offset (3,), {name: (axis (3,), point (3,))}) as the program's header states
    them (comment delimiters and case as the dialect writes them)."""
    head = text.upper()
    m = re.search(r"WORK OFFSET: [^\n]*? TO THE PART ORIGIN (X\S+ Y\S+ Z\S+) MM", head)
    assert m, "the header states no work offset to set"
    g54 = _xyz(m.group(1))
    axes = {}
    for n in names:
        a = re.search(n + r" AXIS [(\[](" + _NUM + "), (" + _NUM + "), (" + _NUM
                      + r")[)\]] THROUGH (X\S+ Y\S+ Z\S+)", head)
        assert a, f"the header does not state the {n} axis line the TCP mode needs"
        axes[n] = (np.array([float(a.group(k)) for k in (1, 2, 3)]),
                   _xyz(a.group(4).rstrip(";)")))
    return g54, axes


def _control_machine_tip(g54, axes, names, tip, deg):
    """The stand-in TCP control (A/C table-table, programmed X Y Z in the work frame turning
    with the table): machine tip position = T_A(a) T_C(c) (work offset + programmed point)."""
    (d1, p1), (d2, p2) = axes[names[0]], axes[names[1]]
    q = np.radians(deg)
    m0 = g54 + tip
    m = rotate(m0 - p2, d2, q[:, 1], scale_last=True) + p2
    return rotate(m - p1, d1, q[:, 0], scale_last=True) + p1


def _planned(path, blades):
    """Every planned pose of every blade (blade k turned k·360°/N about the blisk axis)."""
    o, d = path.axis.o, path.axis.d
    prog = path.program
    tips, axs = [], []
    for k in range(blades):
        t = 2 * math.pi * k / blades
        tips.append(rotate_about(prog.tip, d, t, o))
        axs.append(rotate_about(prog.axis, d, t))
    return tips, axs


@pytest.mark.parametrize("post", ["fanuc", "siemens", "heidenhain"])
def test_tcp_programs_land_on_the_path_through_the_offset_set_up(demo, tmp_path, post):
    m = _machine(tmp_path)
    opts = NcOptions(blades=3)
    out = tmp_path / f"p.{post}"
    export_nc(demo, m, post, opts, out)
    text = out.read_text()
    names = m.axis_names
    g54, axes = _control_from_header(text, names)
    # in the controller's terms
    word = {"fanuc": "G54", "siemens": "G54", "heidenhain": "PRESET TABLE"}[post]
    offset_line = next(ln for ln in text.upper().splitlines() if "WORK OFFSET:" in ln)
    assert word in offset_line
    _, blocks = nc_program(demo, m, post, opts)
    full = blocks.expanded()
    pose = full.poses
    if post == "fanuc":
        tip, deg = parse_fanuc(text, names)
    elif post == "heidenhain":
        tip, deg = parse_words(text, names, start=r"\d+ L X")
    else:
        tip, vec = parse_siemens_program(text)
        # TRAORI solves the rotaries from the vector: those of the block stream must turn the
        # spindle onto the programmed vector through the header's axis lines
        deg = np.degrees(full.angles[pose])
        (d1, _), (d2, _) = axes[names[0]], axes[names[1]]
        s = np.broadcast_to(m.spindle, (len(deg), 3))
        back = rotate(rotate(s, d1, -np.radians(deg[:, 0]), scale_last=True), d2,
                      -np.radians(deg[:, 1]), scale_last=True)
        assert np.abs(back - vec / np.linalg.norm(vec, axis=1, keepdims=True)).max() < AXIS_TOL
    assert len(tip) == pose.sum()
    xyz = _control_machine_tip(g54, axes, names, tip, deg)
    ptip, pax = forward(m, xyz, np.radians(deg))  # the machine's own kinematics
    assert np.abs(ptip - full.tip[pose]).max() < TIP_TOL
    assert np.abs(pax - full.axis[pose]).max() < AXIS_TOL
    # ... and every planned pose of every blade is among them, in order
    src, bl = full.source[pose], full.blade[pose]
    for k, (t, a) in enumerate(zip(*_planned(demo, 3), strict=True)):
        sel = (bl == k) & (src >= 0)
        assert np.array_equal(src[sel], np.arange(len(t)))
        assert np.abs(ptip[sel] - t).max() < TIP_TOL
        assert np.abs(pax[sel] - a).max() < AXIS_TOL
    # the header's part origin relative to the C table, as a set-up sheet would give it
    assert "PART ORIGIN FROM THE C AXIS POINT: X0.0000 Y0.0000 Z20.0000" in text.upper()


@pytest.mark.skipif(RS274 is None, reason="rs274 (LinuxCNC, linuxcnc-uspace) is not installed")
def test_joint_program_with_part_origin_flag_on_the_offset_set_up(demo, tmp_path, capsys):
    m0 = _machine(tmp_path, origin=(0.0, 0.0, 0.0))  # the machine file left at its zero
    js = tmp_path / "p.json"
    write_paths_json(demo, js)
    out = tmp_path / "p.ngc"
    argv = ["nc", "--paths", str(js), "--machine", str(m0.source), "--post", "linuxcnc",
            "--out", str(out), "--quiet", "--blade-count", "3",
            "--part-origin", ",".join(f"{v:g}" for v in PART)]
    assert cli_main(argv) == 0
    capsys.readouterr()
    rc, canon = run_rs274(out, tmp_path)
    assert rc == 0, canon[-500:]
    xyz, deg, _ = parse_canon(canon, m0.axis_names)
    m = _machine(tmp_path, origin=PART)
    tip, ax = forward(m, xyz, np.radians(deg))
    planned_t, planned_a = _planned(demo, 3)
    allt, alla = np.vstack(planned_t), np.vstack(planned_a)
    # every planned pose is reached by some block (nearest block within the tolerance)
    from scipy.spatial import cKDTree

    dist, j = cKDTree(tip).query(allt)
    assert dist.max() < TIP_TOL
    assert np.abs(ax[j] - alla).max() < AXIS_TOL
    # the flag is what placed it: with the machine file's zero origin they miss by the offset
    tip0, _ = forward(m0, xyz, np.radians(deg))
    d0, _ = cKDTree(tip0).query(allt)
    assert np.median(d0) > 10.0
