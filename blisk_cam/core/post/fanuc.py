"""Fanuc (30i/31i-B5) with tool centre point control G43.4 (type 1: rotary angles given).

X Y Z are the paths' tip coordinates in the work offset G54, which must sit at the part
origin with the part's axes; the rotary words are the joint angles of the block stream. Feeds
in mm/min of the tip (G94 under TCP).
"""

from __future__ import annotations

import numpy as np

from ..toolpath import MOVE_RAPID
from .common import SAFE, PostContext, fmt, header_lines
from .tcp import check_tcp

NAME = "fanuc"
TCP = True
INDEXABLE = False


def check(machine):
    check_tcp(machine, "fanuc")


def _comment(text: str) -> str:
    return "(" + text.upper().replace("(", "[").replace(")", "]") + ")"


def write(ctx: PostContext) -> str:
    o = ctx.options
    b = ctx.blocks
    n1, n2 = ctx.rotary_names
    lines = ["%", f"O{o.program_number:04d} (BLISK CAM)"]
    lines += [_comment(h) for h in header_lines(ctx, tcp=True)]
    lines += [
        "G90 G94 G17 G21 G40 G49 G80",
        "G91 G28 Z0.",
        "G90",
        f"T{o.tool_number} M06",
        "G54",
        f"S{o.spindle:g} {'M03' if o.spindle_cw else 'M04'}",
        "M08" if o.coolant else "M09",
        f"G43.4 H{o.tool_number}",
    ]
    deg = np.degrees(b.angles)
    last_f = None
    for i in range(len(b)):
        if b.kind[i] == SAFE:
            lines += ["G49", "G91 G28 Z0. (SAFE RETRACT, INDEX TO BLADE)", "G90",
                      f"G43.4 H{o.tool_number}"]
            last_f = None
            continue
        x, y, z = (fmt(v) for v in b.tip[i])
        words = f"X{x} Y{y} Z{z} {n1}{fmt(deg[i, 0])} {n2}{fmt(deg[i, 1])}"
        if b.kind[i] == MOVE_RAPID:
            lines.append(f"G00 {words}")
        else:
            f = fmt(b.feed[i], 1)
            lines.append(f"G01 {words}" + (f" F{f}" if f != last_f else ""))
            last_f = f
    lines += ["G49", "G91 G28 Z0.", "G90", "M09", "M05", "M30", "%"]
    return "\n".join(lines) + "\n"
