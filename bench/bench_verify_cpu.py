"""Benchmark verify against the plan in CPU seconds (issue 21's "verify ÷ plan" on a shared
machine); prints figures (no assertions).

    python bench/bench_verify_cpu.py [--tools bull,ball] [--repeat 2] [--backends compiled,numpy]

Rotor 37 as stored (20k triangles): the Ø12 R2 bull nose at lead 10° tilt 5° (and the Ø12
ball), cusp 0.05 mm, chord 0.01 mm, planned once per tool; then ``verify_path(workers=1)``
per backend, best of ``--repeat``, in process CPU seconds (on a shared machine CPU time
moves far less than wall time), with the plan's CPU seconds and the ratio, the stages' wall
seconds and the load. The last line per tool compares the backends' reports: the summary
and every per-sample array, naming the fields that differ.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import sys
import time
from dataclasses import fields, replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from blisk_cam.core.geometry.axis import Axis  # noqa: E402
from blisk_cam.core.geometry.mesh import TriMesh  # noqa: E402
from blisk_cam.core.kernels import backend  # noqa: E402
from blisk_cam.core.process.blade_finish import PathRequest, plan_paths  # noqa: E402
from blisk_cam.core.verify.measure import verify_path  # noqa: E402
from tests.support.blades import nasa_blade  # noqa: E402


def load():
    return f"load {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores"


def report_fields(rep):
    """The report's summary (without timings) and its arrays, for comparison."""
    s = rep.summary()
    s.pop("timings", None)
    out = {"summary": json.dumps(s, default=str, sort_keys=True)}
    for f in fields(rep):
        v = getattr(rep, f.name)
        if isinstance(v, np.ndarray):
            out[f.name] = v
    return out


def differing(a, b):
    names = []
    for k in sorted(set(a) | set(b)):
        x, y = a.get(k), b.get(k)
        if isinstance(x, str) or isinstance(y, str):
            if x != y:
                names.append(k)
        elif x is None or y is None or x.shape != y.shape or not np.array_equal(
                x, y, equal_nan=x.dtype.kind == "f"):
            names.append(k)
    return names


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tools", default="bull,ball")
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--backends", default="compiled,numpy")
    args = ap.parse_args()
    V, F, c1, c2 = nasa_blade("rotor37")
    mesh = TriMesh.from_arrays(V, F)
    base = PathRequest(axis=Axis(), cone1=c1, cone2=c2, tool_type="ball", tool_radius=6.0,
                       cusp=0.05, chord=0.01)
    for tool in args.tools.split(","):
        req = base if tool == "ball" else replace(
            base, tool_type="bull", corner_radius=2.0, lead=np.radians(10.0),
            tilt=np.radians(5.0))
        c0 = time.process_time()
        path = plan_paths(mesh, req).path
        plan = time.process_time() - c0
        print(f"[{tool}] plan {plan:.2f} s CPU, {path.n_poses:,} poses ({load()})", flush=True)
        reps = {}
        for bk in args.backends.split(","):
            best = np.inf
            for _ in range(max(args.repeat, 1)):
                with backend.numpy_only() if bk == "numpy" else contextlib.nullcontext():
                    c0 = time.process_time()
                    rep = verify_path(mesh, path, workers=1)
                    best = min(best, time.process_time() - c0)
            reps[bk] = report_fields(rep)
            steps = ", ".join(f"{k} {v:.2f}" for k, v in rep.timings.items() if k != "total")
            print(f"[{tool}, {bk}] verify {best:.2f} s CPU (1 thread, best of {args.repeat}); "
                  f"verify/plan {best / plan:.2f}; stages (wall) {steps} ({load()})",
                  flush=True)
        if len(reps) == 2:
            (a, ra), (b, rb) = reps.items()
            diff = differing(ra, rb)
            print(f"[{tool}] reports on {a} and {b}: "
                  + ("identical" if not diff else "differ in " + ", ".join(diff)), flush=True)


if __name__ == "__main__":
    main()
