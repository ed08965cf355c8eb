"""The ``process`` command: a whole job (part, stock, tools, operations in order) → one folder.

::

    python -m blisk_cam process JOB.toml --out DIR [--force] [--quiet]
    python -m blisk_cam process --template tung-tso --out DIR

DIR receives, per operation k (``01-<name>``…): ``NN-name.paths.json``, the stock after it
(``NN-name.stock.npz``, the next operation's input, and ``simulate --stock`` reads it), its
deviation map (``NN-name.deviation.ply``) and simulation summary (``NN-name.simulation.json``);
one program per post (``job.linuxcnc.ngc``) and for LinuxCNC its tool table
(``job.linuxcnc.tbl``, lengths to be measured); ``setup_sheet.md``; ``summary.json``; a copy of
the job file. The folder is built in a temporary folder beside DIR and renamed into place at
the end: a failure or Ctrl-C leaves nothing half-written. A non-empty DIR is refused unless
``--force`` (then replaced as a whole). Exit 0 when every operation's verdict and the final verdict
(:mod:`..core.process.job_verdict`: left ≤ cusp + chord and no gouge beyond the chord except
the zones named unreachable, with their areas) passed, 5 when one failed (the folder is
written), 6 when nothing failed but the final verdict is *incomplete*: zones no finishing
operation plans to cut are named "not machined", each with its area and the operation that
would cover it (a deliberately partial job — roughing alone, the blades without the fillet —
ends so; the folder is written), 4 when the collision gate refused a post (an operation has
unresolved collisions: the folder is written without that program, the setup sheet and the
summary say why), 1 on bad input, 2 on a usage error. When several apply: 4, then 5, then 6.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import re
import shutil
import sys
import tempfile
import time
from pathlib import Path

from ..core.files import umask
from .flags import PROG, UsageError
from .progress import StageProgress

__all__ = ["add_process_arguments", "run_process"]

EXIT_VERDICT_FAILED = 5
#: every verdict passed, but zones of the part are not machined (the final verdict incomplete)
EXIT_INCOMPLETE = 6
#: a post refused by the collision gate (as `paths` with unresolved collisions)
EXIT_UNRESOLVED_COLLISIONS = 4
PROGRAM_SUFFIX = {"linuxcnc": ".ngc", "fanuc": ".nc", "siemens": ".mpf", "heidenhain": ".h",
                  "apt": ".apt"}


def add_process_arguments(parser: argparse.ArgumentParser):
    """Add the ``process`` arguments to ``parser``."""
    parser.add_argument("job", metavar="JOB.toml", nargs="?", help="the job file (part, "
                        "stock, machine, tools, operations in order)")
    parser.add_argument("--template", metavar="NAME", help="run a job shipped with Blisk CAM "
                        "instead of JOB.toml: tung-tso (paper 003's process on the demo blisk: "
                        "disk blank, roughing leaving 0.5 mm, semi-finishing leaving 0.1 mm, "
                        "blade, hub and fillet finishing)")
    parser.add_argument("--out", required=True, metavar="DIR", help="output folder (built "
                        "beside it and renamed into place at the end)")
    parser.add_argument("--force", action="store_true",
                        help="replace a non-empty output folder")
    parser.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    return parser


def _slug(text: str) -> str:
    s = re.sub(r"[^A-Za-z0-9]+", "-", text).strip("-").lower()
    return s[:40] or "operation"


def _check_out(out: Path, force: bool) -> None:
    if out.exists() and not out.is_dir():
        raise UsageError(f"--out {out}: exists and is not a folder")
    if not out.parent.is_dir():
        raise UsageError(f"--out {out}: the folder {out.parent} does not exist")
    if out.is_dir() and any(out.iterdir()) and not force:
        raise UsageError(f"--out {out}: the folder is not empty; choose another folder or give "
                         "--force to replace it")


def _replace_folder(tmp: Path, out: Path) -> None:
    """Rename ``tmp`` to ``out``; an existing ``out`` is moved aside first and removed after."""
    os.chmod(tmp, 0o777 & ~umask())
    old = None
    if out.exists():
        old = Path(tempfile.mkdtemp(prefix=".blisk_old_", dir=out.parent))
        os.rmdir(old)
        os.rename(out, old)
    try:
        os.rename(tmp, out)
    except BaseException:
        if old is not None:
            os.rename(old, out)
        raise
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)


def run_process(args) -> int:
    """Run the ``process`` command; the exit status."""
    from ..core.process.job import iter_run_job, load_job
    from ..core.process.setup_sheet import setup_sheet
    from ..core.stock.deviation import ply_bytes
    from ..core.toolpath.paths_io import write_paths_json

    t0 = time.perf_counter()
    if (args.job is None) == (args.template is None):
        raise UsageError("give the job file JOB.toml or --template NAME (one of them)")
    if args.template is not None:
        from ..core.process.job import job_template

        args.job = str(job_template(args.template))
    out = Path(args.out).expanduser().resolve()
    if out == Path(args.job).expanduser().resolve().parent or out in Path(
            args.job).expanduser().resolve().parents:
        raise UsageError(f"--out {args.out}: the folder holds the job file; choose another")
    _check_out(out, args.force)
    job = load_job(args.job)
    progress = StageProgress(args.quiet)
    tmp = Path(tempfile.mkdtemp(prefix=".blisk_job_", dir=out.parent))
    files: dict = {"programs": {}}
    try:
        def save(orun):
            stem = f"{orun.op.index:02d}-{_slug(orun.op.name)}"
            names = {"paths": f"{stem}.paths.json", "stock": f"{stem}.stock.npz",
                     "deviation": f"{stem}.deviation.ply",
                     "simulation": f"{stem}.simulation.json"}
            write_paths_json(orun.path, tmp / names["paths"])
            orun.stock.save(tmp / names["stock"])
            sim = orun.simulation
            (tmp / names["deviation"]).write_bytes(
                ply_bytes(sim.V, sim.F, sim.deviation, sim.judged))
            summary = dict(sim.summary, stock_in=orun.stock_in, stock_out=orun.stock_out)
            (tmp / names["simulation"]).write_text(json.dumps(summary, indent=1) + "\n",
                                                   encoding="utf-8")
            files[orun.op.index] = names

        gen = iter_run_job(job, on_operation=save)
        while True:
            try:
                pr = next(gen)
            except StopIteration as stop:
                run = stop.value
                break
            progress.report("process", pr.fraction, pr.message)
        for post, (text, _, _) in run.programs.items():
            name = f"job.{post}{PROGRAM_SUFFIX.get(post, '.nc')}"
            (tmp / name).write_text(text, encoding="ascii", newline="\n")
            files["programs"][post] = name
        if "linuxcnc" in run.programs:
            from ..core.options import describe_tool
            from ..core.post.linuxcnc import tool_table

            name = "job.linuxcnc.tbl"
            (tmp / name).write_text(tool_table(
                (n, t.diameter, describe_tool(t.type, t.diameter, t.corner_radius,
                                              t.taper_angle))
                for n, t in job.tools.items()), encoding="ascii", newline="\n")
            files["tool_table"] = name
        (tmp / "setup_sheet.md").write_text(setup_sheet(run, files), encoding="utf-8")
        shutil.copyfile(job.file, tmp / "job.toml")
        summary = _summary(run, files, time.perf_counter() - t0)
        (tmp / "summary.json").write_text(json.dumps(summary, indent=1) + "\n",
                                          encoding="utf-8")
        _replace_folder(tmp, out)
    except BaseException:
        with contextlib.suppress(OSError):
            shutil.rmtree(tmp)
        raise
    progress.done("process", time.perf_counter() - t0)
    failed = [o for o in summary["operations"] if not o["passed"]]
    for o in summary["operations"]:
        c = o["cutting"]
        print(f"operation {o['index']} ({o['name']}): T{o['tool']} {o['tool_name']}, "
              f"S{c['spindle_rpm']:.0f} F{c['feed_mm_min']:.0f} at Ø{c['d_eff_mm']:.2f}, "
              f"{o['poses']} poses, verdict {'passed' if o['passed'] else 'FAILED'}")
    print(f"wrote {out}: {len(summary['operations'])} operation(s), "
          f"{', '.join(files['programs'].values()) or 'no program'}, setup_sheet.md "
          f"({summary['seconds']:.1f} s)")
    from ..core.process.job_verdict import job_verdict_lines

    for line in job_verdict_lines(run.verdict):
        print(line)
    for reason in run.refused.values():
        print(f"{PROG}: {reason}", file=sys.stderr)
    if run.refused:
        print(f"{PROG}: the outputs were written, the program(s) for "
              f"{', '.join(run.refused)} were not (see {out / 'setup_sheet.md'})",
              file=sys.stderr)
        return EXIT_UNRESOLVED_COLLISIONS
    if failed:
        print(f"{PROG}: verdict: FAILED in operation(s) "
              f"{', '.join(str(o['index']) for o in failed)}; see {out / 'setup_sheet.md'}",
              file=sys.stderr)
        return EXIT_VERDICT_FAILED
    if run.verdict.status == "failed":
        print(f"{PROG}: final verdict: FAILED (material left beyond the bound where a finishing "
              f"operation plans contacts, or a gouge); see {out / 'setup_sheet.md'}",
              file=sys.stderr)
        return EXIT_VERDICT_FAILED
    if run.verdict.status == "incomplete":
        print(f"{PROG}: final verdict: INCOMPLETE (zones no finishing operation plans to cut, "
              f"named 'not machined' with the operation that would cover them); see "
              f"{out / 'setup_sheet.md'}", file=sys.stderr)
        return EXIT_INCOMPLETE
    return 0


def _summary(run, files, seconds) -> dict:
    from ..core.options import describe_tool
    from ..core.process.job_verdict import job_verdict_dict

    ops = []
    for k, r in enumerate(run.operations):
        c = r.cutting
        t = r.op.tool
        ops.append({
            "index": r.op.index, "name": r.op.name, "kind": r.op.kind.name, "tool": t.number,
            "tool_name": describe_tool(t.type, t.diameter, t.corner_radius, t.taper_angle),
            "poses": int(len(r.path.program)),
            "cutting": {"vc_m_min": c.vc, "fz_mm": c.fz, "flutes": c.flutes,
                        "d_eff_mm": c.d_eff, "depth_mm": c.depth,
                        "axis_from_normal_deg": math.degrees(c.tilt),
                        "spindle_rpm": c.spindle, "feed_mm_min": c.feed, "source": c.source,
                        "limited": c.limited},
            "stock_in": r.stock_in, "stock_out": r.stock_out,
            "passed": bool(r.simulation.summary["passed"]),
            "deviation_mm": r.simulation.summary["deviation_mm"],
            "crashes": len(r.simulation.summary.get("crashes", [])),
            "seconds": r.seconds,
            "minutes": {p: prog[1][k].minutes for p, prog in run.programs.items()},
            "files": files.get(r.op.index, {}),
        })
    return {"job": str(run.job.file), "blades": run.part.blade_count,
            "material": run.job.material, "stock_initial": run.stock_initial,
            "operations": ops, "programs": files["programs"],
            "programs_refused": dict(run.refused),
            "final_verdict": job_verdict_dict(run.verdict),
            "forward_kinematics": {p: {str(k): v for k, v in prog[2].items()}
                                   for p, prog in run.programs.items()},
            "seconds": round(seconds, 3)}
