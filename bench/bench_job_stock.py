"""Benchmark the stock simulation of a whole job: the five programs of the ``tung-tso``
template (roughing, semi-finishing, blade, hub and fillet finishing) run one after another on
one pitch sector of its blank, each with its tool-table body, as ``process`` does — issue
#22's goal ("a full five-stage program of one sector at 0.05 mm in ≤ 10 s"). Prints figures
(no assertions).

    python bench/bench_job_stock.py [--resolution 0.1 [0.05 ...]] [--from DIR]

``--from DIR``: the output of an earlier ``python -m blisk_cam process --template tung-tso
--out DIR`` (else the template is run first into a temporary directory, ~2–3 min). For each
resolution: per operation its rows, wall and CPU seconds (the removal and its deviation map)
and crash rows; then the whole: rows, wall, CPU, moves per second, peak resident memory, and
the backend that ran. The job itself simulates at its own ``[stock] resolution`` (0.5 mm in
the template): crashes thinner than half a cell are not seen there, and this bench shows
what a finer stock finds.
"""

from __future__ import annotations

import argparse
import dataclasses
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from blisk_cam.core.kernels.backend import backend_name
from blisk_cam.core.process.job import build_part, build_stock, load_job, make_cutter
from blisk_cam.core.process.operation_kinds import tool_assembly
from blisk_cam.core.runtime import parallel, run_to_end
from blisk_cam.core.stock.simulation import iter_simulate
from blisk_cam.core.toolpath.paths_io import read_paths_json


def _template(out: Path) -> None:
    t = time.perf_counter()
    subprocess.run([sys.executable, "-m", "blisk_cam", "process", "--template", "tung-tso",
                    "--out", str(out)], check=True, stdout=subprocess.DEVNULL)
    print(f"template run: {time.perf_counter() - t:.1f} s wall")


def _simulate(out: Path, res: float) -> None:
    job = dataclasses.replace(load_job(out / "job.toml"), resolution=res)
    part = build_part(job)
    stock = build_stock(job, part)
    files = sorted(out.glob("[0-9][0-9]-*.paths.json"))
    print(f"\nresolution {res:g} mm: {stock.n_theta} × {stock.n_z} rays, blank {job.blank}, "
          f"kernels: {backend_name()}")
    t0, c0 = time.perf_counter(), time.process_time()
    rows = crashes = 0
    for op, f in zip(job.operations, files, strict=True):
        path = read_paths_json(f)
        t, c = time.perf_counter(), time.process_time()
        with parallel(None):
            sim = run_to_end(iter_simulate(part, stock, [path],
                                           gouge_tolerance=job.gouge_tolerance,
                                           assembly=tool_assembly(op.tool, make_cutter(op.tool))))
        s = sim.summary
        rows += s["rows"]
        crashes += len(s["crashes"])
        where = ", ".join(f"row {x['row']} {x['kind']} {x['depth_mm']:.2f} mm"
                          for x in s["crashes"][:4])
        print(f"  {f.name:32s} {s['rows']:6d} rows  {time.perf_counter() - t:7.1f} s wall "
              f"{time.process_time() - c:7.1f} s CPU  crashes {len(s['crashes'])}"
              + (f" ({where})" if where else ""))
    wall = time.perf_counter() - t0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6
    print(f"  whole: {rows} rows, {wall:.1f} s wall, {time.process_time() - c0:.1f} s CPU, "
          f"{rows / wall:.0f} moves/s, peak {peak:.2f} GB, {crashes} crash rows "
          "(goal: ≤ 10 s at 0.05 mm)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--resolution", type=float, nargs="+", default=[0.1])
    ap.add_argument("--from", dest="src", default=None, metavar="DIR")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(a.src) if a.src else Path(tmp) / "job"
        if not a.src:
            _template(out)
        for res in a.resolution:
            _simulate(out, res)


if __name__ == "__main__":
    main()
