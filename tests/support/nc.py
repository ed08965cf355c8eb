"""NC programs read back: one parser per dialect (the FK round trip of the posts reads the
programs back), LinuxCNC's interpreter (rs274) run on a program, and the two paths the
machine and post tests use (the demo blade and Rotor 37, small)."""

from __future__ import annotations

import math
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np

from blisk_cam.core.geometry.axis import Axis
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.part.cones import Cone
from blisk_cam.core.process.blade_finish import PathRequest, plan_paths
from tests.support.blades import nasa_blade


# --- the paths posted by the tests ------------------------------------------------------------
def demo_path():
    """Demo blade above the hub fillet (the fillet turns the axis beyond A 110°), axis near
    radial (radial tilt 75°), coarse cusp/chord: ~600 poses."""
    d = make_demo_blisk(resolution=0.5, fillet=True, fillet_radius=10.0)
    mesh = TriMesh.from_arrays(d.blade_vertices, d.blade_faces)
    req = PathRequest(axis=d.axis, cone1=Cone(170.0, -25.0, 185.0, 35.0), cone2=d.tip_cone,
                      tool_radius=6.0, cusp=0.5, chord=0.1, axis_mode="radial",
                      radial_tilt=math.radians(75.0))
    return plan_paths(mesh, req).path


def rotor37_path():
    """Rotor 37 with its fitted cones, 3 mm ball, coarse."""
    V, F, c1, c2 = nasa_blade("rotor37")
    req = PathRequest(axis=Axis(), cone1=c1, cone2=c2, tool_radius=3.0, cusp=0.2, chord=0.1,
                      axis_mode="radial", radial_tilt=math.radians(75.0))
    return plan_paths(TriMesh.from_arrays(V, F), req).path


# --- dialect parsers: list of (xyz (3,), angles_deg (2,) or axis (3,)) per pose block --------
RS274 = shutil.which("rs274")
_NUM = r"[-+]?\d+(?:\.\d*)?"


def run_rs274(filename, workdir) -> tuple[int, str]:
    """(exit status, canonical output text) of LinuxCNC's interpreter on ``filename``."""
    out = Path(workdir) / (Path(filename).name + ".canon")
    cp = subprocess.run([RS274, "-g", str(filename), str(out)], stdin=subprocess.DEVNULL,
                        capture_output=True, text=True, timeout=120)
    return cp.returncode, out.read_text() if out.exists() else ""


def parse_canon(text: str, names) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """Motions of rs274 canonical output: xyz (k, 3), rotaries (k, 2) degrees, kind names."""
    idx = {"A": 3, "B": 4, "C": 5}
    xyz, rot, kinds = [], [], []
    for line in text.splitlines():
        m = re.search(r"(STRAIGHT_TRAVERSE|STRAIGHT_FEED)\(([^)]*)\)", line)
        if not m:
            continue
        v = [float(x) for x in m.group(2).split(",")]
        xyz.append(v[:3])
        rot.append([v[idx[names[0]]], v[idx[names[1]]]])
        kinds.append(m.group(1))
    return np.array(xyz), np.array(rot), kinds


def parse_words(text: str, names, *, start: str, sep: str = "") -> tuple[np.ndarray, np.ndarray]:
    """Fanuc / Heidenhain motion lines (starting with a pattern in ``start``) → xyz (k, 3),
    rotaries (k, 2) degrees."""
    xyz, rot = [], []
    for line in text.splitlines():
        if not re.match(start, line):
            continue
        w = dict(re.findall(r"\b([XYZABC])" + sep + "(" + _NUM + ")", line))
        if not all(k in w for k in "XYZ"):
            continue
        xyz.append([float(w[k]) for k in "XYZ"])
        rot.append([float(w[names[0]]), float(w[names[1]])])
    return np.array(xyz), np.array(rot)


