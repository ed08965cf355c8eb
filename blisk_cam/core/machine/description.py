"""Machine description (TOML) and forward kinematics of 5-axis machines.

A machine is three linear axes X, Y, Z and two rotaries in chain order from the machine base
outward (``rotary[0]`` = rotary 1, ``rotary[1]`` = rotary 2). Every ``axis``, ``point`` and
``spindle`` is in machine coordinates with all rotaries at 0; a positive joint value θ turns
the moving member by θ right-handed about ``axis`` through ``point``:
``T(θ) p = R(axis, θ) (p − point) + point`` (Rodrigues).

Kinds (the programmed X, Y, Z are always the machine position of the **tool tip**):

``table-table``
    both rotaries carry the part (e.g. the A/C double turntable of paper 002, §2.1, Fig. 2).
    A path point w sits, rotaries at 0, at ``m0 = origin + [x, y, z] w`` (y = z × x), and at
    joints (θ1, θ2) at ``m = T1(θ1) T2(θ2) m0``; the tool axis is ``spindle``.
``head-table``
    rotary 1 turns the spindle (head), rotary 2 the part (table): ``m = T2(θ2) m0``, tool axis
    ``R1(θ1) spindle``.
``head-head``
    both rotaries turn the spindle: ``m = m0``, tool axis ``R1(θ1) R2(θ2) spindle``.

This is the forward model whose time derivative is the Jacobian of paper 002, Eq. (4)–(6)
(A/C table-table: X, Y, Z, A, C → tip P_W and axis O_W in the workpiece frame). Paper 003
§IV.A (Fig. 4) names the three frames used here: machine (x_M y_M z_M), workpiece, part.

Lengths mm, angles radians in this module (degrees only in the TOML and in messages).

Presets live in ``blisk_cam/machines/<name>.toml``; :func:`load_machine` takes a preset name
or a path.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import MachineError, check_known_keys
from ..geometry.vectors import rotate
from ..presets import preset_names, read_preset_toml

__all__ = [
    "KINEMATICS",
    "MACHINES_DIR",
    "Machine",
    "Rotary",
    "forward",
    "known_presets",
    "load_machine",
    "machine_axis",
    "machine_from_dict",
    "tip_to_machine",
]

KINEMATICS = ("table-table", "head-table", "head-head")
#: the keys a machine TOML may have (anything else is a typo: MachineError naming the nearest)
TOP_KEYS = ("name", "kinematics", "spindle", "rotary", "linear", "part", "pivot_length")
ROTARY_KEYS = ("name", "axis", "point", "limits")
LINEAR_KEYS = ("X", "Y", "Z")
PART_KEYS = ("origin", "x", "z")
MACHINES_DIR = Path(__file__).resolve().parents[2] / "machines"
_ORTHO_TOL = 1e-6  # |x·z| accepted for the part frame (unit vectors)


def _turn(v, axis, angles):
    """:func:`~..geometry.vectors.rotate` in the rotaries' arithmetic (``scale_last``)."""
    return rotate(v, axis, angles, scale_last=True)


@dataclass(frozen=True)
class Rotary:
    """One rotary axis.

    name : str — NC address letter (A, B or C)
    axis : (3,) unit vector, machine coordinates at zero
    point : (3,) mm — a point of the axis line
    limits : (lo, hi) radians, or None for a continuous (endless) axis
    """

    name: str
    axis: np.ndarray
    point: np.ndarray
    limits: tuple[float, float] | None = None

    @property
    def continuous(self) -> bool:
        return self.limits is None

    def transform(self, angles, p) -> np.ndarray:
        """(n, 3) points p (n, 3) turned by ``angles`` (n,) about this axis line."""
        return _turn(np.asarray(p) - self.point, self.axis, angles) + self.point


@dataclass(frozen=True)
class Machine:
    """A 5-axis machine (module docstring for the meaning of every field).

    name : str; kinematics : one of :data:`KINEMATICS`; spindle : (3,) unit tool axis at zero;
    rotaries : (Rotary, Rotary) in chain order; linear : {"X": (lo, hi), ...} mm (missing
    axes unlimited); part_origin : (3,) mm; part_rotation : (3, 3) columns = the paths' x, y, z
    in machine coordinates; pivot_length : float mm (head kinds: spindle nose → last head
    pivot, for the travel limits); source : where it was read from.
    """

    name: str
    kinematics: str
    spindle: np.ndarray
    rotaries: tuple[Rotary, Rotary]
    linear: dict = field(default_factory=dict)
    part_origin: np.ndarray = field(default_factory=lambda: np.zeros(3))
    part_rotation: np.ndarray = field(default_factory=lambda: np.eye(3))
    pivot_length: float = 0.0
    source: str = ""

    @property
    def axis_names(self) -> tuple[str, str]:
        return (self.rotaries[0].name, self.rotaries[1].name)

    @property
    def part_is_identity(self) -> bool:
        """True when the paths' frame is the machine frame at zero (TCP posts need this)."""
        return bool(
            np.allclose(self.part_rotation, np.eye(3), atol=1e-12)
            and np.allclose(self.part_origin, 0.0, atol=1e-12)
        )

    @property
    def tables(self) -> tuple[bool, bool]:
        """Whether rotary 1, rotary 2 carry the part."""
        return {
            "table-table": (True, True),
            "head-table": (False, True),
            "head-head": (False, False),
        }[self.kinematics]

    # --- part ↔ machine at zero ---------------------------------------------------------
    def part_to_machine0(self, w) -> np.ndarray:
        """(n, 3) machine position, rotaries at 0, of path points w (n, 3)."""
        return np.asarray(w, dtype=np.float64) @ self.part_rotation.T + self.part_origin

    def machine0_to_part(self, m) -> np.ndarray:
        return (np.asarray(m, dtype=np.float64) - self.part_origin) @ self.part_rotation


