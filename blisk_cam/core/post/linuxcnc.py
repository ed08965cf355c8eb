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
from .common import PostContext, block_minutes, fmt, header_lines

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
        f"S{o.spindle:g} {'M3' if o.spindle_cw else 'M4'}",
        "M8" if o.coolant else "M9",
        "G93 (inverse time feed on feed moves)",
    ]
    if b.indexed:
        lines.append(f"o{SUB} sub (one blade; #1 = {ctx.rotary_names[1]} offset, degrees)")
        lines += _moves(ctx, param=True)
        lines.append(f"o{SUB} endsub")
        for k, off in enumerate(np.degrees(b.offsets)):
            lines.append(f"o{SUB} call [{fmt(off)}] (blade {k})")
    else:
        lines += _moves(ctx, param=False)
    lines += ["G94", f"G53 G0 Z{fmt(b.safe_z)}", "M9", "M5", "M2", "%"]
    return "\n".join(lines) + "\n"
