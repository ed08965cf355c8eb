"""LinuxCNC (rs274ngc) joint program for table-table machines without TCP.

X Y Z are the machine tip positions and the two rotary words the joint angles of the block
stream (:mod:`.blocks`); feed moves run in inverse time (G93: F = 1 / minutes of the block),
because in G94 LinuxCNC reads F as a combined linear/rotary rate. Blades indexed on the
innermost table rotary are an O-word subroutine called once per blade with the rotary offset
(degrees) as parameter #1 (paper 003 §V.A: one blade's program rotated to all blades).
"""

from __future__ import annotations

import numpy as np

from ..errors import PostError
from ..toolpath.types import MOVE_RAPID
from .blocks import SAFE
from .common import PostContext, ascii_text, block_minutes, fmt, header_lines

NAME = "linuxcnc"
TCP = False
INDEXABLE = True
SUB = 100


def check(machine):
    if machine.kinematics != "table-table":
        raise PostError(
            f"post linuxcnc writes joint programs for table-table machines only; "
            f"{machine.name!r} is {machine.kinematics} (use fanuc, siemens or heidenhain with "
            "TCP, or apt)"
        )


def _comment(text: str) -> str:
    return "(" + text.replace("(", "[").replace(")", "]") + ")"


def _moves(ctx: PostContext, param: bool) -> list[str]:
    """The motion lines of the block stream (``param``: blade 0 inside a subprogram, the
    innermost rotary offset by #1)."""
    b = ctx.blocks
    n1, n2 = ctx.rotary_names
    minutes = block_minutes(b, ctx.options)
    out = []
    deg = np.degrees(b.angles)
    for i in range(len(b)):
        j = i + 1 if b.kind[i] == SAFE else i  # a SAFE turns the rotaries to the next pose
        a1 = fmt(deg[j, 0])
        a2 = f"[#1+{fmt(deg[j, 1])}]" if param else fmt(deg[j, 1])
        if b.kind[i] == SAFE:
            out.append(f"G53 G0 Z{fmt(b.safe_z)} (safe retract, index to blade)")
            out.append(f"G0 {n1}{a1} {n2}{a2} (rotaries at the safe height)")
            continue
        x, y, z = (fmt(v) for v in b.xyz[i])
        words = f"X{x} Y{y} Z{z} {n1}{a1} {n2}{a2}"
        if b.kind[i] == MOVE_RAPID:
            out.append(f"G0 {words}")
        else:
            out.append(f"G1 {words} F{fmt(1.0 / minutes[i])}")
    return out


def _tool_on(o) -> list[str]:
    """Spindle, coolant and feed mode of a section (after its tool change)."""
    return [f"S{o.spindle:g} {'M3' if o.spindle_cw else 'M4'}",
            "M8" if o.coolant else "M9",
            "G93 (inverse time feed on feed moves)"]


def _body(ctx: PostContext, sub: int) -> list[str]:
    """The moves of one path: blade 0 as subprogram ``sub`` called per blade when indexed."""
    b = ctx.blocks
    if not b.indexed:
        return _moves(ctx, param=False)
    lines = [f"o{sub} sub (one blade; #1 = {ctx.rotary_names[1]} offset, degrees)"]
    lines += _moves(ctx, param=True)
    lines.append(f"o{sub} endsub")
    for k, off in enumerate(np.degrees(b.offsets)):
        lines.append(f"o{sub} call [{fmt(off)}] (blade {k})")
    return lines


def write(ctx: PostContext) -> str:
    o = ctx.options
    b = ctx.blocks
    lines = ["%"] + [_comment(h) for h in header_lines(ctx, tcp=False)]
    lines += [
        "G21 G90 G94 G17 G40 G49 G80 (mm, absolute, safe start)",
        "G54",
        f"G53 G0 Z{fmt(b.safe_z)}",
        f"T{o.tool_number} M6",
        f"G43 H{o.tool_number}",
        *_tool_on(o),
    ]
    lines += _body(ctx, SUB)
    lines += ["G94", f"G53 G0 Z{fmt(b.safe_z)}", "M9", "M5", "M2", "%"]
    return "\n".join(lines) + "\n"


def write_job(sections, header: list[str]) -> str:
    """One program for a job's operations in order (:mod:`.job_program`): ``sections`` are
    (title, PostContext) with each operation's tool, spindle, feed and coolant in its
    options. A tool change (``T… M6``, ``G43 H…``) only where the tool differs from the one
    in the spindle; every section starts and ends at the safe machine Z with the spindle and
    coolant off between operations; subprograms numbered per section."""
    safe = max(ctx.blocks.safe_z for _, ctx in sections)
    lines = ["%"] + [_comment(h) for h in header]
    lines += ["G21 G90 G94 G17 G40 G49 G80 (mm, absolute, safe start)", "G54",
              f"G53 G0 Z{fmt(safe)}"]
    loaded = None
    for k, (title, ctx) in enumerate(sections):
        o = ctx.options
        lines.append(_comment(f"operation {k + 1}: {title}"))
        lines += [_comment(note) for note in o.notes]
        if o.tool_number != loaded:
            lines += [f"T{o.tool_number} M6", f"G43 H{o.tool_number}"]
            loaded = o.tool_number
        lines += _tool_on(o)
        lines += _body(ctx, SUB + 1 + k)
        lines += ["G94", f"G53 G0 Z{fmt(safe)} (safe retract, end of operation {k + 1})",
                  "M9", "M5"]
    lines += ["M2", "%"]
    return "\n".join(lines) + "\n"


def tool_table(tools) -> str:
    """A LinuxCNC tool table (``.tbl``) for a job's tools: ``tools`` are (number, diameter mm,
    description). Pocket = tool number; the length offset is 0: the machinist measures it
    (the program calls ``G43 H<T>``)."""
    lines = [f"T{n} P{n} D{fmt(d)} Z0.0000 ;{ascii_text(text)} - length to be measured"
             for n, d, text in tools]
    return "\n".join(lines) + "\n"