def forward(machine: Machine, xyz, angles) -> tuple[np.ndarray, np.ndarray]:
    """Forward kinematics: joint positions → tool tip and axis in the paths' frame.

    Parameters
    ----------
    xyz : (n, 3) mm — programmed X, Y, Z (machine position of the tool tip)
    angles : (n, 2) radians — rotary 1, rotary 2 joint values

    Returns
    -------
    tip : (n, 3) mm and axis : (n, 3) unit, in the paths' (part) frame.
    Paper 002 Eq. (4): (P_W, O_W) = f(Q_M), here for any of the three kinds.
    """
    xyz = np.atleast_2d(np.asarray(xyz, dtype=np.float64))
    q = np.atleast_2d(np.asarray(angles, dtype=np.float64))
    r1, r2 = machine.rotaries
    s = machine.spindle
    kind = machine.kinematics
    if kind == "table-table":
        # m = T1 T2 m0  ⇒  m0 = T2⁻¹ T1⁻¹ m; the axis likewise
        m0 = r2.transform(-q[:, 1], r1.transform(-q[:, 0], xyz))
        a0 = _turn(_turn(s, r1.axis, -q[:, 0]), r2.axis, -q[:, 1])
    elif kind == "head-table":
        m0 = r2.transform(-q[:, 1], xyz)
        a0 = _turn(_turn(s, r1.axis, q[:, 0]), r2.axis, -q[:, 1])
    else:
        m0 = xyz
        a0 = _turn(_turn(s, r2.axis, q[:, 1]), r1.axis, q[:, 0])
    return machine.machine0_to_part(m0), a0 @ machine.part_rotation


def tip_to_machine(machine: Machine, tip, angles) -> np.ndarray:
    """(n, 3) programmed X, Y, Z of path tips (n, 3) at joints ``angles`` (n, 2) radians."""
    m0 = machine.part_to_machine0(np.atleast_2d(tip))
    q = np.atleast_2d(angles)
    r1, r2 = machine.rotaries
    if machine.kinematics == "table-table":
        return r1.transform(q[:, 0], r2.transform(q[:, 1], m0))
    if machine.kinematics == "head-table":
        return r2.transform(q[:, 1], m0)
    return m0


def machine_axis(machine: Machine, angles) -> np.ndarray:
    """(n, 3) tool axis in machine coordinates at joints ``angles`` (n, 2) radians."""
    q = np.atleast_2d(angles)
    r1, r2 = machine.rotaries
    s = machine.spindle
    if machine.kinematics == "table-table":
        return np.broadcast_to(s, (len(q), 3)).copy()
    if machine.kinematics == "head-table":
        return _turn(s, r1.axis, q[:, 0])
    return _turn(_turn(s, r2.axis, q[:, 1]), r1.axis, q[:, 0])


# --- reading ------------------------------------------------------------------------------
def known_presets() -> list[str]:
    """Names of the machine presets shipped in ``blisk_cam/machines``."""
    return preset_names(MACHINES_DIR)


def load_machine(name_or_path) -> Machine:
    """A preset name (``"ac-trunnion"``) or a path to a machine TOML → :class:`Machine`.

    Raises MachineError naming the problem (unknown preset: lists the known ones)."""
    data, path = read_preset_toml(name_or_path, MACHINES_DIR, "machine", MachineError)
    return machine_from_dict(data, source=str(path))


