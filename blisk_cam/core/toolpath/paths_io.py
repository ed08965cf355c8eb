"""The paths JSON (ARCHITECTURE.md, "paths JSON — contract (version 1)").

``{"format": "blisk_cam.paths", "version": 1, "units": "mm", "axis": [...6], "cone1": [...4],
"cone2": [...4], "tool": {...}, "tolerances": {"cusp", "chord"}, "curves": [{"s", "closed",
"cc", "normal", "tip", "axis"}, ...]}``. Curves in machining order; closed curves do not repeat
their first point; full float precision (``repr`` round-trip of float64). Readers ignore keys
they do not know, so later versions can add fields without breaking version-1 readers.

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
"""

from __future__ import annotations

import json
import math
import os

import numpy as np

from ..errors import BliskCamError
from ..geometry.axis import Axis
from ..part.cones import Cone
from ..part.profiles import Profile
from ..tool.cutter import Cutter
from .types import FLAG_NAMES, MOVE_NAMES, MOVE_RAPID, PassCurve, Program, ToolPath, move_codes

__all__ = [
    "FORMAT",
    "VERSION",
    "path_to_dict",
    "path_from_dict",
    "write_paths_json",
    "read_paths_json",
]

FORMAT = "blisk_cam.paths"
VERSION = 1


