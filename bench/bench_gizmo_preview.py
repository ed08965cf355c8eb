"""Benchmark the cone gizmos' live LMC preview; prints figures (no assertions), no drawing.

    python bench/bench_gizmo_preview.py [--resolution 3.17] [--steps 20] [--no-blender]

On the demo blade (resolution 3.17 ≈ 1M triangles): the one-off mesh preparation when the
preview starts (TriMesh weld/orient, edges, normals; with bpy also reading the blade from a
Blender object), then a simulated drag of P1 (``--steps`` positions 0.2 mm apart), each step
as the gizmo does it: a new slicer for the new cone pair (morph field) and one slice per
preview level. Goal: ≤ 50 ms per curve (slicer set-up shared among the levels) and the draw
geometry (cone wires, preview line segments) in well under a millisecond per cone.
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

from blisk_cam.core.demo import make_demo_blisk  # noqa: E402
from blisk_cam.gizmos import cone_frame as cf  # noqa: E402
from blisk_cam.gizmos.lmc_preview import DEFAULT_LEVELS, LmcPreview  # noqa: E402


def ms(x):
    return f"{1e3 * x:7.1f} ms"


def blender_read_seconds(V, F):
    """Seconds to read the blade back from a Blender object (object_to_arrays), or None."""
    try:
        import bpy  # noqa: F401

        from blisk_cam import blender_io
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

    preview = LmcPreview()
    first = preview.compute("demo", lambda: (V, F), demo.axis, c1, c2)
    assert first.error is None, first.error
    print(f"mesh preparation (once per blade revision): {ms(first.mesh_seconds)}")
    print(
        f"first preview: set-up {ms(first.setup_seconds)}, levels "
        f"{ms(sum(first.level_seconds))}, {len(first.curves)} curves"
    )

    setups, levels, per_curve, steps = [], [], [], []
    for k in range(1, args.steps + 1):
        moved = [c1[0] + 0.2 * k, *c1[1:]]
        t0 = time.perf_counter()
        res = preview.compute("demo", lambda: (V, F), demo.axis, moved, c2)
        steps.append(time.perf_counter() - t0)
        assert res.error is None and res.mesh_seconds == 0.0
        setups.append(res.setup_seconds)
        levels.extend(res.level_seconds)
        per_curve.append(res.seconds_per_curve)
    print(f"drag of P1, {args.steps} steps (mesh cached):")
    for label, xs in (("slicer set-up per step", setups), ("one level (slice)", levels)):
        print(f"  {label:24s}median {ms(statistics.median(xs))}  max {ms(max(xs))}")
    print(
        f"  per curve (set-up/{len(DEFAULT_LEVELS)} + slice) median "
        f"{ms(statistics.median(per_curve))}  max {ms(max(per_curve))}   (budget 50 ms)"
    )
    print(f"  whole step              median {ms(statistics.median(steps))}  max {ms(max(steps))}")

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
