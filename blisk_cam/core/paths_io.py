"""The paths JSON (ARCHITECTURE.md, "paths JSON — contract (version 1)").

``{"format": "blisk_cam.paths", "version": 1, "units": "mm", "axis": [...6], "cone1": [...4],
"cone2": [...4], "tool": {...}, "tolerances": {"cusp", "chord"}, "curves": [{"s", "closed",
"cc", "normal", "tip", "axis"}, ...]}``. Curves in machining order; closed curves do not repeat
their first point; full float precision (``repr`` round-trip of float64). Readers ignore keys
they do not know, so later versions can add fields without breaking version-1 readers.
"""

from __future__ import annotations

import json
import os

import numpy as np

from .cones import Axis, Cone
from .errors import BliskCamError
from .toolpath import BallTool, PassCurve, ToolPath

__all__ = ["FORMAT", "VERSION", "path_to_dict", "path_from_dict", "write_paths_json", "read_paths_json"]

FORMAT = "blisk_cam.paths"
VERSION = 1


def path_to_dict(path: ToolPath) -> dict:
    """The JSON-ready dict of a tool path (floats as Python floats, full precision)."""
    return {
        "format": FORMAT,
        "version": VERSION,
        "units": "mm",
        "axis": path.axis.as_list(),
        "cone1": path.cone1.as_list(),
        "cone2": path.cone2.as_list(),
        "tool": path.tool.as_dict(),
        "tolerances": {"cusp": float(path.cusp), "chord": float(path.chord)},
        "curves": [
            {
                "s": float(c.s),
                "closed": bool(c.closed),
                "cc": np.asarray(c.cc, dtype=float).tolist(),
                "normal": np.asarray(c.normal, dtype=float).tolist(),
                "tip": np.asarray(c.tip, dtype=float).tolist(),
                "axis": np.asarray(c.axis, dtype=float).tolist(),
            }
            for c in path.curves
        ],
        "stats": {k: v for k, v in path.stats.items() if isinstance(v, (int, float, str, list))},
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
                s=float(c["s"]), closed=bool(c["closed"]),
                cc=np.asarray(c["cc"], dtype=np.float64).reshape(-1, 3),
                normal=np.asarray(c["normal"], dtype=np.float64).reshape(-1, 3),
                tip=np.asarray(c["tip"], dtype=np.float64).reshape(-1, 3),
                axis=np.asarray(c["axis"], dtype=np.float64).reshape(-1, 3),
            )
            for c in d["curves"]
        ]
        tool = d.get("tool", {})
        return ToolPath(
            axis=Axis(tuple(ax[:3]), tuple(ax[3:6])),
            cone1=Cone.from_list(d["cone1"]), cone2=Cone.from_list(d["cone2"]),
            tool=BallTool(float(tool.get("radius", 0.0)), str(tool.get("type", "ball"))),
            cusp=float(d["tolerances"]["cusp"]), chord=float(d["tolerances"]["chord"]),
            curves=curves, stats=dict(d.get("stats", {})),
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
    with open(tmp, "w", encoding="utf-8") as fh:
        json.dump(path_to_dict(path), fh, allow_nan=False)
    os.replace(tmp, filename)
    return filename


def read_paths_json(filename) -> ToolPath:
    with open(os.fspath(filename), encoding="utf-8") as fh:
        try:
            d = json.load(fh)
        except json.JSONDecodeError as err:
            raise BliskCamError(f"{filename} is not valid JSON: {err}") from err
    return path_from_dict(d)
