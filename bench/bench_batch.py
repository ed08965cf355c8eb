"""Benchmark of the batch runs (blisk_cam/batch): per-blade paths of a scan-like whole blisk
of 8 blades (each blade offset along its normals by its own δ_k, tests/support/scan_blisk.py)
with 1 and 2 local Dask workers, and the same jobs against a scheduler this script starts on
the loopback (``dask scheduler`` and ``dask worker`` processes, as a user would run them).

Every run plans, checks collisions against the scanned neighbours, verifies and posts (APT)
all 8 blades; the outputs of each run are compared byte for byte with the first (they must
be identical). Printed: wall time per run, speed-up and parallel efficiency of 2 workers over
1 (efficiency = t1 / (2 · t2)), the load average (the machine may be shared: compare within
one run), the seconds of the blades' own work summed over the tasks.

Run: ``python bench/bench_batch.py [--blades 8] [--resolution 0.2] [--cusp 0.3]
[--no-scheduler] [--keep DIR]``; prints the figures as JSON (not a timed test).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from blisk_cam.batch.run import run_batch  # noqa: E402
from tests.support.mesh_files import write_binary_stl  # noqa: E402
from tests.support.scan_blisk import worn_blisk  # noqa: E402

JOBS = """
[[job]]
name = "scan"
command = "blades"
mesh = "scan.stl"
neighbours = 1
tool = "ball"
tool-diameter = 10
cusp = {cusp}
chord = 0.2
lead = 10
machine = "ac-trunnion"
post = "apt"
"""


def _files(folder: Path) -> dict:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file() and p.name not in ("summary.csv", "summary.md")}


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _dask_cli() -> list[str]:
    exe = Path(sys.executable).with_name("dask")
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "dask"]


def _timed(jobs, out, **kw) -> tuple[float, object]:
    t = time.perf_counter()
    rep = run_batch(jobs, out, stream=open(os.devnull, "w"), **kw)  # noqa: SIM115
    return time.perf_counter() - t, rep


def _scheduler_run(jobs, out, workers: int) -> tuple[float, object]:
    """Start ``dask scheduler`` and ``workers`` ``dask worker`` processes on 127.0.0.1, run
    the jobs through ``--scheduler``, stop the processes (by their own ids)."""
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH",
                                                                                  "")]))
    procs = [subprocess.Popen([*_dask_cli(), "scheduler", "--host", "127.0.0.1", "--port",
                               str(port), "--no-dashboard"], env=env,
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    try:
        for _ in range(workers):
            procs.append(subprocess.Popen(
                [*_dask_cli(), "worker", address, "--nthreads", "1", "--nworkers", "1",
                 "--no-dashboard", "--host", "127.0.0.1"], env=env,
                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        from distributed import Client

        t_start = time.perf_counter()
        with Client(address, timeout="60s") as client:
            client.wait_for_workers(workers, timeout=120)
            startup = time.perf_counter() - t_start
            wall, rep = _timed(jobs, out, client=client)
        return wall, rep, startup
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--blades", type=int, default=8)
    ap.add_argument("--resolution", type=float, default=0.2)
    ap.add_argument("--cusp", type=float, default=0.3)
    ap.add_argument("--no-scheduler", action="store_true")
    ap.add_argument("--keep", default=None, help="keep the runs in this folder")
    a = ap.parse_args(argv)
    work = Path(a.keep or tempfile.mkdtemp(prefix="bench_batch_"))
    work.mkdir(parents=True, exist_ok=True)
    import numpy as np

    V, F, _, _ = worn_blisk(a.blades, a.resolution,
                            offsets=0.03 + 0.02 * np.arange(a.blades))
    write_binary_stl(work / "scan.stl", V, F)
    (work / "JOBS.toml").write_text(JOBS.format(cusp=a.cusp))
    out = {"blades": a.blades, "scan_triangles": int(len(F)), "cpu_count": os.cpu_count(),
           "load_before": os.getloadavg()}
    runs = {}
    for name, kw in (("local_1_worker", {"workers": 1}), ("local_2_workers", {"workers": 2})):
        folder = work / name
        shutil.rmtree(folder, ignore_errors=True)
        wall, rep = _timed(work / "JOBS.toml", folder, **kw)
        runs[name] = (folder, rep)
        out[f"{name}_wall_s"] = round(wall, 2)
        out[f"{name}_task_seconds"] = rep.rows[0].get("seconds")
        out[f"{name}_status"] = rep.rows[0]["status"]
    t1, t2 = out["local_1_worker_wall_s"], out["local_2_workers_wall_s"]
    out["speedup_2_over_1"] = round(t1 / t2, 3)
    out["efficiency_2_workers"] = round(t1 / (2.0 * t2), 3)
    if not a.no_scheduler:
        folder = work / "scheduler_2_workers"
        shutil.rmtree(folder, ignore_errors=True)
        wall, rep, startup = _scheduler_run(work / "JOBS.toml", folder, 2)
        runs["scheduler_2_workers"] = (folder, rep)
        out["scheduler_2_workers_wall_s"] = round(wall, 2)
        out["scheduler_startup_s"] = round(startup, 2)
        out["scheduler_2_workers_status"] = rep.rows[0]["status"]
    ref = _files(runs["local_1_worker"][0])
    out["outputs_identical"] = {k: _files(f) == ref for k, (f, _) in runs.items()}
    out["load_after"] = os.getloadavg()
    print(json.dumps(out, indent=1))
    if not a.keep:
        shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
