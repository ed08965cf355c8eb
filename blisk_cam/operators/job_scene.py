"""The job of the Operations panel (issue 24): the scene's settings as the tables of a job file
(``core.process.job``), so Generate All runs the very job that Export Job writes and
``blisk_cam process`` reads.

Option values are stored per operation as text (one row per key the kind declares: the value
as written in a job file, a TOML value), read here with the TOML grammar: a number, a word
(quoted or bare), a list ``[170, -25, 185, 35]``, true/false; empty rows are left out (the
kind's default). One text per key round-trips exactly to the job file and holds every type an
option takes (numbers, whole numbers, words, cones as lists) without a property per type.
"""

from __future__ import annotations

import os
import re
import tomllib
from pathlib import Path

import bpy

from ..core.errors import BliskCamError

__all__ = ["JOB_NAME", "job_data", "job_path", "option_value"]

#: how messages name the panel's job (as a job file's name)
JOB_NAME = "Operations panel"
_WORD = re.compile(r"^[A-Za-z_][A-Za-z0-9_-]*$")


def option_value(text: str, where: str, key: str):
    """The value of an option row (module docstring); BliskCamError naming ``where`` and the
    key."""
    text = text.strip()
    if text in ("true", "false"):
        return text == "true"
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        if _WORD.match(text):
            return text  # a bare word: the kind's choices (radial, channel, check …)
        raise BliskCamError(f"{where} key {key!r}: cannot read {text!r}: give a number, a word "
                            "or a list [a, b, ...]") from None


def job_path() -> Path:
    """The path the panel's job is named by; relative files are taken from the .blend's
    folder (the current folder for an unsaved file)."""
    folder = bpy.path.abspath("//") if bpy.data.filepath else os.getcwd()
    return Path(folder) / JOB_NAME


def _mm(x) -> float:
    """A float property's value as typed: Blender keeps single precision (0.3 is stored as
    0.30000001192…), seven significant digits give the number back."""
    return float(f"{float(x):.7g}")


def _tool(t) -> dict:
    out = {"number": int(t.number), "type": t.type, "diameter": _mm(t.diameter),
           "flutes": int(t.flutes)}
    if t.type == "bull":
        out["corner_radius"] = _mm(t.corner_radius)
    if t.flute_length > 0:
        out["flute_length"] = _mm(t.flute_length)
    if t.stick_out > 0:
        out["stick_out"] = _mm(t.stick_out)
    if t.holder.strip():
        out["holder"] = t.holder.strip()
    return out


def job_data(scene) -> dict:
    """The job file's tables of the scene's Operations panel (with the Stock panel's blank and
    resolution and the Machine & NC panel's machine and post). BliskCamError on what cannot be
    written in a job (a blank mesh object, an unreadable option value)."""
    s = scene.blisk_cam
    part = {}
    if s.job_part_source == "DEMO":
        part["source"] = "demo"
        part["demo"] = {"resolution": _mm(s.job_demo_resolution)}
    else:
        if not s.job_part_file:
            raise BliskCamError("No part file: choose the part's mesh file in the Operations "
                                "panel")
        part["source"] = bpy.path.abspath(s.job_part_file)
        if s.job_hub_profile:
            part["hub_profile"] = bpy.path.abspath(s.job_hub_profile)
        if s.blade_count < 1:
            raise BliskCamError("Blade Count is not set: set the Blade Count (the blades on the "
                                "blisk) in the Operations panel")
        part["blade_count"] = int(s.blade_count)
    if s.job_material != "NONE":
        part["material"] = s.job_material
    blank = {"ALLOWANCE": lambda: f"allowance:{_mm(s.stock_allowance):g}",
             "ENVELOPE": lambda: f"envelope:{_mm(s.stock_margin):g}",
             "PROFILE": lambda: bpy.path.abspath(s.stock_profile)}.get(s.stock_blank)
    if blank is None:
        raise BliskCamError("Blank Mesh is not a job's blank: the job reads a blank from a file; "
                            "choose Part + Allowance, Envelope + Margin or Profile CSV in the "
                            "Stock panel")
    stock = {"blank": blank(), "resolution": _mm(s.stock_resolution)}
    if s.stock_gouge_tolerance > 0:
        stock["gouge_tolerance"] = _mm(s.stock_gouge_tolerance)
    machine = {"name": bpy.path.abspath(s.machine_file) if s.machine == "FILE" else s.machine,
               "posts": [s.post]}
    ops = []
    for k, o in enumerate(s.operations):
        where = f"job {JOB_NAME} operation {k + 1} ({o.name!r})"
        d = {"name": o.name, "kind": o.kind, "tool": int(o.tool)}
        if not o.enabled:
            d["enabled"] = False
        for row in o.options:
            if row.value.strip():
                d[row.key] = option_value(row.value, where, row.key)
        ops.append(d)
    return {"part": part, "stock": stock, "machine": machine,
            "tool": [_tool(t) for t in s.job_tools], "operation": ops}
