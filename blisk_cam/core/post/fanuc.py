"""Fanuc (30i/31i-B5) with tool centre point control G43.4 (type 1: rotary angles given).

X Y Z are the paths' tip coordinates in the work offset G54, which must sit at the part
origin with the part's axes; the rotary words are the joint angles of the block stream. Feeds
in mm/min of the tip (G94 under TCP).

Blades: when the blisk axis is the paths' z axis and the innermost table rotary (the C table
of an A/C trunnion), blade 0 is a subprogram ``O<program+1>`` called once per blade with
``M98`` after setting the macro variables #1 (blade turn about Z, degrees) and #2 (rotary
offset, degrees): its words are ``X[#3*x-#4*y] Y[#4*x+#3*y] Z z A a C[#2+c]`` with #3 = COS[#1],
#4 = SIN[#1] (custom macro B). Otherwise every blade's CL data are rotated and solved again.
"""

from __future__ import annotations

import numpy as np

from ..toolpath.types import MOVE_RAPID
from .blocks import SAFE
from .common import PostContext, fmt, header_lines
from .tcp import check_tcp

NAME = "fanuc"
TCP = True
INDEXABLE = "z"


def check(machine):
    check_tcp(machine, "fanuc")


def _comment(text: str) -> str:
    return "(" + text.upper().replace("(", "[").replace(")", "]") + ")"


def _moves(ctx: PostContext, macro: bool) -> list[str]:
    o = ctx.options
    b = ctx.blocks
    n1, n2 = ctx.rotary_names
    deg = np.degrees(b.angles)
    out = []
    last_f = None
    for i in range(len(b)):
        if b.kind[i] == SAFE:
            r2 = f"[#2+{fmt(deg[i + 1, 1])}]" if macro else fmt(deg[i + 1, 1])
            out += [] if (i == 0 and not macro) else ["G49"]
            out += ["G91 G28 Z0. (SAFE RETRACT, INDEX TO BLADE)", "G90",
                    f"G00 {n1}{fmt(deg[i + 1, 0])} {n2}{r2}", f"G43.4 H{o.tool_number}"]
            last_f = None
            continue
        x, y, z = (fmt(v) for v in b.tip[i])
        if macro:
            xy = f"X[#3*{x}-#4*{y}] Y[#4*{x}+#3*{y}]"
            r2 = f"[#2+{fmt(deg[i, 1])}]"
        else:
            xy = f"X{x} Y{y}"
            r2 = fmt(deg[i, 1])
        words = f"{xy} Z{z} {n1}{fmt(deg[i, 0])} {n2}{r2}"
        if b.kind[i] == MOVE_RAPID:
            out.append(f"G00 {words}")
        else:
            f = fmt(b.feed[i], 1)
            out.append(f"G01 {words}" + (f" F{f}" if f != last_f else ""))
            last_f = f
    return out


def write(ctx: PostContext) -> str:
    o = ctx.options
    b = ctx.blocks
    sub = o.program_number + 1
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
    ]  # G43.4 (TCP + length compensation) follows the safe retract that starts every blade
    if b.indexed:
        for k, (turn, off) in enumerate(zip(np.degrees(b.z_turns), np.degrees(b.offsets),
                                            strict=True)):
            lines += [f"#1={fmt(turn)} (BLADE {k})", f"#2={fmt(off)}", f"M98 P{sub:04d}"]
    else:
        lines += _moves(ctx, macro=False)
    lines += ["G49", "G91 G28 Z0.", "G90", "M09", "M05", "M30"]
    if b.indexed:
        lines += [f"O{sub:04d} (ONE BLADE: #1 TURN ABOUT Z, #2 {ctx.rotary_names[1]} OFFSET)",
                  "#3=COS[#1]", "#4=SIN[#1]"]
        lines += _moves(ctx, macro=True)
        lines.append("M99")
    lines.append("%")
    return "\n".join(lines) + "\n"


def write_job(sections, header: list[str]) -> str:
    """One program for a job's operations (:mod:`.job_program`): ``sections`` are (title,
    PostContext). A tool change (``T… M06``) only where the tool differs from the one in the
    spindle; each section sets its spindle and coolant, runs at TCP (G43.4 after each safe
    retract) and ends retracted (G49, G28 Z) with coolant and spindle off; indexed sections
    call their own subprogram ``O<program + 1 + k>``, written after ``M30``."""
    o0 = sections[0][1].options
    lines = ["%", f"O{o0.program_number:04d} (BLISK CAM JOB)"]
    lines += [_comment(h) for h in header]
    lines += ["G90 G94 G17 G21 G40 G49 G80", "G91 G28 Z0.", "G90"]
    subs = []
    loaded = None
    for k, (title, ctx) in enumerate(sections):
        o, b = ctx.options, ctx.blocks
        lines.append(_comment(f"operation {k + 1}: {title}"))
        lines += [_comment(note) for note in o.notes]
        if o.tool_number != loaded:
            lines.append(f"T{o.tool_number} M06")
            loaded = o.tool_number
        lines += ["G54", f"S{o.spindle:g} {'M03' if o.spindle_cw else 'M04'}",
                  "M08" if o.coolant else "M09"]
        if b.indexed:
            sub = o0.program_number + 1 + k
            for j, (turn, off) in enumerate(zip(np.degrees(b.z_turns), np.degrees(b.offsets),
                                                strict=True)):
                lines += [f"#1={fmt(turn)} (BLADE {j})", f"#2={fmt(off)}", f"M98 P{sub:04d}"]
            subs.append((sub, ctx))
        else:
            lines += _moves(ctx, macro=False)
        lines += ["G49", "G91 G28 Z0.", "G90", "M09", "M05"]
    lines.append("M30")
    for sub, ctx in subs:
        lines += [f"O{sub:04d} (ONE BLADE: #1 TURN ABOUT Z, #2 {ctx.rotary_names[1]} OFFSET)",
                  "#3=COS[#1]", "#4=SIN[#1]"]
        lines += _moves(ctx, macro=True)
        lines.append("M99")
    lines.append("%")
    return "\n".join(lines) + "\n"
