"""Robot programs read back: our own parsers of the four dialects that :mod:`.programs` writes,
and the joints a controller would take for what was read (closed-form IK with the written
configuration). The tests turn them through forward kinematics and compare with the path.

:func:`read_program` follows the main file's calls into the parts (texts given as
{filename: text}) and returns the motions in order: (n, 4, 4) tool frames in the part frame,
(n,) joint-move flags and the configuration tags as written (None on linear moves that carry
none); the frames the main file sets (part in the cell, tool on the flange).
"""

from __future__ import annotations

import itertools
import math
import re
from dataclasses import dataclass

import numpy as np

from . import kinematics as K
from .description import Robot, RobotError
from .orientation import matrix_from_abc, matrix_from_quaternion, matrix_from_zyz
from .programs import config_tag

__all__ = ["ReadProgram", "decode_joints", "read_program"]

_N = r"[-+]?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?"


@dataclass
class ReadProgram:
    """frames (n, 4, 4) tool in the part frame; joint_move (n,) bool; tags [tuple | None];
    part (4, 4) the part frame in the cell; tool (4, 4) the tool on the flange."""

    frames: np.ndarray
    joint_move: np.ndarray
    tags: list
    part: np.ndarray
    tool: np.ndarray


def _frame(xyz, R) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = xyz
    return T


def _abc_frame(x, y, z, a, b, c):
    return _frame([x, y, z], matrix_from_abc(*np.radians([a, b, c])))


def _calls(main: str, pattern: str) -> list[str]:
    return re.findall(pattern, main, flags=re.M)


def read_program(dialect: str, files: dict, main: str) -> ReadProgram:
    """Parse the program ``files`` ({name: text}) starting at ``main``."""
    reader = {"krl": _krl, "rapid": _rapid, "pdl2": _pdl2, "fanuc-ls": _fanuc}.get(dialect)
    if reader is None:
        raise RobotError(f"no reader for dialect {dialect!r}")
    frames, jm, tags, part, tool = reader(files, main)
    return ReadProgram(np.array(frames), np.array(jm, bool), tags, part, tool)


def _krl(files, main):
    text = files[main]
    agg = r"\{FRAME: X (\S+), Y (\S+), Z (\S+), A (\S+), B (\S+), C (\S+)\}"
    part = _abc_frame(*map(float, re.search(r"^\$BASE = " + agg, text, re.M).groups()))
    tool = _abc_frame(*map(float, re.search(r"^\$TOOL = " + agg, text, re.M).groups()))
    frames, jm, tags = [], [], []
    pos = (r"X (" + _N + r"), Y (" + _N + r"), Z (" + _N + r"), A (" + _N + r"), B (" + _N
           + r"), C (" + _N + r")")
    for call in _calls(text, r"^(\w+_P\d+)\( \)$"):
        for line in files[f"{call.lower()}.src"].splitlines():
            m = re.match(r"(PTP|LIN) \{E6POS: " + pos + r"(?:, E1 " + _N
                         + r")?(?:, S 'B([01]+)', T 'B([01]+)')?\}", line)
            if not m:
                continue
            frames.append(_abc_frame(*map(float, m.group(2, 3, 4, 5, 6, 7))))
            jm.append(m.group(1) == "PTP")
            tags.append((int(m.group(8), 2), int(m.group(9), 2)) if m.group(8) else None)
    return frames, jm, tags, part, tool


def _rapid(files, main):
    text = files[main]
    pose = (r"\[\[(" + _N + r"), (" + _N + r"), (" + _N + r")\], \[(" + _N + r"), (" + _N
            + r"), (" + _N + r"), (" + _N + r")\]\]")

    def frame(m, k=1):
        v = [float(x) for x in m.groups()[k - 1:k + 6]]
        return _frame(v[:3], matrix_from_quaternion(v[3:]))

    tool = frame(re.search(r"PERS tooldata tPolish := \[(?:TRUE|FALSE), " + pose, text))
    part = frame(re.search(r"PERS wobjdata wBlisk := \[(?:TRUE|FALSE), TRUE, \"\", " + pose,
                           text))
    frames, jm, tags = [], [], []
    for call in _calls(text, r"^    (\w+_p\d+);$"):
        for line in files[f"{call}.mod"].splitlines():
            m = re.match(r"\s+(MoveJ|MoveL) " + pose[:-2] + r", \[(-?\d+), (-?\d+), (-?\d+), "
                         r"(\d+)\]", line)
            if not m:
                continue
            frames.append(frame(m, 2))
            jm.append(m.group(1) == "MoveJ")
            tags.append(tuple(int(x) for x in m.group(9, 10, 11, 12)))
    return frames, jm, tags, part, tool


