"""Robot description (TOML): a 6R arm with an ortho-parallel basis and a spherical wrist (OPW).

The seven OPW parameters (Brandstötter, Angerer, Hofbaur 2014, "An analytical solution of the
inverse kinematics problem of industrial serial manipulators with an ortho-parallel basis and a
spherical wrist", Fig. 1) describe the arms KUKA, ABB, Fanuc and Comau build: ``c1`` height of
joint 2 over the base, ``a1`` its offset from joint 1, ``b`` the lateral offset, ``c2`` the
upper arm, ``a2`` the elbow offset, ``c3`` the forearm to the wrist centre, ``c4`` wrist centre
→ flange. The controller's joint values relate to the model angles θ of the paper by
``joint = sign · (θ + offset)`` (the convention of the OPW literature's parameter tables).

Frames (all 4×4 homogeneous, mm):

* **base** — the robot's base frame (OPW frame 0) in the cell frame;
* **part** — the paths' frame in the cell frame (controller: ``$BASE`` / ``wobjdata``);
* **tool** — the tool centre point frame (TCP) in the flange frame (``$TOOL`` / ``tooldata``);
  its z axis is the **approach** direction, from the head into the part (minus the paths'
  tip → spindle axis). An angled head has a tool z not parallel to the flange z: only then
  does the free angle about the tool axis move joint 5 (paper 004 §2: a polishing head
  at an angle to the flange);
* an optional external **rotary** axis holding the blisk (axis, point in the cell frame,
  limits, speed); the part frame turns with it;
* optional **meshes** for drawing the arm (``[meshes]``: ``base``, ``link1`` … ``link6``,
  mesh files — STL, OBJ, PLY — relative to the TOML, each in its link's frame as
  :func:`.kinematics.joint_frames` gives it; ``scale`` mm per file unit, default 1); a link
  without one is drawn as a simple shape. Only drawing uses them.

Two set-ups (``setup``): ``"robot-holds-tool"`` (default; the frames as above) and
``"robot-holds-part"``: the robot carries the blisk against a fixed spindle or belt; then
``[part]`` is the part frame **in the flange frame** and ``[tool]`` the fixed tool frame **in
the cell frame** (no rotary). Either way a pose is the tool frame in the part frame, and
:meth:`Robot.flange_of` / :meth:`Robot.pose_of` go between poses and flange frames.

In the TOML lengths are mm and angles **degrees** (limits, offsets, speeds in °/s); in this
module and the rest of the core, radians. Presets live in ``blisk_cam/robots/<name>.toml``;
:func:`load_robot` takes a preset name or a path.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import BliskCamError
from ..presets import preset_names, read_preset_toml

__all__ = [
    "MESH_LINKS",
    "OPW_KEYS",
    "ROBOTS_DIR",
    "SETUPS",
    "Robot",
    "RobotError",
    "Rotary",
    "frame_matrix",
    "known_robots",
    "load_robot",
    "robot_from_dict",
    "with_rotary_angle",
]

ROBOTS_DIR = Path(__file__).resolve().parents[2] / "robots"
SETUPS = ("robot-holds-tool", "robot-holds-part")
OPW_KEYS = ("a1", "a2", "b", "c1", "c2", "c3", "c4")
_ORTHO_TOL = 1e-6

# every key the TOML may hold, per table ("" = top level)
_KNOWN = {
    "": ("name", "setup", "opw", "joints", "tool", "base", "part", "rotary", "controller",
         "meshes"),
    "opw": OPW_KEYS,
    "joints": ("offsets", "signs", "limits", "speeds"),
    "tool": ("name", "origin", "x", "z", "mass"),
    "base": ("origin", "x", "z"),
    "part": ("origin", "x", "z"),
    "rotary": ("name", "axis", "point", "limits", "speed", "angle"),
    "controller": ("brand", "model"),
    "meshes": ("base", "link1", "link2", "link3", "link4", "link5", "link6", "scale"),
}
#: the drawn links of ``[meshes]``, in the order of :func:`.kinematics.joint_frames`
MESH_LINKS = ("base", "link1", "link2", "link3", "link4", "link5", "link6")


class RobotError(BliskCamError):
    """The robot description is unusable (malformed TOML, a missing OPW parameter, an unknown
    key, a limit below its lower bound, a frame whose x and z are not orthogonal)."""


@dataclass(frozen=True)
class Rotary:
    """The external rotary axis holding the part: unit ``axis`` (3,) and ``point`` (3,) mm in
    the cell frame, ``limits`` (lo, hi) radians or None (endless), ``speed`` rad/s, the
    ``angle`` radians at which it is parked while the program runs."""

    name: str
    axis: np.ndarray
    point: np.ndarray
    limits: tuple[float, float] | None
    speed: float
    angle: float = 0.0

    def transform(self, angle: float) -> np.ndarray:
        """(4, 4) the part's motion for the rotary at ``angle`` radians (cell frame)."""
        k = self.axis
        K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
        R = np.eye(3) + math.sin(angle) * K + (1.0 - math.cos(angle)) * (K @ K)
        T = np.eye(4)
        T[:3, :3] = R
        T[:3, 3] = self.point - R @ self.point
        return T


