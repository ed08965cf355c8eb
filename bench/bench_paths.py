"""Benchmark the LMC path generator; prints figures (no assertions).

    python bench/bench_paths.py [--triangles 1000000]

Figures: one-level slicing time on a ~1M-triangle mesh (goal ≤ 50 ms), LMC slicing of K levels
vs ``trimesh.intersections.mesh_multiplane`` for K planes on the same mesh (goal ratio ≤ 1.0),
the full path time on a ~1M-triangle blade (goal ≤ 5 s on the 2-core machine), and paper-scale
figures (curves, poses, time) for the demo blade at 100k and 1M triangles.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from blisk_cam.core.geometry.axis import Axis  # noqa: E402
from blisk_cam.core.geometry.mesh import TriMesh  # noqa: E402
from blisk_cam.core.part.cones import MorphingCones  # noqa: E402
from blisk_cam.core.paths.passes import generate_paths  # noqa: E402
from blisk_cam.core.paths.slicing import MeshConeSlicer  # noqa: E402
from tests.support.blades import subdivided_blade  # noqa: E402


def timeit(fn, repeat=5):
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def bench_mesh(name, V, F):
    """TriMesh.from_arrays on the welded mesh and on its STL-like soup (goal ≤ 1.5 s / 1.29M)."""
    t_w, mesh = timeit(lambda: TriMesh.from_arrays(V, F), repeat=3)
    soup = V[F].reshape(-1, 3)
    Fs = np.arange(len(soup)).reshape(-1, 3)
    t_s, m2 = timeit(lambda: TriMesh.from_arrays(soup, Fs), repeat=2)
    print(
        f"[{name}] TriMesh.from_arrays, {len(F):,} triangles: welded input {t_w:.2f} s "
        f"(goal ≤ 1.5 s), STL soup of {len(soup):,} corners {t_s:.2f} s "
        f"(welded {m2.welded_vertices:,}, flipped {m2.flipped_faces})"
    )
    return mesh


def bench_slicing(name, V, F, c1, c2, k_levels=50):
    t0 = time.perf_counter()
    mesh = TriMesh.from_arrays(V, F)
    t_mesh = time.perf_counter() - t0
    t0 = time.perf_counter()
    sl = MeshConeSlicer(mesh, Axis(), MorphingCones(c1, c2))
    _ = sl.slice(0.5)
    t_pre = time.perf_counter() - t0
    t_one, curves = timeit(lambda: sl.slice(0.5))
    print(f"[{name}] {mesh.n_faces:,} triangles: TriMesh {t_mesh:.2f} s, "
          f"slicer setup {t_pre:.2f} s")
    print(f"[{name}] one LMC level: {t_one * 1e3:.1f} ms "
          f"({sum(len(c) for c in curves)} points; goal ≤ 50 ms)")
    levels = np.linspace(0, 1, k_levels)
    t_lmc, _ = timeit(lambda: [sl.slice(s) for s in levels], repeat=2)
    try:
        import trimesh
        from trimesh.intersections import mesh_multiplane

        tm = trimesh.Trimesh(mesh.V, mesh.F, process=False)
        z5, z95 = np.percentile(mesh.V[:, 2], [5, 95])
        z = np.linspace(float(z5), float(z95), k_levels)
        _ = mesh_multiplane(tm, [0, 0, 0], [0, 0, 1], z[:2])  # warm caches (adjacency)
        t_tm, _ = timeit(lambda: mesh_multiplane(tm, [0, 0, 0], [0, 0, 1], z), repeat=2)
        print(
            f"[{name}] {k_levels} LMC levels (ordered polylines): {t_lmc:.3f} s; trimesh "
            f"mesh_multiplane {k_levels} planes (unordered segments): {t_tm:.3f} s; "
            f"ratio {t_lmc / t_tm:.2f} (goal ≤ 1.0)"
        )
    except ImportError:
        print(f"[{name}] {k_levels} LMC levels: {t_lmc:.3f} s "
              "(trimesh not installed: no comparison)")
    return mesh


def bench_full(name, mesh, c1, c2, chord, axis=None):
    t0 = time.perf_counter()
    p = generate_paths(mesh, axis or Axis(), c1, c2, tool_radius=6.0, cusp=0.05, chord=chord)
    dt = time.perf_counter() - t0
    mc = p.stats["measured_cusp"]
    print(
        f"[{name}] full path, 6 mm ball, h = 0.05, e = {chord}: {dt:.2f} s (goal ≤ 5 s at 1M), "
        f"{p.stats['passes']} passes, {len(p.curves)} curves, {p.n_poses} poses, measured cusp "
        f"min/max (w/o last) {min(mc[:-1]):.4f}/{max(mc):.4f} mm, "
        f"uncut poses {p.stats['uncut_poses']}"
    )
    return dt, p


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--triangles", type=int, default=1_000_000)
    args = ap.parse_args()
    V, F, c1, c2 = subdivided_blade("rotor37", args.triangles)
    bench_mesh("rotor37 subdivided", V, F)
    mesh = bench_slicing("rotor37 subdivided", V, F, c1, c2)
    for e in (0.05, 0.01):
        bench_full("rotor37 subdivided", mesh, c1, c2, e)
    from blisk_cam.core.part.blisk import make_demo_blisk

    table = []
    for res_tri in (100_000, args.triangles):
        d = _demo_at(make_demo_blisk, res_tri)
        m = bench_slicing(f"demo {res_tri:,}", d.blade_vertices, d.blade_faces, d.hub_cone,
                          d.tip_cone)
        dt, p = bench_full(f"demo {res_tri:,}", m, d.hub_cone, d.tip_cone, 0.05, axis=d.axis)
        table.append((m.n_faces, len(p.curves), p.n_poses, dt))
    print("\npaper-scale sanity (demo blade with its 8 mm fillet, 6 mm ball, h = e = 0.05 mm):")
    print(f"{'triangles':>12} {'curves':>7} {'points':>8} {'time s':>8}")
    for n, c, q, dt in table:
        print(f"{n:>12,} {c:>7} {q:>8} {dt:>8.2f}")


def _demo_at(make, triangles):
    """The demo blade with about ``triangles`` triangles (resolution ∝ sqrt(triangles))."""
    d = make(resolution=1.0)
    res = np.sqrt(triangles / len(d.blade_faces))
    return make(resolution=float(res))


if __name__ == "__main__":
    main()