def _pdl2_frame(groups):
    x, y, z, e1, e2, e3 = map(float, groups)
    return _frame([x, y, z], matrix_from_zyz(*np.radians([e1, e2, e3])))


def _pdl2(files, main):
    text = files[main]
    pos = (r"POS\((" + _N + r"), (" + _N + r"), (" + _N + r"), (" + _N + r"), (" + _N
           + r"), (" + _N + r"), '([^']*)'\)")
    part = _pdl2_frame(re.search(r"\$UFRAME := " + pos, text).groups()[:6])
    tool = _pdl2_frame(re.search(r"\$TOOL := " + pos, text).groups()[:6])
    frames, jm, tags = [], [], []
    for call in _calls(text, r"^  (\w+_p\d+)_run$"):
        for line in files[f"{call}.pdl"].splitlines():
            m = re.match(r"\s+MOVE (JOINT|LINEAR) TO " + pos, line)
            if not m:
                continue
            frames.append(_pdl2_frame(m.groups()[1:7]))
            jm.append(m.group(1) == "JOINT")
            cfg = m.group(8)
            if m.group(1) == "JOINT":
                turns = dict(re.findall(r"(T\d):(-?\d+)", cfg))
                flags = " ".join(f for f in cfg.split() if ":" not in f)
                tags.append((flags, int(turns["T1"]), int(turns["T2"])))
            else:
                tags.append(None)
    return frames, jm, tags, part, tool


def _fanuc_frame(v):
    x, y, z, w, p, r = v
    return _abc_frame(x, y, z, r, p, w)


def _fanuc(files, main):
    text = files[main]
    six = r"X (\S+) Y (\S+) Z (\S+) W (\S+) P (\S+) R (\S+)"
    part = _fanuc_frame(map(float, re.search(r"! UFRAME 1 = " + six, text).groups()))
    tool = _fanuc_frame(map(float, re.search(r"! UTOOL 1 = " + six, text).groups()))
    frames, jm, tags = [], [], []
    for call in _calls(text, r"^\s*\d+:\s+CALL (\w+) ;$"):
        body = files[f"{call.lower()}.ls"]
        kinds = {n: k for k, n in re.findall(r"^\s*\d+:(J|L) P\[(\d+)\]", body, re.M)}
        for m in re.finditer(
                r"P\[(\d+)\]\{\s+GP1:\s+UF : 1, UT : 1,\s+CONFIG : '([FN] [UD] [TB]), (-?\d+), "
                r"(-?\d+), (-?\d+)',\s+X = (" + _N + r") mm,\s+Y = (" + _N + r") mm,\s+Z = ("
                + _N + r") mm,\s+W = (" + _N + r") deg,\s+P = (" + _N + r") deg,\s+R = (" + _N
                + r") deg", body):
            frames.append(_fanuc_frame(map(float, m.group(6, 7, 8, 9, 10, 11))))
            jm.append(kinds[m.group(1)] == "J")
            tags.append((m.group(2), int(m.group(3)), int(m.group(4)), int(m.group(5))))
    return frames, jm, tags, part, tool


# --- the joints a controller takes ---------------------------------------------------------
def _turn_choices(robot: Robot, q):
    """Per joint, the values q + 2πn inside the limits."""
    out = []
    for i in range(6):
        c = [q[i] + 2 * math.pi * n for n in (-1, 0, 1)]
        out.append([v for v in c if robot.limits[i, 0] - 1e-9 <= v <= robot.limits[i, 1] + 1e-9])
    return out


def decode_joints(robot: Robot, dialect: str, read: ReadProgram) -> np.ndarray:
    """(n, 6) joints radians for the motions read: the IK solution whose configuration tag is
    the one written; on a linear move without a tag, the previous configuration with the
    turns nearest the previous joints (the controller's linear interpolation). Raises
    RobotError where no solution matches."""
    flange = robot.flange_of(read.frames, part=read.part, tool=read.tool)
    Q, ok = K.inverse(robot, flange)
    out = np.empty((len(Q), 6))
    prev = None
    for j in range(len(Q)):
        tag = read.tags[j]
        cands = []
        slots = np.nonzero(ok[j])[0]
        if tag is None and prev is not None:
            slots = [s for s in slots if s == int(K.configuration(robot, prev))]
        for s in slots:
            for combo in itertools.product(*_turn_choices(robot, Q[j, s])):
                v = np.array(combo)
                if tag is None or config_tag(dialect, robot, v) == tag:
                    cands.append(v)
        if not cands:
            raise RobotError(f"motion {j + 1}: no joint solution with configuration {tag}")
        if prev is not None and (tag is None or len(cands) > 1):
            cands.sort(key=lambda v: float(np.abs(v - prev).max()))
        out[j] = prev = cands[0]
    return out