@dataclass(frozen=True)
class Robot:
    """A 6R OPW arm in its cell (module docstring for the meaning of every field).

    opw : dict of the seven parameters, mm; offsets (6,) rad; signs (6,) ±1; limits (6, 2)
    rad (joint values); speeds (6,) rad/s; tool, base, part : (4, 4) frames (module
    docstring); rotary : :class:`Rotary` or None; tool_name, brand : str; source : where read.
    """

    name: str
    opw: dict
    offsets: np.ndarray
    signs: np.ndarray
    limits: np.ndarray
    speeds: np.ndarray
    tool: np.ndarray
    base: np.ndarray
    part: np.ndarray
    rotary: Rotary | None = None
    tool_name: str = "polishing head"
    brand: str = ""
    source: str = ""
    setup: str = "robot-holds-tool"
    meshes: tuple = ()
    mesh_scale: float = 1.0

    @property
    def holds_part(self) -> bool:
        return self.setup == "robot-holds-part"

    @property
    def head_angle(self) -> float:
        """Angle (radians) between the tool's z axis and the flange's z axis: 0 for a head on
        the flange axis (the free angle then turns joint 6 only)."""
        return math.acos(float(np.clip(self.tool[2, 2], -1.0, 1.0)))

    def part_in_base(self) -> np.ndarray:
        """(4, 4) the part frame in the robot's base frame, the rotary at its parked angle
        (robot-holds-tool)."""
        part = self.part
        if self.rotary is not None:
            part = self.rotary.transform(self.rotary.angle) @ part
        return np.linalg.solve(self.base, part)

    def flange_of(self, pose, *, part=None, tool=None) -> np.ndarray:
        """(..., 4, 4) flange frames in the base frame that put the tool at ``pose`` (...,
        4, 4: tool frame in the part frame). ``part``, ``tool``: the frames as a program
        states them (default this robot's; the part in the cell for robot-holds-tool)."""
        pose = np.asarray(pose, dtype=np.float64)
        base_inv = np.linalg.inv(self.base)
        tool = self.tool if tool is None else tool
        if self.holds_part:  # base · flange · part · pose = tool (fixed, in the cell)
            part = self.part if part is None else part
            return base_inv @ tool @ np.linalg.inv(pose) @ np.linalg.inv(part)
        part = self.base @ self.part_in_base() if part is None else part
        return base_inv @ part @ pose @ np.linalg.inv(tool)

    def pose_of(self, flange) -> np.ndarray:
        """(..., 4, 4) tool frames in the part frame of flange frames in the base frame (the
        inverse of :meth:`flange_of`)."""
        flange = np.asarray(flange, dtype=np.float64)
        if self.holds_part:
            return np.linalg.inv(self.part) @ np.linalg.inv(flange) @ np.linalg.solve(
                self.base, self.tool)
        return np.linalg.inv(self.part_in_base()) @ flange @ self.tool


def frame_matrix(origin, x, z) -> np.ndarray:
    """(4, 4) frame with ``origin`` (3,) mm and unit axes x, z (3,) (y = z × x)."""
    T = np.eye(4)
    T[:3, 0], T[:3, 2] = x, z
    T[:3, 1] = np.cross(z, x)
    T[:3, 3] = origin
    return T


def with_rotary_angle(robot: Robot, angle: float) -> Robot:
    """The robot with its external rotary parked at ``angle`` radians (RobotError without a
    rotary or outside its limits)."""
    rot = robot.rotary
    if rot is None:
        raise RobotError(f"robot {robot.name} has no external rotary; add a [rotary] table")
    if rot.limits is not None and not rot.limits[0] <= angle <= rot.limits[1]:
        raise RobotError(
            f"rotary {rot.name} angle {math.degrees(angle):g}° is outside its limits "
            f"[{math.degrees(rot.limits[0]):g}°, {math.degrees(rot.limits[1]):g}°]")
    return dataclasses.replace(robot, rotary=dataclasses.replace(rot, angle=angle))


# --- reading -----------------------------------------------------------------------------
def known_robots() -> list[str]:
    """Names of the robot presets shipped in ``blisk_cam/robots``."""
    return preset_names(ROBOTS_DIR)