def _vec(d: dict, key: str, where: str, *, unit: bool = True, required: bool = True):
    if key not in d:
        if not required:
            return None
        raise MachineError(f"machine {where}: missing {key!r} (a 3-vector)")
    try:
        v = np.asarray(d[key], dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise MachineError(f"machine {where}: {key!r} must be 3 numbers, got {d[key]!r}") from err
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise MachineError(f"machine {where}: {key!r} must be 3 finite numbers, got {d[key]!r}")
    if unit:
        n = float(np.linalg.norm(v))
        if n < 1e-12:
            raise MachineError(f"machine {where}: {key!r} is the zero vector; give a direction")
        v = v / n
    return v


def _range(value, what: str, *, degrees: bool) -> tuple[float, float]:
    try:
        lo, hi = (float(x) for x in value)
    except (TypeError, ValueError) as err:
        raise MachineError(f"machine {what}: limits must be [min, max], got {value!r}") from err
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise MachineError(f"machine {what}: limits must be finite, got {value!r}")
    if lo >= hi:
        raise MachineError(
            f"machine {what}: limits reversed or empty ({lo:g} ≥ {hi:g}); write [min, max]"
        )
    return (math.radians(lo), math.radians(hi)) if degrees else (lo, hi)


def machine_from_dict(data: dict, source: str = "") -> Machine:
    """Validate a parsed machine TOML (module docstring) → :class:`Machine`."""
    where = Path(source).name if source else "description"
    check_known_keys(data, TOP_KEYS, f"machine {where}", MachineError)
    for sub, keys in (("linear", LINEAR_KEYS), ("part", PART_KEYS)):
        if sub in data:
            if not isinstance(data[sub], dict):
                raise MachineError(f"machine {where}: [{sub}] must be a table")
            check_known_keys(data[sub], keys, f"machine {where} [{sub}]", MachineError)
    kind = data.get("kinematics")
    if kind not in KINEMATICS:
        raise MachineError(
            f"machine {where}: unknown kinematics {kind!r}; use one of {', '.join(KINEMATICS)}"
        )
    spindle = _vec(data, "spindle", where)
    rot = data.get("rotary")
    if not isinstance(rot, list) or len(rot) != 2:
        raise MachineError(
            f"machine {where}: needs exactly two [[rotary]] tables in chain order, got "
            f"{0 if not isinstance(rot, list) else len(rot)}"
        )
    rotaries = []
    for i, r in enumerate(rot, 1):
        if not isinstance(r, dict):
            raise MachineError(f"machine {where}: rotary {i} must be a [[rotary]] table")
        check_known_keys(r, ROTARY_KEYS, f"machine {where} rotary {i}", MachineError)
        name = str(r.get("name", "")).upper()
        if name not in ("A", "B", "C"):
            raise MachineError(f"machine {where}: rotary {i} needs name A, B or C, got {name!r}")
        w = f"{where} rotary {i} ({name})"
        axis = _vec(r, "axis", w)
        point = _vec(r, "point", w, unit=False, required=False)
        limits = None if "limits" not in r else _range(r["limits"], w, degrees=True)
        rotaries.append(Rotary(name, axis, np.zeros(3) if point is None else point, limits))
    if rotaries[0].name == rotaries[1].name:
        raise MachineError(f"machine {where}: both rotaries are named {rotaries[0].name}")
    if np.linalg.norm(np.cross(rotaries[0].axis, rotaries[1].axis)) < 1e-6:
        raise MachineError(
            f"machine {where}: rotaries {rotaries[0].name} and {rotaries[1].name} have parallel "
            "axes; two parallel rotaries cannot orient the tool"
        )
    linear = {}
    for ax, lim in dict(data.get("linear", {})).items():
        if ax not in ("X", "Y", "Z"):
            raise MachineError(f"machine {where}: unknown linear axis {ax!r} (X, Y or Z)")
        linear[ax] = _range(lim, f"{where} linear {ax}", degrees=False)
    part = dict(data.get("part", {}))
    origin = _vec(part, "origin", f"{where} [part]", unit=False, required=False)
    px = _vec(part, "x", f"{where} [part]", required=False)
    pz = _vec(part, "z", f"{where} [part]", required=False)
    px = np.array([1.0, 0, 0]) if px is None else px
    pz = np.array([0, 0, 1.0]) if pz is None else pz
    if abs(float(px @ pz)) > _ORTHO_TOL:
        raise MachineError(
            f"machine {where}: [part] x and z are not orthogonal (angle "
            f"{math.degrees(math.acos(np.clip(px @ pz, -1, 1))):.4f}°)"
        )
    py = np.cross(pz, px)
    pivot = float(data.get("pivot_length", 0.0))
    if not math.isfinite(pivot) or pivot < 0:
        raise MachineError(f"machine {where}: pivot_length must be ≥ 0 mm, got {pivot}")
    return Machine(
        name=str(data.get("name", where)),
        kinematics=kind,
        spindle=spindle,
        rotaries=(rotaries[0], rotaries[1]),
        linear=linear,
        part_origin=np.zeros(3) if origin is None else origin,
        part_rotation=np.stack([px, py, pz], axis=1),
        pivot_length=pivot,
        source=source,
    )
