"""APT / CLDATA source: machine-independent cutter locations (``GOTO/x,y,z,i,j,k``) in the
paths' frame, for a downstream post-processor."""

from __future__ import annotations

from ..toolpath.types import MOVE_RAPID
from .blocks import SAFE
from .common import PostContext, fmt, fvec, header_lines

NAME = "apt"
TCP = True
INDEXABLE = False
SOLVE = False  # no machine kinematics: CL data only


def check(machine):
    return None


def write(ctx: PostContext) -> str:
    o = ctx.options
    b = ctx.blocks
    t = ctx.path.tool
    lines = [f"PARTNO/BLISK CAM {o.blade_name.upper()[:40]}"]
    lines += ["$$ " + h for h in header_lines(ctx, tcp=True)]
    lines += ["UNITS/MM", "MULTAX/ON", f"CUTTER/{fmt(t.d)},{fmt(t.r)}",
              f"LOADTL/{o.tool_number}",
              f"SPINDL/RPM,{o.spindle:g},{'CLW' if o.spindle_cw else 'CCLW'}",
              "COOLNT/" + ("FLOOD" if o.coolant else "OFF")]
    first = b.poses.argmax()
    lines.append("TLAXIS/" + ",".join(fvec(b.axis[first])))
    last_f = None
    for i in range(len(b)):
        if b.kind[i] == SAFE:
            lines.append(f"$$ blade {int(b.blade[i])}: safe retract and index")
            last_f = None
            continue
        if b.kind[i] == MOVE_RAPID:
            lines.append("RAPID")
        else:
            f = fmt(b.feed[i])
            if f != last_f:
                lines.append(f"FEDRAT/{f},MMPM")
                last_f = f
        lines.append("GOTO/" + ",".join([fmt(v) for v in b.tip[i]] + fvec(b.axis[i])))
    lines += ["COOLNT/OFF", "SPINDL/OFF", "FINI"]
    return "\n".join(lines) + "\n"
