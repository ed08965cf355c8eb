"""What a worker runs: one task of a job (:mod:`.jobs`), returning the files it made as bytes
(the client writes them, so the workers need no access to the output folder) and a record for
the summary. Plain functions of plain data (no dask here): the same call runs in a worker
process and, for a run one job after another, in this process.

Kinds of task:

* ``command`` — a single command (``paths``, ``nc``, ``simulate``) run as the user runs it,
  ``python -m blisk_cam <command> ...`` in a child process of the worker (the interpreter
  running the worker; this package's folder first on its path), its outputs in a private
  temporary folder;
* ``blade`` — one blade of a whole-blisk scan (:func:`..core.process.per_blade.plan_blade`);
* ``sweep`` — one set-up of a sweep: plan with the collision check, and with a machine the
  inverse kinematics: does it reach every pose without collision?
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from ..core.errors import BliskCamError
from ..core.process.blade_finish import plan_paths
from ..core.process.collision_stage import collision_stage
from ..core.process.per_blade import blade_blocks, plan_blade
from ..core.toolpath.paths_io import path_to_dict
from .jobs import Task

__all__ = ["execute", "deterministic_paths_json"]


def execute(task: Task) -> dict:
    """Run ``task``; returns ``{"files": {name: bytes}, "record": {...}, "value": ...}``.
    Never raises for the job's own trouble (bad input, a failing blade): that is in the
    record's ``status`` and ``detail``; a crash of the worker or a bug propagates (the batch
    retries the task once)."""
    t = time.perf_counter()
    run = {"command": _run_command, "blade": _run_blade, "sweep": _run_sweep}[task.kind]
    out = run(task.payload)
    out["record"]["seconds"] = round(time.perf_counter() - t, 3)
    return out


def deterministic_paths_json(path) -> bytes:
    """The paths JSON of ``path`` without its wall-time figures (the stats' ``seconds*``):
    the same plan gives the same bytes on any worker (the times go to the summary)."""
    import json

    d = path_to_dict(path)
    stats = d.get("stats") or {}
    for key in [k for k in stats if k.startswith("seconds")]:
        stats.pop(key)
    return json.dumps(d, allow_nan=False).encode()


def _run_command(p: dict) -> dict:
    root = str(Path(__file__).resolve().parents[2])  # the folder holding blisk_cam
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([root, *filter(None, [env.get("PYTHONPATH")])])
    package = __package__.split(".")[0]
    with tempfile.TemporaryDirectory(prefix="blisk_batch_") as tmp:
        argv = [a.replace("{OUT}", tmp) for a in p["argv"]]
        proc = subprocess.run([sys.executable, "-m", package, *argv], cwd=tmp, env=env,
                              stdin=subprocess.DEVNULL, capture_output=True, text=True)
        files = {}
        for f in sorted(Path(tmp).rglob("*")):
            if f.is_file():
                files[str(f.relative_to(tmp))] = f.read_bytes()
    status = proc.returncode
    if status < 0:  # killed by a signal: the worker's trouble, not the job's (retried)
        raise ChildProcessError(f"{package} {argv[0]} was killed by signal {-status}")
    err = " ".join(proc.stderr.split())
    ok = status == 0
    return {"files": files, "value": None,
            "record": {"status": "ok" if ok else f"failed (exit {status})",
                       "detail": "" if ok else err, "stdout": proc.stdout}}


def _run_blade(p: dict) -> dict:
    o = plan_blade(p["blade"], p["request"], p["collision"], verify=True,
                   machine=p.get("machine"), post=p.get("post"), nc=p.get("nc"))
    files = {}
    if o.path is not None:
        files[f"blade_{o.index}.json"] = deterministic_paths_json(o.path)
    o.path = _light(o.path)
    return {"files": files, "value": o,
            "record": {"status": "ok" if o.ok else "failed", "detail": o.reason or "",
                       **o.figures}}


def _light(path):
    """The path without its passes (the program of the NC sections only needs the tool and
    tolerances of one path): less to send back from the worker."""
    if path is None:
        return None
    import dataclasses

    return dataclasses.replace(path, curves=[], program=None)


def _run_sweep(p: dict) -> dict:
    """One set-up: plan with the collision check (mode "check": nothing corrected), and
    with a machine the blocks. ``ok`` = every pose clear and reachable."""
    rec = dict(p["point"])
    try:
        extra = (collision_stage(p["collision"], p.get("obstacles", ())),)
        plan = plan_paths(p["mesh"], p["request"], extra=extra)
    except BliskCamError as exc:
        rec.update(status="failed", detail=" ".join(str(exc).split()), ok=False)
        return {"files": {}, "value": None, "record": rec}
    s = plan.path.collision or {}
    n_bad = int(plan.collision.n_unresolved) if plan.collision is not None else 0
    rec.update(poses=int(plan.path.n_poses), colliding=n_bad,
               min_clearance_mm=_round(s.get("min_clearance")))
    reach = ""
    if p.get("machine") and n_bad == 0:
        try:
            blade_blocks(plan.path, p["machine"], p.get("post") or "apt", p.get("nc"), 0)
        except BliskCamError as exc:
            reach = " ".join(str(exc).split())
    rec.update(reachable=(reach == "") if p.get("machine") else None, ok=n_bad == 0 and not reach,
               status="ok", detail=reach)
    return {"files": {}, "value": None, "record": rec}


def _round(x):
    return None if x is None else round(float(x), 6)


