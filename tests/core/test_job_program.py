"""One program for a job's operations (:mod:`blisk_cam.core.post.job_program`), every post:
sections T1, T1, T2 (two tool changes: the second section keeps its tool), each read back
with the dialect's parser, through forward kinematics where the program gives joints, and
compared with the sections' solved poses in order, every blade."""

from __future__ import annotations

import math
import re
import subprocess

import numpy as np
import pytest

from blisk_cam.core.errors import BliskCamError
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.machine.description import forward, load_machine
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.part.cones import Cone
from blisk_cam.core.post.blocks import NcOptions
from blisk_cam.core.post.job_program import JOB_POSTS, JobSection, check_job_post, job_program
from blisk_cam.core.post.linuxcnc import tool_table
from blisk_cam.core.process.blade_finish import PathRequest, plan_paths
from tests.support.nc import (
    RS274,
    parse_apt,
    parse_canon,
    parse_fanuc,
    parse_siemens,
    parse_words,
)

TIP_TOL = 1e-3 + 1e-4
AXIS_TOL = 1e-5
TOOLS = (1, 1, 2)
SPINDLE = (5000.0, 6000.0, 7000.0)


def _path():
    """The demo blade at the process test's coarse settings (~300 poses, cheap)."""
    d = make_demo_blisk(resolution=0.3)
    req = PathRequest(axis=d.axis, cone1=Cone(170.0, -25.0, 185.0, 35.0), cone2=d.tip_cone,
                      tool_diameter=12.0, cusp=1.0, chord=0.5, axis_mode="radial",
                      radial_tilt=math.radians(75.0))
    return plan_paths(TriMesh.from_arrays(d.blade_vertices, d.blade_faces), req).path


@pytest.fixture(scope="module")
def sections():
    path = _path()
    return [JobSection(f"op {k + 1}", path,
                       NcOptions(tool_number=t, spindle=s, feed=800.0 + 100 * k, blades=2,
                                 coolant=k != 1))
            for k, (t, s) in enumerate(zip(TOOLS, SPINDLE, strict=True))]


def _siemens_job(text: str):
    """Siemens motion blocks in execution order with every ``BLADE_LOOP<k>:`` section
    repeated under its ``ROT Z=_BLADE*pitch``."""
    lines = text.splitlines()
    xs, axs = [], []
    i = 0
    while i < len(lines):
        m = re.match(r"BLADE_LOOP\d+:$", lines[i])
        if not m:
            x, a = parse_siemens(lines[i])
            if len(x):
                xs.append(x)
                axs.append(a)
            i += 1
            continue
        end = next(j for j in range(i, len(lines)) if lines[j].startswith("IF _BLADE<"))
        n = int(re.search(r"<(\d+)", lines[end]).group(1))
        pitch = float(re.search(r"ROT Z=_BLADE\*([-\d.]+)", lines[i + 1]).group(1))
        x0, a0 = parse_siemens("\n".join(lines[i:end]))
        for k in range(n):
            t = math.radians(k * pitch)
            R = np.array([[math.cos(t), -math.sin(t), 0], [math.sin(t), math.cos(t), 0],
                          [0, 0, 1]])
            xs.append(x0 @ R.T)
            axs.append(a0 @ R.T)
        i = end + 1
    return np.vstack(xs), np.vstack(axs)


def _angle(a, b):
    a = a / np.linalg.norm(a, axis=1, keepdims=True)
    b = b / np.linalg.norm(b, axis=1, keepdims=True)
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.einsum("ij,ij->i", a, b))


@pytest.mark.parametrize("post", JOB_POSTS)
def test_job_program_every_post(sections, post, tmp_path):
    machine = load_machine("ac-trunnion")
    text, solved = job_program(sections, machine, post, header=["a test job"])
    assert text.isascii()
    full = [s.blocks.expanded() for s in solved]
    want_tip = np.concatenate([f.tip[f.poses] for f in full])
    want_axis = np.concatenate([f.axis[f.poses] for f in full])
    names = machine.axis_names
    if post == "linuxcnc":
        if RS274 is None:
            pytest.skip("rs274 (LinuxCNC, linuxcnc-uspace) is not installed")
        (tmp_path / "t.tbl").write_text(tool_table([(1, 12.0, "D12 ball"),
                                                    (2, 12.0, "D12 ball")]))
        (tmp_path / "p.ngc").write_text(text)
        cp = subprocess.run([RS274, "-t", str(tmp_path / "t.tbl"), "-g",
                             str(tmp_path / "p.ngc"), str(tmp_path / "p.canon")],
                            stdin=subprocess.DEVNULL, capture_output=True, text=True,
                            timeout=120)
        canon = (tmp_path / "p.canon").read_text()
        assert cp.returncode == 0, canon[-400:]
        assert [int(t) for t in re.findall(r"SELECT_TOOL\((\d+)\)", canon)] == [1, 2]
        speeds = [float(s) for s in re.findall(r"SET_SPINDLE_SPEED\(\d*,?\s*([\d.]+)\)",
                                               canon)]
        assert [s for s in speeds if s > 0][:3] == list(SPINDLE)
        xyz, rot, kinds = parse_canon(canon, names)
        tip, ax = forward(machine, xyz, np.radians(rot))
        # drop the safe moves: the start, two per SAFE block (retract, index), one per end
        keep = []
        for f in full:
            safe = ~f.poses
            keep.append(np.repeat(~safe, np.where(safe, 2, 1)))
            keep.append([False])
        keep = np.concatenate([[False], *keep])
        tip, ax = tip[keep], ax[keep]
        changes = re.findall(r"^T(\d+) M6$", text, re.M)
    elif post == "fanuc":
        xyz, rot = parse_fanuc(text, names)
        tip = xyz
        _, ax = forward(machine, np.zeros_like(xyz), np.radians(rot))
        changes = re.findall(r"^T(\d+) M06$", text, re.M)
    elif post == "heidenhain":
        xyz, rot = parse_words(text, names, start=r"\d+ L X")
        tip = xyz
        _, ax = forward(machine, np.zeros_like(xyz), np.radians(rot))
        changes = re.findall(r"^\d+ TOOL CALL (\d+) Z", text, re.M)
        assert len(re.findall(r"^\d+ TOOL CALL Z S6000$", text, re.M)) == 1
    elif post == "siemens":
        tip, ax = _siemens_job(text)
        changes = re.findall(r"^T(\d+) D1\nM6$", text, re.M)
    else:
        tip, ax = parse_apt(text)
        changes = re.findall(r"^LOADTL/(\d+)$", text, re.M)
    assert changes == ["1", "2"]  # one change per tool: section 2 keeps T1
    assert len(tip) == len(want_tip)
    assert np.abs(tip - want_tip).max() < TIP_TOL
    assert _angle(ax, want_axis).max() < AXIS_TOL
    # every section: each program row of its path once per blade, in order
    for s, f in zip(solved, full, strict=True):
        for b in range(f.blades):
            sel = f.poses & (f.blade == b) & (f.source >= 0)
            assert np.array_equal(f.source[sel], np.arange(len(s.path.program)))


def test_unknown_post_and_empty_job(sections):
    with pytest.raises(BliskCamError, match="unknown post 'haas'"):
        check_job_post("haas")
    with pytest.raises(BliskCamError, match="no operation"):
        job_program([], "ac-trunnion", "linuxcnc")
