"""The paths JSON (ARCHITECTURE.md, "paths JSON — contract (version 1)").

``{"format": "blisk_cam.paths", "version": 1, "units": "mm", "axis": [...6], "cone1": [...4],
"cone2": [...4], "tool": {...}, "tolerances": {"cusp", "chord"[, "allowance"]}, "curves":
[{"s", "closed", "cc", "normal", "tip", "axis"}, ...]}``. Curves in machining order; closed
curves do not repeat their first point; full float precision (``repr`` round-trip of
float64). Readers ignore keys they do not know, so later versions can add fields without
breaking version-1 readers.

Fields added (still version 1; none of the above changed):

* ``"tool"`` — the full cutter (:meth:`..tool.cutter.Cutter.as_dict`: ``type``, ``radius``,
  ``corner_radius``, the DIN 66215 fields d, r, e, f, alpha, beta, h, shank/holder); a
  version-1 ``{"type": "ball", "radius": 6.0}`` still reads.
* per curve ``"move"`` — the move type name of every pose (``"cut"``, ``"link"``,
  ``"approach"``, ``"retract"``, ``"rapid"``: the motion that ends at the pose), ``"flags"`` —
  the pose flag bit mask (int per pose), ``"ratio"`` — only when the morph ratio varies along
  the pass (a spiral): every pose's.
* ``"move_types"`` — the list of move names; ``"flag_bits"`` — ``{name: bit}``.
* ``"program"`` (when the passes are linked) — every pose in machining order, links included:
  ``{"tip": [[x, y, z], ...], "axis": [...], "move": [names], "rapid": [bool],
  "curve": [index into "curves" or −1], "index": [pose index in that curve or −1],
  "flags": [int]}``.
* ``"profile1"``/``"profile2"`` — curved (LMRS) generatrices, see ``_generatrix_entries``.
* ``"operation"`` — the operation that made the path: ``"rough"`` for channel roughing
  (:mod:`..process.roughing`: its curves are the passes, ``cc`` = ``tip``, ``normal`` =
  ``axis``: no contact point, ``s`` the level index), ``"hub-finish"``, ``"fillet-finish"``;
  absent for blade finishing, so those paths are written as before.
* ``"warnings"`` — ``ToolPath.warnings``, a list of strings for the user (e.g. zero cutting
  speed); absent when there are none, so a path without warnings is written as before.
* collision (only when the path was checked, :mod:`..collision.avoid`): per curve ``"collision":
  {"status": [0 clear | 1 corrected | 2 unresolved per pose], "clearance": [mm per pose],
  "rotation_deg": [degrees per pose from the planned axis]}``; in ``"program"`` the arrays
  ``"collision_status"``, ``"clearance"`` and ``"rotation_deg"`` (every row, links
  included; re-routed links, :mod:`..collision.reroute`, are rows like any other); top level
  ``"collision"`` — the summary (checked poses, colliding before, corrected, unresolved, min
  clearance, obstacles, assembly, safety, mode), and ``"tool" → "assembly"``
  (``{"flute_length", "profile": [[z, r], ...], "safety"}``). Absent when not checked, so
  unchecked paths write exactly what they did before.
* ``"tolerances" → "allowance"`` — mm of stock the path leaves (semi-finishing,
  ``ToolPath.allowance``): the CC points lie on the blade offset outward by it and the tips
  are the real cutter's touching that offset surface. Absent for a finishing path (0).
"""

from __future__ import annotations

import json
import math
import os

import numpy as np

from ..errors import BliskCamError
from ..files import write_atomic
from ..geometry.axis import Axis
from ..kernels.float_text import json_float_array
from ..part.cones import Cone
from ..part.profiles import Profile
from ..runtime import map_tasks, workers
from ..tool.cutter import Cutter
from .types import FLAG_NAMES, MOVE_NAMES, MOVE_RAPID, PassCurve, Program, ToolPath, move_codes

__all__ = [
    "FORMAT",
    "VERSION",
    "path_to_dict",
    "path_from_dict",
    "write_paths_json",
    "paths_json_text",
    "read_paths_json",
]

FORMAT = "blisk_cam.paths"
VERSION = 1


def path_to_dict(path: ToolPath) -> dict:
    """The JSON-ready dict of a tool path (floats as Python floats, full precision)."""
    return _path_dict(path, _float_list)