def load_robot(name_or_path) -> Robot:
    """A preset name (``"kr120-r2700"``) or a path to a robot TOML → :class:`Robot`.

    Raises RobotError naming the problem (unknown preset: lists the known ones)."""
    data, path = read_preset_toml(name_or_path, ROBOTS_DIR, "robot", RobotError)
    return robot_from_dict(data, source=str(path))


def _check_keys(d: dict, table: str, where: str) -> None:
    known = _KNOWN[table]
    for key in d:
        if key not in known:
            near = difflib.get_close_matches(str(key), known, n=1, cutoff=0.0)
            label = f"[{table}] " if table else ""
            raise RobotError(
                f"robot {where}: unknown key {label}{key!r}; did you mean {near[0]!r}? "
                f"(known: {', '.join(known)})"
            )


def _table(data: dict, key: str, where: str, *, required: bool) -> dict | None:
    if key not in data:
        if required:
            raise RobotError(f"robot {where}: missing table [{key}]")
        return None
    t = data[key]
    if not isinstance(t, dict):
        raise RobotError(f"robot {where}: [{key}] must be a table, got {t!r}")
    _check_keys(t, key, where)
    return t


def _number(d: dict, key: str, what: str) -> float:
    if key not in d:
        raise RobotError(f"robot {what}: missing {key!r} (a number)")
    try:
        v = float(d[key])
    except (TypeError, ValueError):
        raise RobotError(f"robot {what}: {key!r} must be a number, got {d[key]!r}") from None
    if not math.isfinite(v):
        raise RobotError(f"robot {what}: {key!r} must be finite, got {d[key]!r}")
    return v


def _numbers(d: dict, key: str, what: str, n: int, *, default=None) -> np.ndarray:
    if key not in d:
        if default is not None:
            return np.asarray(default, dtype=np.float64)
        raise RobotError(f"robot {what}: missing {key!r} ({n} numbers)")
    try:
        v = np.asarray(d[key], dtype=np.float64)
    except (TypeError, ValueError):
        raise RobotError(f"robot {what}: {key!r} must be {n} numbers, got {d[key]!r}") from None
    if v.shape != (n,) or not np.all(np.isfinite(v)):
        raise RobotError(f"robot {what}: {key!r} must be {n} finite numbers, got {d[key]!r}")
    return v


def _unit(d: dict, key: str, what: str, default) -> np.ndarray:
    v = _numbers(d, key, what, 3, default=default)
    n = float(np.linalg.norm(v))
    if n < 1e-12:
        raise RobotError(f"robot {what}: {key!r} is the zero vector; give a direction")
    return v / n


def _frame(t: dict | None, what: str, *, default_x=(1.0, 0.0, 0.0)) -> np.ndarray:
    t = t or {}
    origin = _numbers(t, "origin", what, 3, default=(0.0, 0.0, 0.0))
    z = _unit(t, "z", what, (0.0, 0.0, 1.0))
    if "x" in t:
        x = _unit(t, "x", what, None)
        if abs(float(x @ z)) > _ORTHO_TOL:
            ang = math.degrees(math.acos(float(np.clip(x @ z, -1, 1))))
            raise RobotError(f"robot {what}: x and z are not orthogonal (angle {ang:.4f}°)")
    else:  # the default x projected onto the plane normal to z
        x = np.asarray(default_x, dtype=np.float64)
        if abs(float(x @ z)) > 0.99:
            x = np.array([0.0, 1.0, 0.0])
        x = x - (x @ z) * z
        x /= np.linalg.norm(x)
    return frame_matrix(origin, x, z)


