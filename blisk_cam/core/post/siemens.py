"""Siemens 840D sl with TRAORI and tool-orientation vectors (ORIWKS: orientation in the
workpiece frame).

X Y Z are the paths' tip coordinates in G54 at the part origin with the part's axes;
A3= B3= C3= the unit tool axis — all three components in every block, because the control
reads a missing one as 0 (paper 002 §4.2: the blisk was cut on a double-turntable machine
with a Siemens 840D sl).

Blades: when the blisk axis is the paths' z axis and the innermost table rotary, blade 0 is
written once as a program section repeated with the blade number ``_BLADE`` as parameter and
the programmable frame ``ROT Z=_BLADE*pitch`` (under ORIWKS the frame turns the orientation
vectors too); otherwise every blade's CL data are rotated and written out.
"""

from __future__ import annotations

import math

from ..toolpath.types import MOVE_RAPID
from .blocks import SAFE
from .common import PostContext, fmt, fvec, header_lines
from .tcp import check_tcp

NAME = "siemens"
TCP = True
INDEXABLE = "z"


def check(machine):
    check_tcp(machine, "siemens")


def _moves(ctx: PostContext) -> list[str]:
    b = ctx.blocks
    out = []
    last_f = None
    for i in range(len(b)):
        if b.kind[i] == SAFE:
            out.append(f"SUPA G0 Z{fmt(b.safe_z)} ; safe retract, index to blade")
            last_f = None
            continue
        x, y, z = (fmt(v) for v in b.tip[i])
        a, bb, c = fvec(b.axis[i])
        words = f"X={x} Y={y} Z={z} A3={a} B3={bb} C3={c}"
        if b.kind[i] == MOVE_RAPID:
            out.append(f"G0 {words}")
        else:
            f = fmt(b.feed[i], 1)
            out.append(f"G1 {words}" + (f" F{f}" if f != last_f else ""))
            last_f = f
    return out


def write(ctx: PostContext) -> str:
    o = ctx.options
    b = ctx.blocks
    lines = ["DEF INT _BLADE"] if b.indexed else []
    lines += ["; " + h for h in header_lines(ctx, tcp=True)]
    lines += [
        "G17 G90 G71 G94 G40",
        "SUPA G0 Z" + fmt(b.safe_z) + " D0",
        f"T{o.tool_number} D1",
        "M6",
        "G54",
        f"S{o.spindle:g} {'M3' if o.spindle_cw else 'M4'}",
        "M8" if o.coolant else "M9",
        "TRAORI",
        "ORIWKS",
        "ORIVECT",
    ]
    if b.indexed:
        pitch = math.copysign(360.0 / b.blades, b.blisk_axis[1][2])
        lines += ["_BLADE=0", "BLADE_LOOP:", f"ROT Z=_BLADE*{fmt(pitch, 8)} ; blade turn"]
        lines += _moves(ctx)
        lines += ["_BLADE=_BLADE+1", f"IF _BLADE<{b.blades} GOTOB BLADE_LOOP", "ROT"]
    else:
        lines += _moves(ctx)
    lines += ["TRAFOOF", f"SUPA G0 Z{fmt(b.safe_z)} D0", "M9", "M5", "M30"]
    return "\n".join(lines) + "\n"


def write_job(sections, header: list[str]) -> str:
    """One program for a job's operations (:mod:`.job_program`): ``sections`` are (title,
    PostContext). A tool change (``T… D1`` ``M6``) only where the tool differs from the one in
    the spindle; each section sets spindle and coolant, runs under TRAORI and ends with
    TRAFOOF at the safe Z, coolant and spindle off; indexed sections loop over the blades
    with their own label ``BLADE_LOOP<k>``."""
    safe = max(ctx.blocks.safe_z for _, ctx in sections)
    lines = ["DEF INT _BLADE"] + ["; " + h for h in header]
    lines += ["G17 G90 G71 G94 G40", f"SUPA G0 Z{fmt(safe)} D0"]
    loaded = None
    for k, (title, ctx) in enumerate(sections):
        o, b = ctx.options, ctx.blocks
        lines.append(f"; operation {k + 1}: {title}")
        lines += ["; " + note for note in o.notes]
        if o.tool_number != loaded:
            lines += [f"T{o.tool_number} D1", "M6"]
            loaded = o.tool_number
        lines += ["G54", f"S{o.spindle:g} {'M3' if o.spindle_cw else 'M4'}",
                  "M8" if o.coolant else "M9", "TRAORI", "ORIWKS", "ORIVECT"]
        if b.indexed:
            pitch = math.copysign(360.0 / b.blades, b.blisk_axis[1][2])
            label = f"BLADE_LOOP{k + 1}"
            lines += ["_BLADE=0", f"{label}:", f"ROT Z=_BLADE*{fmt(pitch, 8)} ; blade turn"]
            lines += _moves(ctx)
            lines += ["_BLADE=_BLADE+1", f"IF _BLADE<{b.blades} GOTOB {label}", "ROT"]
        else:
            lines += _moves(ctx)
        lines += ["TRAFOOF", f"SUPA G0 Z{fmt(safe)} D0", "M9", "M5"]
    lines.append("M30")
    return "\n".join(lines) + "\n"
