"""Benchmark Blender object ↔ arrays in bulk (``blender.objects``) on about a million
triangles; prints figures (issue 28: the figure moved here from a timed test assertion).

    timeout 600 .venv/bpy45/bin/python bench/bench_bulk_arrays.py [--n 709] [--repeat 3]

A wavy n × n grid (n = 709: 1 002 528 triangles) becomes an object, then
``object_to_arrays`` runs ``--repeat`` times; the best and median wall seconds are printed
(the former test asked for ≤ 1 s on an idle machine).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402


def grid_mesh(n):
    x, y = np.meshgrid(np.arange(n, dtype=np.float64), np.arange(n, dtype=np.float64))
    V = np.stack([x.ravel(), y.ravel(), np.sin(0.1 * x.ravel())], axis=1)
    idx = np.arange(n * n).reshape(n, n)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    c, d = idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    return V, np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=709)
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args()
    from blisk_cam.blender import objects as blender_io

    V, F = grid_mesh(a.n)
    t = time.perf_counter()
    obj = blender_io.arrays_to_object("big", V, F)
    made = time.perf_counter() - t
    obj.location = (1.0, 2.0, 3.0)
    times = []
    for _ in range(a.repeat):
        t = time.perf_counter()
        V2, F2 = blender_io.object_to_arrays(obj)
        times.append(time.perf_counter() - t)
    assert len(F2) == len(F)
    print(f"{len(F):,} triangles: arrays_to_object {made:.2f} s; object_to_arrays best "
          f"{min(times):.2f} s, median {statistics.median(times):.2f} s ({a.repeat} runs)")


if __name__ == "__main__":
    main()