def _float_list(a) -> list:
    """A float array as (nested) lists of Python floats."""
    return np.asarray(a, dtype=float).tolist()


def _int_list(a) -> list:
    """``[int(x) for x in a]`` of a (k,) array of codes, counts or indices: the same Python
    ints, by numpy for an integer or bool array (a program of 15k rows: ~5 ms of the writer's
    loops in one pass)."""
    a = np.asarray(a)
    if a.dtype.kind in "biu":
        return a.astype(np.int64).tolist()
    return [int(x) for x in a]


def _path_dict(path: ToolPath, floats) -> dict:
    """:func:`path_to_dict` with each float array as ``floats(array)`` gives it."""
    return {
        "format": FORMAT,
        "version": VERSION,
        **({} if path.operation is None else {"operation": str(path.operation)}),
        "units": "mm",
        "axis": path.axis.as_list(),
        **_generatrix_entries(path.cone1, path.cone2),
        "tool": _tool_dict(path),
        "tolerances": {"cusp": float(path.cusp), "chord": float(path.chord),
                       # written only when stock is left, so finishing files stay as before
                       **({"allowance": float(path.allowance)} if path.allowance else {})},
        "curves": [
            {
                "s": float(c.s),
                "closed": bool(c.closed),
                "cc": floats(c.cc),
                "normal": floats(c.normal),
                "tip": floats(c.tip),
                "axis": floats(c.axis),
                **_curve_extras(c, floats),
            }
            for c in path.curves
        ],
        "move_types": list(MOVE_NAMES),
        "flag_bits": {name: bit for bit, name in FLAG_NAMES.items()},
        **({} if path.program is None else {"program": _program_to_dict(path.program, floats)}),
        **({} if path.collision is None else {"collision": jsonable(path.collision)}),
        **({} if path.verify is None else {"verify": jsonable(path.verify)}),
        # JSON has no infinity or NaN: such figures are left out
        "stats": {
            k: v
            for k, v in path.stats.items()
            if isinstance(v, (int, float, str, list))
            and not (isinstance(v, float) and not math.isfinite(v))
        },
        **({"warnings": [str(w) for w in path.warnings]} if path.warnings else {}),
    }


def path_from_dict(d: dict) -> ToolPath:
    """Read a paths dict (version 1 or a later one that only added fields), validated against
    the contract: every number finite, every array of its shape (rows of 3 for points and
    axes, one entry per pose for the per-pose lists), the version a whole number ≥ 1.
    BliskCamError naming the field and the row (``curves[3].tip row 17 is not finite``)."""
    if not isinstance(d, dict) or d.get("format") != FORMAT:
        raise BliskCamError(f"not a Blisk CAM paths file (format is not {FORMAT!r})")
    if (not isinstance(d.get("version"), int) or isinstance(d.get("version"), bool)
            or d["version"] < 1):
        raise BliskCamError(f"paths file has an invalid version {d.get('version')!r} (a whole "
                            "number ≥ 1 is expected)")
    try:
        ax = _numbers(d["axis"], "axis", 6)
        curves = [
            PassCurve(
                s=_number(c["s"], f"curves[{i}].s"),
                closed=bool(c["closed"]),
                cc=_rows(c["cc"], f"curves[{i}].cc"),
                normal=_rows(c["normal"], f"curves[{i}].normal", len(c["cc"])),
                tip=_rows(c["tip"], f"curves[{i}].tip", len(c["cc"])),
                axis=_rows(c["axis"], f"curves[{i}].axis", len(c["cc"])),
                **_read_curve_extras(c, i),
            )
            for i, c in enumerate(_list(d["curves"], "curves"))
        ]
        tool = d.get("tool", {"type": "ball", "radius": 0.0})
        tol = d["tolerances"]
        return ToolPath(
            axis=Axis(tuple(ax[:3]), tuple(ax[3:6])),
            cone1=_read_generatrix(d, 1),
            cone2=_read_generatrix(d, 2),
            tool=Cutter.from_dict(tool),
            cusp=_number(tol["cusp"], "tolerances.cusp", positive=True),
            chord=_number(tol["chord"], "tolerances.chord", positive=True),
            allowance=_allowance(tol),
            curves=curves,
            stats=dict(d.get("stats", {})),
            program=_program_from_dict(d["program"]) if "program" in d else None,
            warnings=_read_warnings(d),
            collision=dict(d["collision"]) if isinstance(d.get("collision"), dict) else None,
            verify=dict(d["verify"]) if isinstance(d.get("verify"), dict) else None,
            operation=str(d["operation"]) if isinstance(d.get("operation"), str) else None,
        )
    except (KeyError, TypeError, ValueError, IndexError) as err:
        if isinstance(err, BliskCamError):
            raise
        raise BliskCamError(f"paths file is incomplete or malformed: {err}") from err


