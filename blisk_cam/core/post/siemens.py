"""Siemens 840D sl with TRAORI and tool-orientation vectors (ORIWKS: orientation in the
workpiece frame).

X Y Z are the paths' tip coordinates in G54 at the part origin with the part's axes;
A3= B3= C3= the unit tool axis — all three components in every block, because the control
reads a missing one as 0 (paper 002 §4: 840D post-processing of the blisk program).
"""

from __future__ import annotations

from ..toolpath import MOVE_RAPID
from .common import SAFE, PostContext, fmt, fvec, header_lines
from .tcp import check_tcp

NAME = "siemens"
TCP = True
INDEXABLE = False


def check(machine):
    check_tcp(machine, "siemens")


def write(ctx: PostContext) -> str:
    o = ctx.options
    b = ctx.blocks
    lines = ["; " + h for h in header_lines(ctx, tcp=True)]
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
    last_f = None
    for i in range(len(b)):
        if b.kind[i] == SAFE:
            lines.append(f"SUPA G0 Z{fmt(b.safe_z)} ; safe retract, index to blade")
            last_f = None
            continue
        x, y, z = (fmt(v) for v in b.tip[i])
        a, bb, c = fvec(b.axis[i])
        words = f"X={x} Y={y} Z={z} A3={a} B3={bb} C3={c}"
        if b.kind[i] == MOVE_RAPID:
            lines.append(f"G0 {words}")
        else:
            f = fmt(b.feed[i], 1)
            lines.append(f"G1 {words}" + (f" F{f}" if f != last_f else ""))
            last_f = f
    lines += ["TRAFOOF", f"SUPA G0 Z{fmt(b.safe_z)} D0", "M9", "M5", "M30"]
    return "\n".join(lines) + "\n"
