"""A job → its tasks (client side, before the workers start) and the tasks' results → the
job's files and summary rows (client side, after the last of its tasks).

* a single command is one task: its command line with the outputs in the worker's temporary
  folder (bare names, the command's default when the job names none);
* ``blades`` reads the scan, splits it with the part model
  (:func:`..core.part.model.split_blisk_mesh`) and makes one task per blade with its own
  faces and its scanned neighbours (:func:`..core.process.per_blade.blades_of_scan`); the
  results are one paths JSON per blade, ``blades.csv``/``blades.md`` (every blade, failed ones
  with their reason) and, with ``machine`` and ``post``, one program with a section per blade
  that passed (:func:`..core.process.per_blade.sections_program`);
* ``sweep`` makes one task per combination of its lists and writes ``sweep.csv``/``sweep.md``.

The arguments of ``blades`` and ``sweep`` are those of ``paths`` (read by its own parser and
checks, so a bad value gets the message the command would give) plus ``neighbours``
(blades), ``holder-length`` and ``holder-diameter`` (sweep).
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from ..cli.flags import UsageError
from ..core.errors import BliskCamError
from .jobs import DEFAULT_OUT, OUTPUT_KEYS, Job, JobsError, Task, argv_of, sweep_points
from .table import table_csv, table_markdown

__all__ = ["assemble", "expand"]

class _Parser(argparse.ArgumentParser):
    """Raises UsageError instead of printing usage and exiting."""

    def error(self, message):
        raise UsageError(message)


BLADE_KEYS = ("neighbours",)  # the scanned neighbours per side (not turned copies)
SWEEP_KEYS = ("holder-length", "holder-diameter")


def expand(job: Job) -> list[Task]:
    """The tasks of ``job``. JobsError naming the job for bad arguments."""
    try:
        if job.command == "blades":
            return _expand_blades(job)
        if job.command == "sweep":
            return _expand_sweep(job)
        return [_command_task(job)]
    except UsageError as exc:
        raise JobsError(f"job {job.name!r}: {exc}") from None
    except BliskCamError as exc:
        raise JobsError(f"job {job.name!r}: {' '.join(str(exc).split())}") from None


def _command_task(job: Job) -> Task:
    args = dict(job.args)
    if "out" not in args and job.command in DEFAULT_OUT:
        args["out"] = DEFAULT_OUT[job.command]
    for key in OUTPUT_KEYS:
        if args.get(key):
            args[key] = "{OUT}/" + args[key]
    return Task(job.name, job.name, "command", {"argv": argv_of(job.command, args)})


def _parse_paths(job: Job, args: dict):
    """The parsed and checked ``paths`` arguments of ``args`` (their --out a throw-away)."""
    from ..cli.paths import add_paths_arguments, check_paths_args

    argv = argv_of("paths", args, drop=("out", *BLADE_KEYS, *SWEEP_KEYS, "nc"))[1:]
    argv += ["--out", str(Path(tempfile.gettempdir()) / "unused.json")]
    if args.get("machine") or args.get("post"):
        argv += ["--nc", str(Path(tempfile.gettempdir()) / "unused.nc")]
    parser = _Parser(prog="blisk_cam paths")
    add_paths_arguments(parser)
    parsed, extra = parser.parse_known_args(argv)
    if extra:
        raise UsageError(f"unknown argument(s) {' '.join(extra)}")
    check_paths_args(parsed)
    return parsed


def _request(parsed):
    from ..core.process.blade_finish import PathRequest

    return PathRequest(parsed.axis_obj, parsed.cone1_obj, parsed.cone2_obj, **parsed.stages)


def _nc(parsed):
    if not (parsed.machine and parsed.post):
        return None, None, None
    from ..cli.nc import nc_options

    return parsed.machine, parsed.post, nc_options(parsed)


def _expand_blades(job: Job) -> list[Task]:
    from ..core.geometry.mesh_io import read_mesh
    from ..core.part.model import split_blisk_mesh
    from ..core.process.per_blade import blades_of_scan

    args = dict(job.args)
    if "mesh" not in args:
        raise JobsError(f"job {job.name!r}: blades needs mesh = the whole-blisk scan")
    V, F = read_mesh(args["mesh"])
    probe = _parse_paths(job, {k: v for k, v in args.items() if k != "collisions"})
    split = split_blisk_mesh(V, F, args.get("blade-count"), probe.axis_obj)
    n = split.blade_count
    if args.get("collisions", "avoid") != "off":
        args.setdefault("collisions", "avoid")
        args["blade-count"] = n
    parsed = _parse_paths(job, args)
    machine, post, nc = _nc(parsed)
    collision = parsed.collision if parsed.collision.mode != "off" else None
    blades = blades_of_scan(V, F, split, int(args.get("neighbours", 1)))
    req = _request(parsed)
    return [Task(job.name, f"{job.name}/blade-{b.index}", "blade",
                 {"blade": b, "request": req, "collision": collision, "machine": machine,
                  "post": post, "nc": nc, "blade_count": n}) for b in blades]


def _holder(point: dict, diameter: float) -> str | None:
    """The --holder profile of a holder length L (mm, tip to holder face): the shank (the
    tool's diameter) from the flute to L, the holder (``holder-diameter``, default 25 mm) for
    40 mm above it."""
    L = point.get("holder-length")
    if L is None:
        return None
    L = float(L)
    rh = 0.5 * float(point.get("holder-diameter", 25.0))
    flute = min(3.0 * diameter, L)
    r = 0.5 * diameter
    return f"{flute:g} {r:g} {L:g} {r:g} {L:g} {rh:g} {L + 40.0:g} {rh:g}"


def _expand_sweep(job: Job) -> list[Task]:
    from ..core.geometry.mesh_io import read_trimesh

    if "mesh" not in job.args:
        raise JobsError(f"job {job.name!r}: sweep needs mesh = the blade")
    mesh = read_trimesh(job.args["mesh"])  # a binary STL welded as it is read
    tasks = []
    for i, point in enumerate(sweep_points(job.args)):
        args = dict(point)
        args.setdefault("collisions", "check")
        if args["collisions"] == "off":
            raise JobsError(f"job {job.name!r}: a sweep checks collisions; drop collisions = "
                            "\"off\"")
        parsed0 = _parse_paths(job, {k: v for k, v in args.items() if k != "collisions"})
        holder = _holder(point, parsed0.stages.get("tool_diameter", 10.0))
        if holder is not None:
            args["holder"] = holder
        parsed = _parse_paths(job, args)
        machine, post, nc = _nc(parsed)
        shown = {k: point.get(k) for k in ("tool-diameter", "lead", "tilt", "holder-length")}
        from ..cli.paths import read_obstacles

        tasks.append(Task(job.name, f"{job.name}/{i}", "sweep",
                          {"mesh": mesh, "request": _request(parsed),
                           "collision": parsed.collision,
                           "obstacles": read_obstacles(parsed.obstacle),
                           "machine": machine, "post": post, "nc": nc, "point": shown}))
    return tasks


def assemble(job: Job, tasks: list[Task], results: dict) -> tuple[dict, dict]:
    """The job's files ({relative name: bytes}) and its summary row from its tasks' results
    (``results[task.key]`` a worker's answer, or ``{"error": text}`` when the task failed
    twice)."""
    if job.command == "blades":
        return _assemble_blades(job, tasks, results)
    if job.command == "sweep":
        return _assemble_sweep(job, tasks, results)
    r = results[tasks[0].key]
    if "error" in r:
        return {}, {"status": "failed", "detail": r["error"]}
    rec = r["record"]
    return dict(r["files"]), {"status": rec["status"], "detail": rec["detail"],
                              "seconds": rec.get("seconds")}


BLADE_COLUMNS = ("blade", "status", "poses", "length_mm", "max_material_left_mm",
                 "max_gouge_mm", "verdict", "colliding_before", "collisions_unresolved",
                 "detail")  # no wall times: the same inputs give the same bytes


def _assemble_blades(job, tasks, results):
    from ..core.process.per_blade import BladeOutcome, sections_program

    files, rows, outcomes = {}, [], []
    for t in tasks:
        r = results[t.key]
        k = t.payload["blade"].index
        if "error" in r:
            rows.append({"blade": k, "status": "failed", "detail": f"blade {k}: {r['error']}"})
            outcomes.append(BladeOutcome(k, False, f"blade {k}: {r['error']}"))
            continue
        files.update(r["files"])
        rows.append(dict(r["record"]))
        outcomes.append(r["value"])
    p = tasks[0].payload if tasks else {}
    status, detail = "ok", ""
    failed = [o.index for o in outcomes if not o.ok]
    if failed:
        status = "partial" if len(failed) < len(outcomes) else "failed"
        detail = f"blade(s) {', '.join(map(str, failed))} failed"
    if p.get("machine") and any(o.ok for o in outcomes):
        from ..core.post.export import get_post

        ext = ".apt" if get_post(p["post"]).NAME == "apt" else ".nc"
        name = job.args.get("nc") or f"{job.name}{ext}"
        try:
            text = sections_program(outcomes, p["machine"], p["post"], p["nc"],
                                    name=Path(job.args["mesh"]).stem)
            files[name] = text.encode()
        except BliskCamError as exc:
            status, detail = "failed", " ".join(str(exc).split())
    rows.sort(key=lambda r: r["blade"])
    files["blades.csv"] = table_csv(rows, BLADE_COLUMNS).encode()
    files["blades.md"] = table_markdown(rows, BLADE_COLUMNS).encode()
    seconds = sum(float(r.get("seconds") or 0.0) for r in rows)
    return files, {"status": status, "detail": detail, "seconds": round(seconds, 3)}


SWEEP_COLUMNS = ("tool-diameter", "lead", "tilt", "holder-length", "ok", "poses", "colliding",
                 "min_clearance_mm", "reachable", "status", "detail")


def _assemble_sweep(job, tasks, results):
    rows = []
    for t in tasks:
        r = results[t.key]
        if "error" in r:
            rows.append({**t.payload["point"], "status": "failed", "ok": False,
                         "detail": r["error"]})
        else:
            rows.append(dict(r["record"]))
    good = sum(1 for r in rows if r.get("ok"))
    files = {"sweep.csv": table_csv(rows, SWEEP_COLUMNS).encode(),
             "sweep.md": table_markdown(rows, SWEEP_COLUMNS).encode()}
    seconds = sum(float(r.get("seconds") or 0.0) for r in rows)
    return files, {"status": "ok", "seconds": round(seconds, 3),
                   "detail": f"{good} of {len(rows)} set-ups reach every pose without "
                   "collision"}