# --- validation at the door (issue 28): finite numbers, shapes, the field and row named ---
def _allowance(tol: dict) -> float:
    """``tolerances.allowance`` (mm ≥ 0; absent: 0, a finishing path)."""
    if "allowance" not in tol:
        return 0.0
    a = _number(tol["allowance"], "tolerances.allowance")
    if a < 0:
        raise BliskCamError(f"tolerances.allowance must be ≥ 0 mm, got {a:g}")
    return a


def _list(value, name: str) -> list:
    if not isinstance(value, list):
        raise BliskCamError(f"paths file: {name} must be a list, got {type(value).__name__}")
    return value


def _number(value, name: str, *, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise BliskCamError(f"paths file: {name} must be a number, got {value!r}")
    x = float(value)
    if not math.isfinite(x) or (positive and x <= 0):
        raise BliskCamError(f"paths file: {name} must be a finite number"
                            + (" > 0" if positive else "") + f", got {value!r}")
    return x


def _numbers(value, name: str, n: int) -> list[float]:
    if not isinstance(value, list) or len(value) != n:
        raise BliskCamError(f"paths file: {name} must be a list of {n} numbers, got {value!r}")
    return [_number(v, f"{name}[{k}]") for k, v in enumerate(value)]


def _rows(value, name: str, count: int | None = None, cols: int = 3) -> np.ndarray:
    """(k, cols) float64 of a list of rows; BliskCamError naming ``name`` and the row when a
    row is not ``cols`` numbers or not finite, or when ``count`` rows were expected."""
    _list(value, name)
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        a = None
    if a is None or (a.size and (a.ndim != 2 or a.shape[1] != cols)):
        for r, row in enumerate(value):
            if not isinstance(row, list) or len(row) != cols:
                raise BliskCamError(f"paths file: {name} row {r} must be {cols} numbers, got "
                                    f"{row!r}")
        raise BliskCamError(f"paths file: {name} must be rows of {cols} numbers")
    a = a.reshape(-1, cols)
    bad = ~np.isfinite(a).all(axis=1)
    if bad.any():
        r = int(np.flatnonzero(bad)[0])
        raise BliskCamError(f"paths file: {name} row {r} is not finite ({a[r].tolist()}); "
                            "every coordinate must be a finite number (mm)")
    if count is not None and len(a) != count:
        raise BliskCamError(f"paths file: {name} has {len(a)} rows for {count} poses")
    return a


def _values(value, name: str, count: int) -> np.ndarray:
    """(count,) float64 of a per-pose list of finite numbers (field and row named)."""
    _list(value, name)
    if len(value) != count:
        raise BliskCamError(f"paths file: {name} has {len(value)} entries for {count} poses")
    try:
        a = np.asarray(value, dtype=np.float64).reshape(count)
    except (TypeError, ValueError):
        raise BliskCamError(f"paths file: {name} must be one number per pose") from None
    bad = ~np.isfinite(a)
    if bad.any():
        r = int(np.flatnonzero(bad)[0])
        raise BliskCamError(f"paths file: {name} row {r} is not finite ({value[r]!r})")
    return a


def write_paths_json(path: ToolPath, filename, *, overwrite: bool = True) -> str:
    """Write the JSON; written to a temporary file first and renamed, so a failure never
    leaves a half-written file in place of a good one. Returns the file name."""
    filename = os.fspath(filename)
    if not overwrite and os.path.exists(filename):
        raise BliskCamError(f"{filename} exists; choose another name or allow overwriting")
    write_atomic(filename, paths_json_text(path))
    return filename


def paths_json_text(path: ToolPath) -> str:
    """The text of the paths JSON: ``json.dumps(path_to_dict(path), allow_nan=False)``, byte
    for byte. The float arrays (~150k floats at 1M triangles, ~0.07 s of the encoder) are
    written by the compiled kernel (:func:`..kernels.float_text.json_float_array`, the same
    bytes) into the frame ``json.dumps`` makes of the rest, where array k stands as the
    string NUL, k, NUL until then; without the kernel, or when a value is not finite or
    another string of the file holds a NUL (never, but then the placeholders could not be
    told apart), the whole dict goes through ``json.dumps``."""
    if json_float_array(np.zeros(0)) is None:  # the numpy kernels
        return json.dumps(path_to_dict(path), allow_nan=False)
    arrays = []

    def placeholder(a) -> str:
        arrays.append(a)
        return f"\x00{len(arrays) - 1}\x00"

    parts = json.dumps(_path_dict(path, placeholder), allow_nan=False).split('"\\u0000')
    texts = _float_texts(arrays)
    out = [parts[0]]
    for k, part in enumerate(parts[1:]):
        head = f"{k}\\u0000\""
        if k >= len(texts) or texts[k] is None or not part.startswith(head):
            return json.dumps(path_to_dict(path), allow_nan=False)
        out += [texts[k], part[len(head):]]
    if len(parts) != len(arrays) + 1:
        return json.dumps(path_to_dict(path), allow_nan=False)
    return "".join(out)


def _float_texts(arrays) -> list:
    """``[json_float_array(a) for a in arrays]``, the arrays cut into one run of about equal
    floats per thread of :func:`..runtime.parallel`, formatted side by side (the kernel
    formats without the GIL: ~0.02 s of a 1M-triangle write on one core, ~0.045 s for
    Rotor 37's 280k floats)."""
    n = min(workers(), len(arrays))
    if n < 2:
        return [json_float_array(a) for a in arrays]
    ends = np.cumsum([np.size(a) for a in arrays])
    cuts = np.searchsorted(ends, ends[-1] * np.arange(1, n) / n) + 1  # a run ends past it
    runs = [r for r in np.split(np.arange(len(arrays)), cuts) if len(r)]
    done = map_tasks(lambda run: [json_float_array(arrays[i]) for i in run], runs)
    return [t for texts in done for t in texts]


def read_paths_json(filename) -> ToolPath:
    with open(os.fspath(filename), encoding="utf-8") as fh:
        try:
            d = json.load(fh)
        except json.JSONDecodeError as err:
            raise BliskCamError(f"{filename} is not valid JSON: {err}") from err
    return path_from_dict(d)


# --- profile generatrices (LMRS, paper 001 §4.2) ----------------------------------------
def _generatrix_entries(cone1, cone2) -> dict:
    """``"cone1"``/``"cone2"`` as version 1 has them; a :class:`..part.profiles.Profile` is
    written there as its least-squares straight cone (so version-1 readers still see a cone) and in
    full as
    ``"profile1"``/``"profile2"``: ``[[r, z], ...]`` (mm)."""
    out = {}
    for k, g in ((1, cone1), (2, cone2)):
        out[f"cone{k}"] = (g.to_cone() if isinstance(g, Profile) else g).as_list()
    for k, g in ((1, cone1), (2, cone2)):
        if isinstance(g, Profile):
            out[f"profile{k}"] = g.as_list()
    return out


def _read_generatrix(d: dict, k: int):
    """Generatrix ``k`` (1 or 2) of a paths dict: ``"profile<k>"`` when present, else
    ``"cone<k>"``."""
    if d.get(f"profile{k}") is not None:
        return Profile.from_list(_rows(d[f"profile{k}"], f"profile{k}", cols=2).tolist())
    return Cone.from_list(_numbers(d[f"cone{k}"], f"cone{k}", 4))


# --- moves, flags, program (issue #4) ----------------------------------------------------
def _read_warnings(d: dict) -> list[str]:
    w = d.get("warnings", [])
    if not isinstance(w, list) or not all(isinstance(x, str) for x in w):
        raise BliskCamError('paths file: "warnings" must be a list of strings')
    return list(w)


def _curve_extras(c: PassCurve, floats=_float_list) -> dict:
    out = {"move": [MOVE_NAMES[m] for m in _int_list(c.move)], "flags": _int_list(c.flags)}
    if c.ratio is not None:
        out["ratio"] = floats(c.ratio)
    if c.collision is not None:
        out["collision"] = {
            "status": _int_list(c.collision["status"]),
            "clearance": floats(c.collision["clearance"]),
            # the degrees read from a file are written back as they were (exact round trip)
            "rotation_deg": floats(c.collision["rotation_deg"])
            if "rotation_deg" in c.collision
            else floats(np.degrees(np.asarray(c.collision["rotation"], float))),
        }
    return out


def _tool_dict(path: ToolPath) -> dict:
    out = path.tool.as_dict()
    asm = (path.collision or {}).get("assembly")
    if asm is not None:
        out["assembly"] = asm
    return out


def jsonable(x):
    """``x`` as plain JSON values: dicts with str keys, lists for tuples and arrays, Python
    bools, ints and floats; non-finite floats become None (JSON has no NaN or inf)."""
    if isinstance(x, dict):
        return {str(k): jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple, np.ndarray)):
        return [jsonable(v) for v in x]
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    if isinstance(x, (int, np.integer)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        return float(x) if math.isfinite(x) else None
    return x


def _read_curve_extras(c: dict, i: int = 0) -> dict:
    k = len(c["cc"])
    out = {}
    for key in ("move", "flags", "ratio"):
        if key in c and len(c[key]) != k:
            raise BliskCamError(
                f"paths file: curves[{i}].{key} has {len(c[key])} entries for {k} poses"
            )
    if "move" in c:
        out["move"] = move_codes(c["move"])
    if "flags" in c:
        out["flags"] = np.asarray(c["flags"], dtype=np.uint8)
    if "ratio" in c:
        out["ratio"] = _values(c["ratio"], f"curves[{i}].ratio", k)
    if isinstance(c.get("collision"), dict):
        col = c["collision"]
        for key in ("status", "clearance", "rotation_deg"):
            if len(col[key]) != k:
                raise BliskCamError(f"paths file: curves[{i}].collision.{key} has "
                                    f"{len(col[key])} entries for {k} poses")
        rot = _values(col["rotation_deg"], f"curves[{i}].collision.rotation_deg", k)
        out["collision"] = {
            "status": np.asarray(col["status"], dtype=np.int8),
            "clearance": _values(col["clearance"], f"curves[{i}].collision.clearance", k),
            "rotation": np.radians(rot),
            "rotation_deg": rot,
        }
    return out


def _program_to_dict(p: Program, floats=_float_list) -> dict:
    return {
        "tip": floats(p.tip),
        "axis": floats(p.axis),
        "move": [MOVE_NAMES[m] for m in _int_list(p.move)],
        "rapid": [m == MOVE_RAPID for m in _int_list(p.move)],
        "curve": _int_list(p.curve),
        "index": _int_list(p.index),
        "flags": _int_list(p.flags),
        **({} if p.collision_status is None else {
            "collision_status": _int_list(p.collision_status),
            "clearance": floats(p.clearance)}),
        **({} if p.collision_status is None or p.rotation_deg is None else {
            "rotation_deg": floats(p.rotation_deg)}),
    }


def _program_from_dict(d: dict) -> Program:
    tip = _rows(d["tip"], "program.tip")
    m = len(tip)
    for key in ("axis", "move", "curve", "index", "flags", "collision_status", "clearance",
                "rotation_deg"):
        if key not in d:
            continue
        if len(d[key]) != m:
            raise BliskCamError(
                f"paths file: program.{key} has {len(d[key])} entries for {m} poses"
            )
    return Program(
        tip=tip,
        axis=_rows(d["axis"], "program.axis", m),
        move=move_codes(d["move"]),
        curve=np.asarray(d["curve"], dtype=np.int64),
        index=np.asarray(d["index"], dtype=np.int64),
        flags=np.asarray(d["flags"], dtype=np.uint8),
        collision_status=(np.asarray(d["collision_status"], dtype=np.int8)
                          if "collision_status" in d else None),
        clearance=_values(d["clearance"], "program.clearance", m) if "clearance" in d else None,
        rotation_deg=(_values(d["rotation_deg"], "program.rotation_deg", m)
                      if "rotation_deg" in d else None),
    )
