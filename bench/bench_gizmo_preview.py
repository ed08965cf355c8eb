"""Benchmark the cone gizmos' live LMC preview; prints figures (no assertions), no drawing.

    python bench/bench_gizmo_preview.py [--resolution 3.17] [--steps 20] [--no-blender]

On the demo blade (resolution 3.17 ≈ 1M triangles): the one-off mesh preparation when the
preview starts (TriMesh weld/orient, edges, normals, the meridional index; with bpy also
reading the blade from a Blender object), then a simulated drag of P1 (``--steps`` positions
0.2 mm apart), each step as the gizmo does it: a slicer for the new cone pair and one slice per
preview level — first with the slicer over the whole mesh (as before the meridional index),
then on the faces near the levels (``LmcPreview``'s default); p50/p95 per step. Goal: ≤ 50 ms
per step, slicer set-up included, and the draw geometry (cone wires, preview line segments)
in well under a millisecond per cone.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from blisk_cam.core.part.blisk import make_demo_blisk  # noqa: E402
from blisk_cam.gizmos import cone_frame as cf  # noqa: E402
from blisk_cam.gizmos.lmc_preview import DEFAULT_LEVELS, LmcPreview  # noqa: E402


def ms(x):
    return f"{1e3 * x:7.1f} ms"


def p(xs, q):
    """The q-th percentile of xs."""
    return float(np.percentile(np.asarray(xs, dtype=np.float64), q))


def blender_read_seconds(V, F):
    """Seconds to read the blade back from a Blender object (object_to_arrays), or None."""
    try:
        import bpy  # noqa: F401

        from blisk_cam.blender import objects as blender_io
    except ImportError:
        return None
    obj = blender_io.arrays_to_object("BenchBlade", V, F)
    best = np.inf
    for _ in range(3):
        t0 = time.perf_counter()
        blender_io.object_to_arrays(obj)
        best = min(best, time.perf_counter() - t0)
    return best


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--resolution", type=float, default=3.17)
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--no-blender", action="store_true", help="skip the bpy read figure")
    args = ap.parse_args()

    demo = make_demo_blisk(resolution=args.resolution)
    V, F = demo.blade_vertices, demo.blade_faces
    c1, c2 = demo.hub_cone.as_list(), demo.tip_cone.as_list()
    print(f"demo blade: {len(F):,} triangles, {len(V):,} vertices; levels {len(DEFAULT_LEVELS)}")

    if not args.no_blender:
        t = blender_read_seconds(V, F)
        if t is not None:
            print(f"read blade from Blender (object_to_arrays, best of 3): {ms(t)}")

    # the two ways side by side, their steps interleaved (the machine's load hits both alike)
    modes = {"before": LmcPreview(indexed=False), "now": LmcPreview(indexed=True)}
    labels = {"before": "whole mesh: a slicer over every face per step (before)",
              "now": "indexed: a slicer on the faces near the levels only (now)"}
    for name, preview in modes.items():
        first = preview.compute("demo", lambda: (V, F), demo.axis, c1, c2)
        assert first.error is None, first.error
        print(f"{name}: set-up once per blade revision (TriMesh weld/orient, edges, normals"
              f"{', meridional index' if preview.indexed else ''}): {ms(first.mesh_seconds)}; "
              f"first preview: set-up {ms(first.setup_seconds)}, levels "
              f"{ms(sum(first.level_seconds))}, {len(first.curves)} curves")
    rec = {name: {"setup": [], "level": [], "curve": [], "step": [], "faces": []}
           for name in modes}
    res = {}
    for k in range(1, args.steps + 1):
        moved = [c1[0] + 0.2 * k, *c1[1:]]
        for name, preview in modes.items():
            t0 = time.perf_counter()
            r = preview.compute("demo", lambda: (V, F), demo.axis, moved, c2)
            step = time.perf_counter() - t0
            assert r.error is None and r.mesh_seconds == 0.0
            x = rec[name]
            x["step"].append(step)
            x["setup"].append(r.setup_seconds)
            x["level"].extend(r.level_seconds)
            x["curve"].append(r.seconds_per_curve)
            x["faces"].append(r.faces_sliced)
            res[name] = r
    same = all(np.array_equal(a.points, b.points) for a, b in
               zip(res["before"].curves, res["now"].curves, strict=True))
    print(f"drag of P1, {args.steps} steps 0.2 mm apart (mesh cached), both ways interleaved; "
          f"last step's curves identical: {same}")
    for name in modes:
        x = rec[name]
        print(f"-- {labels[name]}; faces sliced per step median "
              f"{int(statistics.median(x['faces'])):,} of {len(F):,}")
        for label, xs in (("slicer set-up per step", x["setup"]),
                          ("one level (slice)", x["level"]),
                          (f"per curve (set-up/{len(DEFAULT_LEVELS)} + slice)", x["curve"]),
                          ("whole step", x["step"])):
            print(f"    {label:32s}p50 {ms(p(xs, 50))}  p95 {ms(p(xs, 95))}  max {ms(max(xs))}")
    b, n = rec["before"]["step"], rec["now"]["step"]
    print(f"whole step p50 {ms(p(b, 50))} → {ms(p(n, 50))} ({p(b, 50) / p(n, 50):.1f}×), "
          f"p95 {ms(p(b, 95))} → {ms(p(n, 95))}; budget 50 ms")
    res = res["now"]

    plane = cf.MeridionalPlane(demo.axis, 0.0, 1.0)
    t0 = time.perf_counter()
    for _ in range(100):
        cf.cone_wire_lines(plane, c1)
    t_wire = (time.perf_counter() - t0) / 100
    t0 = time.perf_counter()
    n_seg = sum(len(cf.polyline_lines(c.points, c.closed)) for c in res.curves) // 2
    t_poly = time.perf_counter() - t0
    print(f"draw geometry: cone wire {ms(t_wire)}; preview segments {n_seg:,} in {ms(t_poly)}")


if __name__ == "__main__":
    main()