def parse_siemens(text: str) -> tuple[np.ndarray, np.ndarray]:
    xyz, ax = [], []
    for line in text.splitlines():
        if not re.match(r"G[01] X=", line):
            continue
        w = dict(re.findall(r"\b(X|Y|Z|A3|B3|C3)=(" + _NUM + ")", line))
        xyz.append([float(w[k]) for k in ("X", "Y", "Z")])
        ax.append([float(w[k]) for k in ("A3", "B3", "C3")])
    return np.array(xyz), np.array(ax)


def parse_apt(text: str) -> tuple[np.ndarray, np.ndarray]:
    v = np.array([[float(x) for x in line[5:].split(",")]
                  for line in text.splitlines() if line.startswith("GOTO/")])
    return v[:, :3], v[:, 3:]


def _eval_word(v: str, env: dict) -> float:
    if not v.startswith("["):
        return float(v)
    expr = re.sub(r"#(\d+)", lambda m: repr(env[int(m.group(1))]), v)
    expr = expr.replace("[", "(").replace("]", ")")
    return float(eval(expr, {"__builtins__": {}}))  # noqa: S307 - test-only, own program text


def parse_fanuc(text: str, names) -> tuple[np.ndarray, np.ndarray]:
    """Fanuc motion blocks in execution order: main program, then every ``M98 P<sub>`` call
    expanded with the macro variables set before it (#3 = COS[#1], #4 = SIN[#1] in the sub).
    Returns xyz (k, 3), rotaries (k, 2) degrees."""
    progs, cur = {}, None
    for line in text.splitlines():
        m = re.match(r"O(\d+)", line)
        if m:
            cur = int(m.group(1))
            progs[cur] = []
            continue
        if cur is not None:
            progs[cur].append(line)
    main = min(progs)
    word = r"\b([XYZABC])(\[[^\]]*\]|" + _NUM + ")"
    xyz, rot = [], []

    def run(lines, env):
        for line in lines:
            m = re.match(r"#(\d+)=(" + _NUM + r"|COS\[#1\]|SIN\[#1\])", line)
            if m:
                v = m.group(2)
                env[int(m.group(1))] = (math.cos(math.radians(env[1])) if v.startswith("COS")
                                        else math.sin(math.radians(env[1])) if v.startswith("SIN")
                                        else float(v))
                continue
            m = re.match(r"M98 P(\d+)", line)
            if m:
                run(progs[int(m.group(1))], dict(env))
                continue
            if not re.match(r"G0[01] X", line):
                continue
            w = {k: _eval_word(v, env) for k, v in re.findall(word, line)}
            xyz.append([w[k] for k in "XYZ"])
            rot.append([w[names[0]], w[names[1]]])

    run(progs[main], {})
    return np.array(xyz), np.array(rot)


def parse_siemens_program(text: str) -> tuple[np.ndarray, np.ndarray]:
    """Siemens motion blocks in execution order: a ``BLADE_LOOP:`` section repeated while
    ``IF _BLADE<N``, each pass under ``ROT Z=_BLADE*pitch`` (xyz and A3/B3/C3 turned)."""
    lines = text.splitlines()
    if "BLADE_LOOP:" not in lines:
        return parse_siemens(text)
    a = lines.index("BLADE_LOOP:")
    b = next(i for i, t in enumerate(lines) if t.startswith("IF _BLADE<"))
    n = int(re.search(r"<(\d+)", lines[b]).group(1))
    pitch = float(re.search(r"ROT Z=_BLADE\*(" + _NUM + ")", lines[a + 1]).group(1))
    head, _ = parse_siemens("\n".join(lines[:a]))
    assert len(head) == 0
    xyz0, ax0 = parse_siemens("\n".join(lines[a:b]))
    xs, axs = [], []
    for k in range(n):
        t = math.radians(k * pitch)
        R = np.array([[math.cos(t), -math.sin(t), 0], [math.sin(t), math.cos(t), 0], [0, 0, 1]])
        xs.append(xyz0 @ R.T)
        axs.append(ax0 @ R.T)
    return np.vstack(xs), np.vstack(axs)
