"""Robot programs of a resolved plan: KUKA KRL, ABB RAPID, Comau PDL2, Fanuc LS (texts).

Every program is a main file that sets the frames and speeds and calls the parts, and parts of
at most ``lines`` motions each (the controllers' editors and memory: KUKA ~1,400 lines, ABB and
Comau ~5,000, Fanuc ≤ 9,999 points). Each stroke starts with a joint move (PTP / MoveJ / MOVE
JOINT / J) to its first pose carrying the configuration; the rest are linear moves at the feed.
Positions are the tool tip in the part frame (``$BASE`` / ``wobjdata`` / ``$UFRAME`` / UF 1);
the tool frame is the robot's TCP (``$TOOL`` / ``tooldata`` / UT 1): its z axis points into
the part (minus the paths' tip → spindle axis).

Configuration encodings (from the joints q, :mod:`.kinematics` for shoulder/elbow/wrist):

* KUKA ``S`` bits: 0 wrist centre behind axis 1 (overhead), 1 elbow (A3 ≥ the stretched
  angle), 2 ``A5 < 0``; ``T`` bit i: ``A(i+1) < 0``; both written as KRL binary literals;
* ABB ``confdata [cf1, cf4, cf6, cfx]``: quadrant ``floor(q / 90°)`` of axes 1, 4, 6 and
  ``cfx = 4·back + 2·elbow + (axis 5 < 0)``;
* Fanuc ``CONFIG : 'F|N U|D T|B, t1, t4, t6'``: flip (J5 < 0), elbow, front/back; turn
  numbers ``floor((q + 180°) / 360°)`` of J1, J4, J6;
* Comau PDL2 config string: ``S`` (back), ``E`` (elbow), ``W`` (A5 < 0) and the turn flags
  ``T1:`` (axis 4), ``T2:`` (axis 6).

The robot-holds-part set-up (a fixed spindle or belt) is written in RAPID only: a stationary
``tooldata`` (robhold FALSE, its frame in the world) and a ``wobjdata`` held by the robot
(robhold TRUE, its frame on the flange); the robtargets are the same tool-in-part poses.

Nothing here writes a file: :func:`robot_program` returns the texts (the CLI writes them
atomically). Lengths mm, angles radians in, degrees in the texts, feed mm/min.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..toolpath.types import ToolPath
from ..version import __version__
from . import kinematics as K
from .description import Robot, RobotError
from .free_angle import RobotPlan
from .orientation import abc_from_matrix, quaternion_from_matrix, zyz_from_matrix
from .polishing import PolishingProcess

__all__ = [
    "DIALECTS",
    "LINES",
    "ProgramOptions",
    "RobotProgram",
    "config_tag",
    "robot_program",
]

DIALECTS = ("krl", "rapid", "pdl2", "fanuc-ls")
#: motions per part file
LINES = {"krl": 1200, "rapid": 4500, "pdl2": 4500, "fanuc-ls": 9999}
MAX_PARTS = 999
_P, _A, _Q = 4, 5, 9  # decimals: mm, degrees, quaternion components


@dataclass(frozen=True)
class ProgramOptions:
    """name : program base name; feed : mm/min (linear moves); ptp_percent : joint-move
    speed, % of the axes' maximum; blend : mm (KRL $APO.CDIS, RAPID zone, Fanuc CNT 100 when
    > 0); force : N, the polishing head's contact force setpoint (header only); lines :
    motions per part (default: :data:`LINES` of the dialect); tool_mass : kg (ABB loaddata);
    process : the polishing process values (:mod:`.polishing`) for the header, or None;
    notes : header lines added as they are (the collision gate's, :mod:`..post.gate`), ASCII."""

    name: str = "BLISK"
    feed: float = 600.0
    ptp_percent: float = 20.0
    blend: float = 0.5
    force: float | None = None
    lines: int | None = None
    tool_mass: float = 10.0
    process: PolishingProcess | None = None
    notes: tuple = ()

    def __post_init__(self):
        if not self.name or not self.name.replace("_", "").isalnum() or not self.name[0].isalpha():
            raise RobotError(f"program name {self.name!r}: letters, digits and _ only, "
                             "starting with a letter")
        if len(self.name) > 12:
            raise RobotError(f"program name {self.name!r} is longer than 12 characters")
        if not self.feed > 0:
            raise RobotError(f"feed must be > 0 mm/min, got {self.feed}")
        if not 0 < self.ptp_percent <= 100:
            raise RobotError(f"joint-move speed must be 1..100 %, got {self.ptp_percent}")
        if self.lines is not None and self.lines < 2:
            raise RobotError(f"motions per file must be ≥ 2, got {self.lines}")


@dataclass
class RobotProgram:
    """The files of a program: ``files`` {filename: text}, ``main`` the file to run, the
    ``dialect``, ``motions`` (every pose programmed, in order: (n, 4, 4) tool frames in the
    part frame and (n, 6) joints radians)."""

    dialect: str
    main: str
    files: dict = field(default_factory=dict)
    frames: np.ndarray | None = None
    joints: np.ndarray | None = None

    def summary(self) -> str:
        n = 0 if self.frames is None else len(self.frames)
        return (f"{self.dialect}: {len(self.files)} files ({len(self.files) - 1} parts), "
                f"{n} motions, main {self.main}")


# --- configuration tags -------------------------------------------------------------------
def config_tag(dialect: str, robot: Robot, q) -> tuple:
    """The controller's configuration of joints q (6,) radians, as the dialect writes it
    (module docstring): KRL (S, T); RAPID (cf1, cf4, cf6, cfx); Fanuc (flags, t1, t4, t6);
    PDL2 (flags, t4, t6)."""
    q = np.asarray(q, dtype=np.float64)
    cfg = int(K.configuration(robot, q))
    back, elbow = cfg >> 2 & 1, cfg >> 1 & 1
    neg5 = int(q[4] < 0)
    if dialect == "krl":
        s = back | elbow << 1 | neg5 << 2
        t = sum(int(q[i] < 0) << i for i in range(6))
        return (s, t)
    if dialect == "rapid":
        quad = [int(math.floor(q[i] / (math.pi / 2) + 1e-12)) for i in (0, 3, 5)]
        return (*quad, 4 * back + 2 * elbow + neg5)
    turns = [int(math.floor((q[i] + math.pi) / (2 * math.pi))) for i in (0, 3, 5)]
    if dialect == "fanuc-ls":
        flags = ("F" if neg5 else "N") + (" D" if elbow else " U") + (" B" if back else " T")
        return (flags, *turns)
    if dialect == "pdl2":
        flags = " ".join(f for f, on in (("S", back), ("E", elbow), ("W", neg5)) if on)
        return (flags, turns[1], turns[2])
    raise RobotError(f"unknown robot program dialect {dialect!r}; use one of {', '.join(DIALECTS)}")


# --- number text ----------------------------------------------------------------------------
def _f(x, d) -> str:
    s = f"{float(x):.{d}f}"
    return f"{0.0:.{d}f}" if float(s) == 0.0 else s


def _xyz(p) -> list[str]:
    return [_f(v, _P) for v in p]


def _deg(a) -> list[str]:
    return [_f(math.degrees(v), _A) for v in a]


def _chunks(n: int, per: int):
    """[(start, stop)] of n motions in parts of ``per``; more than MAX_PARTS parts: error."""
    parts = [(a, min(a + per, n)) for a in range(0, n, per)]
    if len(parts) > MAX_PARTS:
        raise RobotError(
            f"the program needs {len(parts)} part files of {per} motions; controllers take "
            f"at most {MAX_PARTS}: split the path (fewer passes) or raise the motions per file"
        )
    return parts


def _header(plan: RobotPlan, path: ToolPath | None, opt: ProgramOptions, c: str) -> list[str]:
    r = plan.robot
    st = plan.stats
    lines = [
        f"{c} Blisk CAM {__version__} robot program",
        f"{c} robot: {r.name}" + (f" ({r.brand})" if r.brand else ""),
        f"{c} tool: {r.tool_name}, head at {math.degrees(r.head_angle):.1f} deg to the flange",
        f"{c} strokes: {len(plan.strokes)}, motions: {plan.n_poses}, feed {opt.feed:g} mm/min",
    ]
    if path is not None:
        lines.append(f"{c} path: {len(path.curves)} passes, cusp {path.cusp:g} mm")
    if opt.force is not None:
        lines.append(f"{c} contact force setpoint: {opt.force:g} N (force-controlled head)")
    if opt.process is not None:
        lines.append(f"{c} polishing: {opt.process.summary()}")
    if st:
        lines.append(f"{c} min wrist-singularity margin {st['min_wrist_deg']:.2f} deg, "
                     f"min joint-limit margin {st['min_limit_margin_deg']:.2f} deg, max joint "
                     f"step {st['max_joint_step_deg']:.2f} deg")
    if r.rotary is not None:
        lines.append(f"{c} external rotary {r.rotary.name} parked at "
                     f"{math.degrees(r.rotary.angle):g} deg")
    lines += [f"{c} {note}" for note in opt.notes]
    return lines


def _part_world(robot: Robot) -> np.ndarray:
    """(4, 4) the part frame in the cell (world) frame, the rotary parked."""
    return robot.base @ robot.part_in_base()


def _motions(plan: RobotPlan):
    frames = np.concatenate([s.frame for s in plan.strokes])
    q = np.concatenate([s.q for s in plan.strokes])
    ptp = np.concatenate([np.arange(len(s.q)) == 0 for s in plan.strokes])
    return frames, q, ptp


def robot_program(plan: RobotPlan, dialect: str, options: ProgramOptions | None = None,
                  path: ToolPath | None = None) -> RobotProgram:
    """The program texts of a feasible ``plan`` in ``dialect`` (one of :data:`DIALECTS`).

    Raises RobotError for an infeasible plan (the ranges are in ``plan.infeasible``), an
    unknown dialect or a program that needs more files than a controller takes."""
    if dialect not in DIALECTS:
        raise RobotError(f"unknown robot program dialect {dialect!r}; use one of "
                         f"{', '.join(DIALECTS)}")
    if not plan.feasible:
        raise RobotError(f"the plan has {len(plan.infeasible)} infeasible stretches (first: "
                         f"{plan.infeasible[0].text()}); no program written")
    if plan.robot.holds_part and dialect != "rapid":
        raise RobotError(f"the robot holds the part (a fixed tool): programs for that set-up "
                         f"are written in RAPID (robhold work object), not {dialect}")
    opt = options or ProgramOptions()
    frames, q, ptp = _motions(plan)
    per = opt.lines or LINES[dialect]
    writer = {"krl": _krl, "rapid": _rapid, "pdl2": _pdl2, "fanuc-ls": _fanuc}[dialect]
    files, main = writer(plan, path, opt, frames, q, ptp, _chunks(len(q), per))
    files = {k: _ascii(v) for k, v in files.items()}
    return RobotProgram(dialect, main, files, frames, q)


_ASCII = {"°": " deg", "Ø": "D", "–": "-", "—": "-", "→": "->", "×": "x", "µ": "u"}


def _ascii(text: str) -> str:
    """The controllers read 7-bit text: names and comments made ASCII (degree signs spelled)."""
    for k, v in _ASCII.items():
        text = text.replace(k, v)
    return text.encode("ascii", "replace").decode("ascii")


# --- KUKA KRL ------------------------------------------------------------------------------
def _krl_frame(T) -> str:
    x, y, z = _xyz(T[:3, 3])
    a, b, c = _deg(abc_from_matrix(T[:3, :3]))
    return f"{{FRAME: X {x}, Y {y}, Z {z}, A {a}, B {b}, C {c}}}"


def _krl(plan, path, opt, frames, q, ptp, parts):
    r = plan.robot
    name = opt.name.upper()
    abc = abc_from_matrix(frames[:, :3, :3])
    files = {}
    calls = []
    for i, (a, z) in enumerate(parts, 1):
        pname = f"{name}_P{i:03d}"
        body = ["&ACCESS RVP", "&REL 1", f"DEF {pname}( )",
                f"; Blisk CAM {__version__}: part {i} of {len(parts)} of {name}_MAIN"]
        for j in range(a, z):
            x, y, zz = _xyz(frames[j, :3, 3])
            aa, bb, cc = _deg(abc[j])
            pos = f"X {x}, Y {y}, Z {zz}, A {aa}, B {bb}, C {cc}"
            if ptp[j]:
                if r.rotary is not None:  # the external axis to its parked angle
                    pos += f", E1 {_f(math.degrees(r.rotary.angle), _A)}"
                s, t = config_tag("krl", r, q[j])
                body.append(f"PTP {{E6POS: {pos}, S 'B{s:03b}', T 'B{t:06b}'}}")
            else:
                body.append(f"LIN {{E6POS: {pos}}} C_DIS")
        body.append("END")
        files[f"{pname.lower()}.src"] = "\n".join(body) + "\n"
        calls.append(f"{pname}( )")
    main = ["&ACCESS RVP", "&REL 1", f"DEF {name}_MAIN( )"]
    main += _header(plan, path, opt, ";")
    main += ["; $ROBROOT (machine data) must be the robot base of the cell:",
             f";   {_krl_frame(r.base)}",
             f"$BASE = {_krl_frame(_part_world(r))}",
             f"$TOOL = {_krl_frame(r.tool)}",
             f"$VEL.CP = {_f(opt.feed / 60000.0, 6)} ; m/s",
             f"$APO.CDIS = {_f(opt.blend, 3)} ; mm"]
    main += [f"$VEL_AXIS[{i}] = {opt.ptp_percent:g}" for i in range(1, 7)]
    main += calls + ["END"]
    mname = f"{name.lower()}_main.src"
    files[mname] = "\n".join(main) + "\n"
    return files, mname


# --- ABB RAPID -----------------------------------------------------------------------------
def _pose_text(T) -> str:
    x, y, z = _xyz(T[:3, 3])
    qq = ", ".join(_f(v, _Q) for v in quaternion_from_matrix(T[:3, :3]))
    return f"[[{x}, {y}, {z}], [{qq}]]"


def _rapid(plan, path, opt, frames, q, ptp, parts):
    r = plan.robot
    name = opt.name
    quat = quaternion_from_matrix(frames[:, :3, :3])
    ext = "9E9"
    if r.rotary is not None:
        ext = _f(math.degrees(r.rotary.angle), _A)
    extax = f"[{ext}, 9E9, 9E9, 9E9, 9E9, 9E9]"
    files, calls = {}, []
    for i, (a, z) in enumerate(parts, 1):
        mod = f"{name}_P{i:03d}"
        body = [f"MODULE {mod}",
                f"  ! Blisk CAM {__version__}: part {i} of {len(parts)} of {name}_MAIN",
                f"  PROC {mod.lower()}()"]
        for j in range(a, z):
            x, y, zz = _xyz(frames[j, :3, 3])
            qq = ", ".join(_f(v, _Q) for v in quat[j])
            cf = ", ".join(str(v) for v in config_tag("rapid", r, q[j]))
            target = f"[[{x}, {y}, {zz}], [{qq}], [{cf}], {extax}]"
            move = "MoveJ" if ptp[j] else "MoveL"
            speed = "vPtp" if ptp[j] else "vPolish"
            zone = "fine" if ptp[j] else "zPolish"
            body.append(f"    {move} {target}, {speed}, {zone}, tPolish\\WObj:=wBlisk;")
        body += ["  ENDPROC", "ENDMODULE"]
        files[f"{mod.lower()}.mod"] = "\n".join(body) + "\n"
        calls.append(f"    {mod.lower()};")
    v = opt.feed / 60.0
    main = [f"MODULE {name}_MAIN"] + ["  " + h for h in _header(plan, path, opt, "!")]
    # robot-holds-part: a stationary tool (tooldata robhold FALSE, its frame in the world)
    # and a work object on the flange (wobjdata robhold TRUE, uframe in the flange frame)
    held, fixed = ("TRUE", "FALSE") if r.holds_part else ("FALSE", "TRUE")
    uframe = r.part if r.holds_part else _part_world(r)
    main += [
        f"  PERS tooldata tPolish := [{fixed}, {_pose_text(r.tool)}, [{opt.tool_mass:g}, "
        f"[{', '.join(_xyz(r.tool[:3, 3] / 2))}], [1, 0, 0, 0], 0, 0, 0]];",
        f"  PERS wobjdata wBlisk := [{held}, TRUE, \"\", {_pose_text(uframe)}, "
        "[[0, 0, 0], [1, 0, 0, 0]]];",
        f"  CONST speeddata vPolish := [{_f(v, 3)}, 30, 5000, 1000];",
        f"  CONST speeddata vPtp := [{_f(20 * opt.ptp_percent, 1)}, 200, 5000, 1000];",
        f"  CONST zonedata zPolish := [FALSE, {_f(opt.blend, 3)}, {_f(opt.blend * 1.5, 3)}, "
        f"{_f(opt.blend * 1.5, 3)}, 0.1, {_f(opt.blend * 1.5, 3)}, 0.1];",
        "  PROC main()",
        "    ConfJ \\On;",
        "    ConfL \\On;",
    ] + calls + ["  ENDPROC", "ENDMODULE"]
    mname = f"{name.lower()}_main.mod"
    files[mname] = "\n".join(main) + "\n"
    return files, mname


# --- Comau PDL2 ----------------------------------------------------------------------------
def _pdl2_pos(T, cfg="") -> str:
    x, y, z = _xyz(T[:3, 3])
    e1, e2, e3 = _deg(zyz_from_matrix(T[:3, :3]))
    return f"POS({x}, {y}, {z}, {e1}, {e2}, {e3}, '{cfg}')"


def _pdl2(plan, path, opt, frames, q, ptp, parts):
    r = plan.robot
    name = opt.name.lower()
    files, calls, imports = {}, [], []
    for i, (a, z) in enumerate(parts, 1):
        prog = f"{name}_p{i:03d}"
        body = [f"PROGRAM {prog} NOHOLD, PROG_ARM = 1",
                f"-- Blisk CAM {__version__}: part {i} of {len(parts)} of {name}_main",
                f"ROUTINE {prog}_run EXPORTED FROM {prog} GLOBAL",
                f"ROUTINE {prog}_run", "BEGIN"]
        for j in range(a, z):
            if ptp[j]:
                flags, t4, t6 = config_tag("pdl2", r, q[j])
                cfg = " ".join(x for x in (flags, f"T1:{t4}", f"T2:{t6}") if x)
                body.append(f"  MOVE JOINT TO {_pdl2_pos(frames[j], cfg)}")
            else:
                body.append(f"  MOVE LINEAR TO {_pdl2_pos(frames[j])}")
        body += [f"END {prog}_run", "BEGIN", f"END {prog}"]
        files[f"{prog}.pdl"] = "\n".join(body) + "\n"
        imports.append(f"ROUTINE {prog}_run EXPORTED FROM {prog}")
        calls.append(f"  {prog}_run")
    main = [f"PROGRAM {name}_main PROG_ARM = 1"]
    main += ["-- " + h[2:] for h in _header(plan, path, opt, "--")]
    main += imports + [
        "BEGIN",
        f"  $UFRAME := {_pdl2_pos(_part_world(r))}",
        f"  $TOOL := {_pdl2_pos(r.tool)}",
        f"  $LIN_SPD := {_f(opt.feed / 60000.0, 6)}  -- m/s",
        f"  $PROG_SPD_OVR := {opt.ptp_percent:g}",
        "  $TERM_TYPE := NOSETTLE",
    ] + calls + [f"END {name}_main"]
    mname = f"{name}_main.pdl"
    files[mname] = "\n".join(main) + "\n"
    return files, mname


# --- Fanuc LS ------------------------------------------------------------------------------
def _fanuc_wpr(T) -> tuple[str, ...]:
    a, b, c = _deg(abc_from_matrix(T[:3, :3]))
    return (*_xyz(T[:3, 3]), c, b, a)  # W = C, P = B, R = A


def _fanuc(plan, path, opt, frames, q, ptp, parts):
    r = plan.robot
    name = opt.name.upper()
    files, calls = {}, []
    mm_s = opt.feed / 60.0
    cnt = "CNT100" if opt.blend > 0 else "FINE"
    for i, (a, z) in enumerate(parts, 1):
        prog = f"{name}{i:03d}"
        mn, pos = [], []
        for n, j in enumerate(range(a, z), 1):
            if ptp[j]:
                mn.append(f"{n:4d}:J P[{n}] {opt.ptp_percent:g}% FINE    ;")
            else:
                mn.append(f"{n:4d}:L P[{n}] {_f(mm_s, 1)}mm/sec {cnt}    ;")
            flags, t1, t4, t6 = config_tag("fanuc-ls", r, q[j])
            x, y, zz, w, p, rr = _fanuc_wpr(frames[j])
            pos += [f"P[{n}]{{", "   GP1:",
                    f"\tUF : 1, UT : 1,\t\tCONFIG : '{flags}, {t1}, {t4}, {t6}',",
                    f"\tX = {x} mm,\tY = {y} mm,\tZ = {zz} mm,",
                    f"\tW = {w} deg,\tP = {p} deg,\tR = {rr} deg", "};"]
        text = [f"/PROG  {prog}", "/ATTR", f'COMMENT\t\t= "Blisk CAM part {i}/{len(parts)}";',
                "DEFAULT_GROUP\t= 1,*,*,*,*;", "/MN"] + mn + ["/POS"] + pos + ["/END"]
        files[f"{prog.lower()}.ls"] = "\n".join(text) + "\n"
        calls.append(f"CALL {prog}")
    uf = " ".join(f"{k} {v}" for k, v in zip("XYZWPR", _fanuc_wpr(_part_world(r)), strict=True))
    ut = " ".join(f"{k} {v}" for k, v in zip("XYZWPR", _fanuc_wpr(r.tool), strict=True))
    lines = [f"! {h[2:]}" for h in _header(plan, path, opt, "!")]
    lines += [f"! UFRAME 1 = {uf}", f"! UTOOL 1 = {ut}", "UFRAME_NUM=1", "UTOOL_NUM=1"]
    lines += calls
    mn = [f"{n:4d}:  {t} ;" for n, t in enumerate(lines, 1)]
    main = [f"/PROG  {name}MAIN", "/ATTR", 'COMMENT\t\t= "Blisk CAM robot program";',
            "DEFAULT_GROUP\t= 1,*,*,*,*;", "/MN"] + mn + ["/POS", "/END"]
    mname = f"{name.lower()}main.ls"
    files[mname] = "\n".join(main) + "\n"
    return files, mname
