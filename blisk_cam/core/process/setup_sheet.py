"""The setup sheet of a job run: what the machinist needs at the machine, in Markdown.

Part and material, stock (blank, resolution, volume before and after every operation), machine
and programs, the tool table ("Ø12 R2 bull nose", flutes, stick-out, holder, coolant), the
operations in order with their cutting data (effective diameter, depth, vc, fz, spindle, feed,
where the data came from), estimated times (the program's blocks at their feeds and the
machine's rapid rates, every blade), the verdict of each operation's deviation map and the
final verdict with its zones (:mod:`.job_verdict`).
No pictures: the core has no renderer (the deviation maps are PLY files beside the sheet).
"""

from __future__ import annotations

import math

from ..options import describe_tool
from ..version import __version__
from .job import JobRun
from .job_verdict import job_verdict_lines

__all__ = ["setup_sheet"]


def _tool_name(t) -> str:
    return describe_tool(t.type, t.diameter, t.corner_radius, t.taper_angle).replace(
        " flat", " flat end")


def _holder(t) -> str:
    if t.holder is None:
        return "the cutter's own shank and holder"
    return " → ".join(f"z {z:g} r {r:g}" for z, r in t.holder) + " mm"


def _minutes(m) -> str:
    if m is None:
        return "—"
    return f"{m:.1f} min" if m < 120 else f"{m / 60:.1f} h"


