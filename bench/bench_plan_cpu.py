"""Benchmark the planning of the paths pipeline in CPU seconds, per backend (issue 21); prints
figures (no assertions).

    python bench/bench_plan_cpu.py [--triangles 0] [--chord 0.05] [--repeat 3] [--threads 1]

Rotor 37 as stored (20k triangles, what the panel plans) or subdivided to ``--triangles``;
ball Ø12, cusp 0.05 mm. For each backend (compiled, numpy): the plan's process CPU time
(best of ``--repeat``; on a shared machine CPU time moves far less than wall time) and the
stages' wall seconds from the path's stats, then the sub-steps of the passes that the
compiled kernels took over — the scallop measurement (``expansion.measure_cusp``), its
distances to the ball-centre polylines and the slicing — timed by wrapping them, on one
thread only: with ``--threads`` 2 or more each trial's levels are sliced and measured on a
side thread while the main thread makes the next pass (``paths/trial_levels.py``), and the
process's CPU time of a wrapped call would count the other thread's work too. The paths of
the two backends must be the same floats: the line says so.

The process runs numpy's OpenBLAS on one thread, as ``python -m blisk_cam`` does
(``blisk_cam/cli/blas.py``): with a thread per core, OpenBLAS's spinning after each matrix
product took ~1.6 s of CPU of a 1M-triangle plan (3.7 s → 2.1 s for the passes on one
worker) that the command line never spends; ``OPENBLAS_NUM_THREADS`` set in the environment
wins, and the first line prints it.
"""

from __future__ import annotations

import argparse
import collections
import contextlib
import functools
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from blisk_cam.cli.blas import BLAS_THREADS_ENV, use_one_blas_thread  # noqa: E402

use_one_blas_thread()  # as `python -m blisk_cam` runs (before numpy loads OpenBLAS)

import numpy as np  # noqa: E402

from blisk_cam.core.geometry.axis import Axis  # noqa: E402
from blisk_cam.core.geometry.mesh import TriMesh  # noqa: E402
from blisk_cam.core.kernels import backend  # noqa: E402
from blisk_cam.core.paths import expansion, passes, slicing  # noqa: E402
from blisk_cam.core.process.blade_finish import PathRequest, plan_paths  # noqa: E402
from blisk_cam.core.runtime import parallel  # noqa: E402
from tests.support.blades import nasa_blade, subdivided_blade  # noqa: E402

SPENT = collections.Counter()


def _timed(owner, name, label):
    """Wrap ``owner.name`` so that its CPU seconds add up in ``SPENT[label]``."""
    fn = getattr(owner, name)

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        t0 = time.process_time()
        try:
            return fn(*args, **kwargs)
        finally:
            SPENT[label] += time.process_time() - t0

    setattr(owner, name, wrapper)


_timed(passes, "measure_cusp", "measure_cusp")
_timed(expansion.PolylineDistance, "__call__", "centre distances")
_timed(slicing.MeshConeSlicer, "slice", "slicing")


def plan_cpu(mesh, req, repeat, threads):
    """(best CPU s, its sub-steps, path)."""
    best = None
    for _ in range(repeat):
        SPENT.clear()
        m = TriMesh.from_arrays(mesh.V, mesh.F)  # fresh caches, as a new run has
        t0 = time.process_time()
        with parallel(threads):
            path = plan_paths(m, req).path
        cpu = time.process_time() - t0
        if best is None or cpu < best[0]:
            best = (cpu, dict(SPENT), path)
    return best


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--triangles", type=int, default=0, help="0: Rotor 37 as stored")
    ap.add_argument("--chord", type=float, default=0.05)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--threads", type=int, default=1)
    args = ap.parse_args()
    print(f"{BLAS_THREADS_ENV}={os.environ.get(BLAS_THREADS_ENV)}")
    if args.triangles:
        V, F, c1, c2 = subdivided_blade("rotor37", args.triangles)
    else:
        V, F, c1, c2 = nasa_blade("rotor37")
    mesh = TriMesh.from_arrays(V, F)
    req = PathRequest(axis=Axis(), cone1=c1, cone2=c2, tool_type="ball", tool_radius=6.0,
                      cusp=0.05, chord=args.chord)
    paths = {}
    for bk in ("compiled", "numpy"):
        if bk == "compiled" and backend.extension() is None:
            print("compiled kernels not installed: numpy only")
            continue
        with backend.numpy_only() if bk == "numpy" else contextlib.nullcontext():
            cpu, steps, path = plan_cpu(mesh, req, args.repeat, args.threads)
        paths[bk] = path
        st = path.stats
        stages = ", ".join(f"{k[8:]} {st[k]:.2f}" for k in
                           ("seconds_passes", "seconds_orient", "seconds_link") if k in st)
        sub = (", ".join(f"{k} {v:.2f}" for k, v in steps.items()) + " s" if args.threads == 1
               else "not split on 2+ threads (the trial levels run beside the pass)")
        print(f"[{bk}] {len(mesh.F):,} triangles, chord {args.chord}, {args.threads} thread(s): "
              f"plan {cpu:.2f} s CPU (best of {args.repeat}); stages wall {stages} s; passes' "
              f"sub-steps CPU {sub}; {path.n_poses:,} poses "
              f"(load {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores)", flush=True)
    if len(paths) == 2:
        a, b = paths["compiled"], paths["numpy"]
        same = len(a.curves) == len(b.curves) and all(
            np.array_equal(x.tip, y.tip) and np.array_equal(x.axis, y.axis)
            for x, y in zip(a.curves, b.curves, strict=True))
        print("compiled and numpy paths: " + ("the same floats" if same else "DIFFERENT"))


if __name__ == "__main__":
    main()