def path_to_dict(path: ToolPath) -> dict:
    """The JSON-ready dict of a tool path (floats as Python floats, full precision)."""
    return {
        "format": FORMAT,
        "version": VERSION,
        "units": "mm",
        "axis": path.axis.as_list(),
        **_generatrix_entries(path.cone1, path.cone2),
        "tool": _tool_dict(path),
        "tolerances": {"cusp": float(path.cusp), "chord": float(path.chord)},
        "curves": [
            {
                "s": float(c.s),
                "closed": bool(c.closed),
                "cc": np.asarray(c.cc, dtype=float).tolist(),
                "normal": np.asarray(c.normal, dtype=float).tolist(),
                "tip": np.asarray(c.tip, dtype=float).tolist(),
                "axis": np.asarray(c.axis, dtype=float).tolist(),
                **_curve_extras(c),
            }
            for c in path.curves
        ],
        "move_types": list(MOVE_NAMES),
        "flag_bits": {name: bit for bit, name in FLAG_NAMES.items()},
        **({} if path.program is None else {"program": _program_to_dict(path.program)}),
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
    """Read a paths dict (version 1 or a later one that only added fields)."""
    if not isinstance(d, dict) or d.get("format") != FORMAT:
        raise BliskCamError(f"not a Blisk CAM paths file (format is not {FORMAT!r})")
    if not isinstance(d.get("version"), int) or d["version"] < 1:
        raise BliskCamError(f"paths file has an invalid version {d.get('version')!r}")
    try:
        ax = d["axis"]
        curves = [
            PassCurve(
                s=float(c["s"]),
                closed=bool(c["closed"]),
                cc=np.asarray(c["cc"], dtype=np.float64).reshape(-1, 3),
                normal=np.asarray(c["normal"], dtype=np.float64).reshape(-1, 3),
                tip=np.asarray(c["tip"], dtype=np.float64).reshape(-1, 3),
                axis=np.asarray(c["axis"], dtype=np.float64).reshape(-1, 3),
                **_read_curve_extras(c),
            )
            for c in d["curves"]
        ]
        tool = d.get("tool", {"type": "ball", "radius": 0.0})
        return ToolPath(
            axis=Axis(tuple(ax[:3]), tuple(ax[3:6])),
            cone1=_read_generatrix(d, 1),
            cone2=_read_generatrix(d, 2),
            tool=Cutter.from_dict(tool),
            cusp=float(d["tolerances"]["cusp"]),
            chord=float(d["tolerances"]["chord"]),
            curves=curves,
            stats=dict(d.get("stats", {})),
            program=_program_from_dict(d["program"]) if "program" in d else None,
            warnings=_read_warnings(d),
            collision=dict(d["collision"]) if isinstance(d.get("collision"), dict) else None,
            verify=dict(d["verify"]) if isinstance(d.get("verify"), dict) else None,
        )
    except (KeyError, TypeError, ValueError, IndexError) as err:
        raise BliskCamError(f"paths file is incomplete or malformed: {err}") from err


def write_paths_json(path: ToolPath, filename, *, overwrite: bool = True) -> str:
    """Write the JSON; written to a temporary file first and renamed, so a failure never
    leaves a half-written file in place of a good one. Returns the file name."""
    filename = os.fspath(filename)
    if not overwrite and os.path.exists(filename):
        raise BliskCamError(f"{filename} exists; choose another name or allow overwriting")
    tmp = filename + ".tmp"
    try:
        text = json.dumps(path_to_dict(path), allow_nan=False)
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(text)
        os.replace(tmp, filename)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise
    return filename


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
        return Profile.from_list(d[f"profile{k}"])
    return Cone.from_list(d[f"cone{k}"])


# --- moves, flags, program (issue #4) ----------------------------------------------------
def _read_warnings(d: dict) -> list[str]:
    w = d.get("warnings", [])
    if not isinstance(w, list) or not all(isinstance(x, str) for x in w):
        raise BliskCamError('paths file: "warnings" must be a list of strings')
    return list(w)


def _curve_extras(c: PassCurve) -> dict:
    out = {"move": [MOVE_NAMES[int(m)] for m in c.move], "flags": [int(x) for x in c.flags]}
    if c.ratio is not None:
        out["ratio"] = np.asarray(c.ratio, dtype=float).tolist()
    if c.collision is not None:
        out["collision"] = {
            "status": [int(x) for x in c.collision["status"]],
            "clearance": np.asarray(c.collision["clearance"], dtype=float).tolist(),
            # the degrees read from a file are written back as they were (exact round trip)
            "rotation_deg": np.asarray(c.collision["rotation_deg"], float).tolist()
            if "rotation_deg" in c.collision
            else np.degrees(np.asarray(c.collision["rotation"], float)).tolist(),
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


def _read_curve_extras(c: dict) -> dict:
    k = len(c["cc"])
    out = {}
    for key in ("move", "flags", "ratio"):
        if key in c and len(c[key]) != k:
            raise BliskCamError(
                f"paths file: a curve's {key!r} has {len(c[key])} entries for {k} poses"
            )
    if "move" in c:
        out["move"] = move_codes(c["move"])
    if "flags" in c:
        out["flags"] = np.asarray(c["flags"], dtype=np.uint8)
    if "ratio" in c:
        out["ratio"] = np.asarray(c["ratio"], dtype=np.float64)
    if isinstance(c.get("collision"), dict):
        col = c["collision"]
        for key in ("status", "clearance", "rotation_deg"):
            if len(col[key]) != k:
                raise BliskCamError(f"paths file: a curve's collision {key!r} has "
                                    f"{len(col[key])} entries for {k} poses")
        out["collision"] = {
            "status": np.asarray(col["status"], dtype=np.int8),
            "clearance": np.asarray(col["clearance"], dtype=np.float64),
            "rotation": np.radians(np.asarray(col["rotation_deg"], dtype=np.float64)),
            "rotation_deg": np.asarray(col["rotation_deg"], dtype=np.float64),
        }
    return out


def _program_to_dict(p: Program) -> dict:
    return {
        "tip": np.asarray(p.tip, dtype=float).tolist(),
        "axis": np.asarray(p.axis, dtype=float).tolist(),
        "move": [MOVE_NAMES[int(m)] for m in p.move],
        "rapid": [bool(m == MOVE_RAPID) for m in p.move],
        "curve": [int(x) for x in p.curve],
        "index": [int(x) for x in p.index],
        "flags": [int(x) for x in p.flags],
        **({} if p.collision_status is None else {
            "collision_status": [int(x) for x in p.collision_status],
            "clearance": np.asarray(p.clearance, dtype=float).tolist()}),
        **({} if p.collision_status is None or p.rotation_deg is None else {
            "rotation_deg": np.asarray(p.rotation_deg, dtype=float).tolist()}),
    }


def _program_from_dict(d: dict) -> Program:
    tip = np.asarray(d["tip"], dtype=np.float64).reshape(-1, 3)
    m = len(tip)
    for key in ("axis", "move", "curve", "index", "flags", "collision_status", "clearance",
                "rotation_deg"):
        if key not in d:
            continue
        if len(d[key]) != m:
            raise BliskCamError(
                f"paths file: program {key!r} has {len(d[key])} entries for {m} poses"
            )
    return Program(
        tip=tip,
        axis=np.asarray(d["axis"], dtype=np.float64).reshape(-1, 3),
        move=move_codes(d["move"]),
        curve=np.asarray(d["curve"], dtype=np.int64),
        index=np.asarray(d["index"], dtype=np.int64),
        flags=np.asarray(d["flags"], dtype=np.uint8),
        collision_status=(np.asarray(d["collision_status"], dtype=np.int8)
                          if "collision_status" in d else None),
        clearance=np.asarray(d["clearance"], dtype=np.float64) if "clearance" in d else None,
        rotation_deg=(np.asarray(d["rotation_deg"], dtype=np.float64)
                      if "rotation_deg" in d else None),
    )