def setup_sheet(run: JobRun, files: dict) -> str:
    """The Markdown setup sheet of ``run``; ``files`` names the written files ({"programs":
    {post: file}, operation index: {"paths": …, "stock": …, "deviation": …}})."""
    job = run.job
    part = run.part
    posts = files.get("programs", {})
    first = next(iter(run.programs.values()), None)
    minutes = {k + 1: s.minutes for k, s in enumerate(first[1])} if first else {}
    used = {}
    for r in run.operations:
        used.setdefault(r.op.tool.number, []).append(str(r.op.index))
    src = "demo blisk" if job.part["source"] == "demo" else job.part["source"]
    L = [f"# Setup sheet — {job.file.name}", "",
         f"Blisk CAM {__version__}. Lengths mm, angles degrees, speeds m/min and rpm, feeds "
         "mm/min. No pictures: the core has no renderer; the deviation maps are PLY files in "
         "this folder (per-vertex `deviation`, mm: + material left, − gouge).", "",
         "## Part and stock", "",
         f"- Part: {src}, {part.blade_count} blades, material "
         f"{job.material or 'not given (cutting data from the operations)'}",
         f"- Blank: `{job.blank if ':' in job.blank else job.blank.split('/')[-1]}`, stock "
         f"resolution {job.resolution:g} mm, {run.stock_initial['volume_mm3']:.1f} mm³ per "
         f"pitch sector ({run.stock_initial['volume_mm3'] * part.blade_count / 1000:.1f} cm³ "
         "for the blisk)",
         f"- Machine: {job.machine.name} ({job.machine.kinematics}, "
         f"{'/'.join(job.machine.axis_names)}); programs: "
         + (", ".join(f"`{f}` ({p})" for p, f in posts.items()) or "none"), "",
         *[f"- **Program {p} NOT written**: {why}" for p, why in run.refused.items()],
         *([""] if run.refused else []),
         "## Tools", "",
         "| T | tool | flutes | stick-out | body (holder) | coolant | operations |",
         "|---|---|---|---|---|---|---|"]
    for n, t in job.tools.items():
        L.append(f"| T{n} | {_tool_name(t)}{' — ' + t.name if t.name else ''} | {t.flutes} | "
                 f"{f'{t.stick_out:g} mm' if t.stick_out else '—'} | {_holder(t)} | "
                 f"{'flood' if t.coolant else 'off'} | "
                 f"{', '.join(used.get(n, [])) or 'not used'} |")
    L += ["", "## Operations", "",
          "| # | operation | kind | tool | D_eff | ap | axis from normal | vc | fz | spindle | "
          "feed | est. time | removed | verdict |",
          "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    total = 0.0
    for k, r in enumerate(run.operations):
        c = r.cutting
        s = r.simulation.summary
        removed = r.stock_in["volume_mm3"] - r.stock_out["volume_mm3"]
        m = minutes.get(k + 1)
        total += m or 0.0
        verdict = "passed" if s["passed"] else "**FAILED**"
        L.append(f"| {r.op.index} | {r.op.name} | {r.op.kind.name} | T{r.op.tool.number} "
                 f"{_tool_name(r.op.tool)} | Ø{c.d_eff:.2f} | {c.depth:g} | "
                 f"{math.degrees(c.tilt):.1f}° | {c.vc:g} | {c.fz:g} | {c.spindle:.0f} | "
                 f"{c.feed:.0f} | {_minutes(m)} | {removed:.1f} mm³ | {verdict} |")
    L += ["", f"Estimated machining time: {_minutes(total)} for {part.blade_count} blades "
          "(feeds and rapid rates of the program; tool changes not counted).", "",
          "## Cutting data", ""]
    for r in run.operations:
        c = r.cutting
        L.append(f"- Operation {r.op.index} ({r.op.name}): {c.source}; D_eff = Ø{c.d_eff:.2f} "
                 f"mm for ap {c.depth:g} mm with the axis {math.degrees(c.tilt):.1f}° from the "
                 f"surface normal (nominal Ø{r.op.tool.diameter:g}); n = 1000·vc/(π·D_eff) = "
                 f"{c.spindle:.0f} rpm, feed = n·z·fz = {c.feed:.0f} mm/min"
                 + (f"; spindle capped: {c.limited}" if c.limited else ""))
    L += ["", "## Verdict per operation", ""]
    for r in run.operations:
        s = r.simulation.summary
        dv = s["deviation_mm"]
        crashes = s.get("crashes", [])
        line = (f"- Operation {r.op.index} ({r.op.name}): "
                f"{'passed' if s['passed'] else 'FAILED'} — material left max {dv['max_left']:.3f}"
                f" mm (p95 {dv['p95_left']:.3f}), gouge max {dv['max_gouge']:.3f} mm (tolerance "
                f"{dv['gouge_tolerance']:.3f}), {len(crashes)} crash(es)"
                + (f"; {dv['not_judged_area_mm2']:.1f} mm² below the stock's resolution not "
                   "judged" if dv.get("not_judged_area_mm2") else ""))
        if crashes:
            c0 = crashes[0]
            line += (f", first at row {c0['row']} ({c0['kind']}, {c0['move']} move, "
                     f"{c0['volume_mm3']:.1f} mm³)")
        f = files.get(r.op.index, {})
        if f:
            line += f"; files: `{f['paths']}`, `{f['deviation']}`, `{f['stock']}`"
        L.append(line)
    if run.verdict is not None:
        L += ["", "## Final verdict (the stock after the last operation)", ""]
        lines = job_verdict_lines(run.verdict, max_zones=30)
        L.append(lines[0][0].upper() + lines[0][1:] + ".")
        if run.verdict.zones:
            L += ["", "| zone | surface | area | r | z | above the hub | worst | why |",
                  "|---|---|---|---|---|---|---|---|"]
            for zn in run.verdict.zones[:30]:
                L.append(f"| {zn.status} ({zn.what}) | {zn.surface} | {zn.area_mm2:.1f} mm² | "
                         f"{zn.r_mm[0]:.1f}–{zn.r_mm[1]:.1f} | {zn.z_mm[0]:.1f}–{zn.z_mm[1]:.1f}"
                         f" | {zn.height_mm[0]:.1f}–{zn.height_mm[1]:.1f} | {zn.worst_mm:.3f} mm"
                         f" | {zn.reason} |")
            if len(run.verdict.zones) > 30:
                L.append(f"\n… and {len(run.verdict.zones) - 30} smaller zone(s) "
                         "(summary.json).")
        L += ["", "## Programs", ""]
    for post, (_, _, fk) in run.programs.items():
        worst = max(v["max_tip_error_mm"] for v in fk.values())
        ok = all(v["rows_per_blade_ok"] for v in fk.values())
        L.append(f"- Program ({post}): every pose block through forward kinematics back to its "
                 f"planned tip within {worst:.2e} mm; every operation's rows once per blade: "
                 f"{'yes' if ok else 'NO'}")
    return "\n".join(L) + "\n"
