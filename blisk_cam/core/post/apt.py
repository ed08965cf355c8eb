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


def _moves(ctx: PostContext) -> list[str]:
    b = ctx.blocks
    lines = []
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
    return lines


def _tool_on(ctx: PostContext, load: bool) -> list[str]:
    o = ctx.options
    t = ctx.path.tool
    b = ctx.blocks
    lines = [f"CUTTER/{fmt(t.d)},{fmt(t.r)}", f"LOADTL/{o.tool_number}"] if load else []
    lines += [f"SPINDL/RPM,{o.spindle:g},{'CLW' if o.spindle_cw else 'CCLW'}",
              "COOLNT/" + ("FLOOD" if o.coolant else "OFF")]
    first = b.poses.argmax()
    lines.append("TLAXIS/" + ",".join(fvec(b.axis[first])))
    return lines


def write(ctx: PostContext) -> str:
    o = ctx.options
    lines = [f"PARTNO/BLISK CAM {o.blade_name.upper()[:40]}"]
    lines += ["$$ " + h for h in header_lines(ctx, tcp=True)]
    lines += ["UNITS/MM", "MULTAX/ON", *_tool_on(ctx, True), *_moves(ctx)]
    lines += ["COOLNT/OFF", "SPINDL/OFF", "FINI"]
    return "\n".join(lines) + "\n"


def write_job(sections, header: list[str]) -> str:
    """CL data of a job's operations (:mod:`.job_program`): ``sections`` are (title,
    PostContext); ``CUTTER`` and ``LOADTL`` (the tool change) where the tool differs from the
    one loaded, the spindle and coolant per section, both off between sections."""
    lines = ["PARTNO/BLISK CAM JOB"] + ["$$ " + h for h in header] + ["UNITS/MM", "MULTAX/ON"]
    loaded = None
    for k, (title, ctx) in enumerate(sections):
        lines.append(f"$$ operation {k + 1}: {title}")
        lines += ["$$ " + note for note in ctx.options.notes]
        lines += _tool_on(ctx, ctx.options.tool_number != loaded)
        loaded = ctx.options.tool_number
        lines += _moves(ctx)
        lines += ["COOLNT/OFF", "SPINDL/OFF"]
    lines.append("FINI")
    return "\n".join(lines) + "\n"
