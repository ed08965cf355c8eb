"""Heidenhain TNC conversational (Klartext) with M128 (tool centre point management).

``L X Y Z <rot1> <rot2>`` blocks, numbered from 0; X Y Z the paths' tip coordinates with the
preset at the part origin and the part's axes; rotary words the joint angles.
"""

from __future__ import annotations

import numpy as np

from ..toolpath.types import MOVE_RAPID
from .blocks import SAFE
from .common import PostContext, fmt, header_lines
from .tcp import check_tcp

NAME = "heidenhain"
TCP = True
INDEXABLE = False


def check(machine):
    check_tcp(machine, "heidenhain")


def _s(x, decimals=4) -> str:
    t = fmt(x, decimals)
    return t if t.startswith("-") else "+" + t


def _moves(ctx: PostContext) -> list[str]:
    """The blocks: poses at TCP (M128), each safe retract with M129 before it (but the
    first) and the rotaries indexed at the safe Z."""
    b = ctx.blocks
    n1, n2 = ctx.rotary_names
    body = []
    deg = np.degrees(b.angles)
    for i in range(len(b)):
        if b.kind[i] == SAFE:
            body += [] if i == 0 else ["M129"]
            body += [f"L Z{_s(b.safe_z)} R0 FMAX M91 ; safe retract, index to blade",
                     f"L {n1}{_s(deg[i + 1, 0])} {n2}{_s(deg[i + 1, 1])} R0 FMAX", "M128"]
            continue
        x, y, z = (_s(v) for v in b.tip[i])
        words = f"L X{x} Y{y} Z{z} {n1}{_s(deg[i, 0])} {n2}{_s(deg[i, 1])} R0"
        f = "FMAX" if b.kind[i] == MOVE_RAPID else f"F{b.feed[i]:.0f}"
        body.append(f"{words} {f}")
    return body


def write(ctx: PostContext) -> str:
    o = ctx.options
    b = ctx.blocks
    name = "BLISK"
    body = [f"BEGIN PGM {name} MM"]
    body += ["; " + h for h in header_lines(ctx, tcp=True)]
    body += [
        f"L Z{_s(b.safe_z)} R0 FMAX M91 ; safe start",
        f"TOOL CALL {o.tool_number} Z S{o.spindle:g}",
        f"L M{3 if o.spindle_cw else 4}",
        f"L M{8 if o.coolant else 9}",
    ]  # M128 follows the safe retract that starts every blade
    body += _moves(ctx)
    body += ["M129", f"L Z{_s(b.safe_z)} R0 FMAX M91", "L M9", "L M5", "M30",
             f"END PGM {name} MM"]
    return "\n".join(f"{k} {line}" for k, line in enumerate(body)) + "\n"


def write_job(sections, header: list[str]) -> str:
    """One program for a job's operations (:mod:`.job_program`): ``sections`` are (title,
    PostContext). ``TOOL CALL <T> Z S…`` where the tool changes, ``TOOL CALL Z S…`` (the
    speed only) where the same tool goes on; each section ends with M129 at the safe Z,
    coolant and spindle off."""
    name = "BLISK"
    safe = max(ctx.blocks.safe_z for _, ctx in sections)
    body = [f"BEGIN PGM {name} MM"] + ["; " + h for h in header]
    body.append(f"L Z{_s(safe)} R0 FMAX M91 ; safe start")
    loaded = None
    for k, (title, ctx) in enumerate(sections):
        o = ctx.options
        body.append(f"; operation {k + 1}: {title}")
        body += ["; " + note for note in o.notes]
        if o.tool_number != loaded:
            body.append(f"TOOL CALL {o.tool_number} Z S{o.spindle:g}")
            loaded = o.tool_number
        else:
            body.append(f"TOOL CALL Z S{o.spindle:g}")
        body += [f"L M{3 if o.spindle_cw else 4}", f"L M{8 if o.coolant else 9}"]
        body += _moves(ctx)
        body += ["M129", f"L Z{_s(safe)} R0 FMAX M91", "L M9", "L M5"]
    body += ["M30", f"END PGM {name} MM"]
    return "\n".join(f"{k} {line}" for k, line in enumerate(body)) + "\n"