def robot_from_dict(data: dict, source: str = "") -> Robot:
    """Validate a parsed robot TOML (module docstring) → :class:`Robot`."""
    where = Path(source).name if source else "description"
    _check_keys(data, "", where)
    setup = str(data.get("setup", SETUPS[0]))
    if setup not in SETUPS:
        raise RobotError(f"robot {where}: unknown setup {setup!r}; use one of {', '.join(SETUPS)}")
    opw_t = _table(data, "opw", where, required=True)
    opw = {k: _number(opw_t, k, f"{where} [opw]") for k in OPW_KEYS}
    for k in ("c2", "c3"):
        if opw[k] <= 0:
            raise RobotError(f"robot {where} [opw]: {k} must be > 0 mm, got {opw[k]:g}")
    if opw["c4"] < 0:
        raise RobotError(f"robot {where} [opw]: c4 must be ≥ 0 mm, got {opw['c4']:g}")
    jt = _table(data, "joints", where, required=True)
    w = f"{where} [joints]"
    offsets = np.radians(_numbers(jt, "offsets", w, 6, default=np.zeros(6)))
    signs = _numbers(jt, "signs", w, 6, default=np.ones(6))
    if not np.all(np.isin(signs, (-1.0, 1.0))):
        raise RobotError(f"robot {w}: signs must be 1 or -1 each, got {jt['signs']!r}")
    if "limits" not in jt:
        raise RobotError(f"robot {w}: missing 'limits' (six [min, max] pairs, degrees)")
    try:
        lim = np.asarray(jt["limits"], dtype=np.float64)
    except (TypeError, ValueError):
        raise RobotError(f"robot {w}: 'limits' must be six [min, max] pairs (degrees)") from None
    if lim.shape != (6, 2) or not np.all(np.isfinite(lim)):
        raise RobotError(f"robot {w}: 'limits' must be six finite [min, max] pairs (degrees)")
    for i, (lo, hi) in enumerate(lim, 1):
        if hi <= lo:
            raise RobotError(
                f"robot {w}: joint {i} limit {hi:g}° is not above its lower bound {lo:g}°; "
                "write [min, max]"
            )
    speeds = _numbers(jt, "speeds", w, 6)
    if np.any(speeds <= 0):
        i = int(np.argmax(speeds <= 0)) + 1
        raise RobotError(f"robot {w}: joint {i} speed must be > 0 °/s, got {speeds[i - 1]:g}")
    tool_t = _table(data, "tool", where, required=True)
    tool = _frame(tool_t, f"{where} [tool]")
    base = _frame(_table(data, "base", where, required=False), f"{where} [base]")
    part = _frame(_table(data, "part", where, required=False), f"{where} [part]")
    rotary = None
    rt = _table(data, "rotary", where, required=False)
    if rt is not None:
        w = f"{where} [rotary]"
        limits = None
        if "limits" in rt:
            lo, hi = _numbers(rt, "limits", w, 2)
            if hi <= lo:
                raise RobotError(f"robot {w}: limit {hi:g}° is not above its lower bound {lo:g}°")
            limits = (math.radians(lo), math.radians(hi))
        speed = _number(rt, "speed", w)
        if speed <= 0:
            raise RobotError(f"robot {w}: speed must be > 0 °/s, got {speed:g}")
        angle = math.radians(float(rt.get("angle", 0.0)))
        if limits is not None and not limits[0] <= angle <= limits[1]:
            raise RobotError(f"robot {w}: parked angle {math.degrees(angle):g}° outside its limits")
        rotary = Rotary(str(rt.get("name", "E1")), _unit(rt, "axis", w, None),
                        _numbers(rt, "point", w, 3, default=(0.0, 0.0, 0.0)), limits,
                        math.radians(speed), angle)
    if rotary is not None and setup == "robot-holds-part":
        raise RobotError(f"robot {where}: a [rotary] holds the part, but the setup is "
                         "robot-holds-part; remove one")
    ctl = _table(data, "controller", where, required=False) or {}
    meshes, mesh_scale = _meshes(_table(data, "meshes", where, required=False), where, source)
    return Robot(
        name=str(data.get("name", where)),
        opw=opw,
        offsets=offsets,
        signs=signs,
        limits=np.radians(lim),
        speeds=np.radians(speeds),
        tool=tool,
        base=base,
        part=part,
        rotary=rotary,
        tool_name=str((tool_t or {}).get("name", "polishing head")),
        brand=str(ctl.get("brand", "")),
        source=source,
        setup=setup,
        meshes=meshes,
        mesh_scale=mesh_scale,
    )


def _meshes(t: dict | None, where: str, source: str) -> tuple[tuple, float]:
    """((link index, absolute path), ...) and the scale of a ``[meshes]`` table; every file
    must exist (named when it does not)."""
    if not t:
        return (), 1.0
    w = f"{where} [meshes]"
    scale = _number(t, "scale", w) if "scale" in t else 1.0
    if scale <= 0:
        raise RobotError(f"robot {w}: scale must be > 0 (mm per file unit), got {scale:g}")
    folder = Path(source).resolve().parent if source else Path.cwd()
    out = []
    for i, key in enumerate(MESH_LINKS):
        if key not in t:
            continue
        if not isinstance(t[key], str) or not t[key]:
            raise RobotError(f"robot {w}: {key!r} must be a mesh file name, got {t[key]!r}")
        path = (folder / Path(t[key]).expanduser()).resolve()
        if not path.is_file():
            raise RobotError(f"robot {w}: {key} mesh {t[key]!r} not found (looked for {path})")
        out.append((i, str(path)))
    return tuple(out), scale
