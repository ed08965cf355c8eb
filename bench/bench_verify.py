"""Benchmark of blisk_cam.core.verify: a ~100k-triangle wavy surface of revolution and a
ball path of ~20k poses on it (passes on z-planes, CC points on the analytic surface), then a
bull-nose and a flat-mill path (lead 10°) on a 20k-triangle case, swept with the fast method
and — with ``--exact`` — with the exact one, printing both times and how far apart they are.

With ``--threads 1,2`` (the default) the ball path is verified once per thread count, each
with its wall and process-CPU seconds, the load average and the speed-up from the first
count to the last (the figures of every run must be the same).

Run: ``python bench/bench_verify.py [--triangles 100000] [--poses 20000] [--exact]
[--threads 1,2]``; prints the timings and the report summary as JSON.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from blisk_cam.core.geometry.axis import Axis  # noqa: E402
from blisk_cam.core.geometry.distance import MeshDistance  # noqa: E402
from blisk_cam.core.geometry.mesh import TriMesh  # noqa: E402
from blisk_cam.core.part.cones import Cone  # noqa: E402
from blisk_cam.core.tool.cutter import Cutter  # noqa: E402
from blisk_cam.core.toolpath.types import BallTool, PassCurve, ToolPath  # noqa: E402
from blisk_cam.core.verify.measure import verify_path  # noqa: E402

R, AMP, K, H = 40.0, 1.5, 5, 60.0


def surface(theta, z):
    """Points and unit normals of r = R + AMP sin(K θ) (1 + z / H) / 2 (a wavy drum)."""
    g = 0.5 * (1.0 + z / H)
    r = R + AMP * np.sin(K * theta) * g
    dr_dth = AMP * K * np.cos(K * theta) * g
    dr_dz = AMP * np.sin(K * theta) * 0.5 / H
    ct, st = np.cos(theta), np.sin(theta)
    p = np.stack([r * ct, r * st, z], axis=-1)
    # n ∝ e_r − (1/r) dr/dθ e_θ − dr/dz e_z
    n = np.stack([ct + dr_dth / r * st, st - dr_dth / r * ct, -dr_dz * np.ones_like(r)], axis=-1)
    return p, n / np.linalg.norm(n, axis=-1, keepdims=True)


def build(n_tri, n_poses, rho=6.0, n_levels=50):
    area = 2 * np.pi * R * H
    edge = np.sqrt(4 * area / (np.sqrt(3) * n_tri) * np.sqrt(3) / 2 * 2 / np.sqrt(3))
    nth = max(16, int(round(2 * np.pi * R / edge)))
    nz = max(3, int(round(n_tri / (2 * nth))) + 1)
    th = np.linspace(0, 2 * np.pi, nth, endpoint=False)
    zz = np.linspace(0, H, nz)
    T, Z = np.meshgrid(th, zz, indexing="ij")
    T = T + 0.5 * (th[1] - th[0]) * (np.arange(nz)[None, :] % 2)  # staggered rows
    V, _ = surface(T.ravel(), Z.ravel())
    idx = np.arange(nth * nz).reshape(nth, nz)
    a, b = idx[:, :-1], np.roll(idx, -1, axis=0)[:, :-1]
    c, d = np.roll(idx, -1, axis=0)[:, 1:], idx[:, 1:]
    F = np.vstack([np.stack([a, b, d], -1).reshape(-1, 3), np.stack([b, c, d], -1).reshape(-1, 3)])
    mesh = TriMesh.from_arrays(V, F)
    z0, z1 = 2.0, H - 2.0
    c1, c2 = Cone(0.0, z0, 200.0, z0), Cone(0.0, z1, 200.0, z1)
    per = max(3, n_poses // n_levels)
    curves = []
    for zl in np.linspace(z0, z1, n_levels):
        t = np.linspace(0, 2 * np.pi, per, endpoint=False)
        p, n = surface(t, np.full_like(t, zl))
        curves.append(PassCurve(s=(zl - z0) / (z1 - z0), closed=True, cc=p, normal=n, tip=p.copy(),
                                axis=n.copy(), face=np.full(per, -1)))
    w = (z1 - z0) / (n_levels - 1)
    h = rho - np.sqrt(rho * rho - w * w / 4)
    path = ToolPath(Axis(), c1, c2, BallTool(rho), float(h), 0.05, curves)
    return mesh, path


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--triangles", type=int, default=100_000)
    ap.add_argument("--poses", type=int, default=20_000)
    ap.add_argument("--levels", type=int, default=50, help="passes (fewer: larger cusp)")
    ap.add_argument("--spacing", type=float, default=None)
    ap.add_argument("--bull-triangles", type=int, default=20_000,
                    help="triangles of the bull-nose and flat lines' case (0: skip them)")
    ap.add_argument("--bull-poses", type=int, default=4_000)
    ap.add_argument("--exact", action="store_true",
                    help="also sweep the non-ball cutters with the exact (slow) method")
    ap.add_argument("--threads", default="1,2",
                    help="thread counts of the ball path's verify, e.g. 1,2 (speed-up printed)")
    args = ap.parse_args(argv)
    threads = [int(x) for x in args.threads.split(",")]
    mesh, path = build(args.triangles, args.poses, n_levels=args.levels)
    print(f"mesh: {mesh.n_faces} triangles, path: {path.n_poses} poses, "
          f"{len(path.curves)} passes, nominal cusp {path.cusp:.4f} mm")
    t = time.perf_counter()
    md = MeshDistance(mesh)
    tb = time.perf_counter() - t
    # query points within 8 mm of the surface (where a path's points are)
    rng = np.random.default_rng(0)
    q = mesh.V[rng.integers(0, mesh.n_vertices, 100_000)] + rng.uniform(-8, 8, (100_000, 3))
    t = time.perf_counter()
    md.query(q)
    tq = time.perf_counter() - t
    print(f"closest points: tree {tb:.2f} s, 100k queries within 8 mm {tq:.2f} s")
    runs = []
    for n in threads:
        t, c = time.perf_counter(), time.process_time()
        rep = verify_path(mesh, path, spacing=args.spacing, workers=n)
        runs.append((n, time.perf_counter() - t, time.process_time() - c, rep))
        print(f"verify_path, {n} thread(s): {runs[-1][1]:.2f} s wall, {runs[-1][2]:.2f} s CPU "
              f"(load {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores)")
    if len(runs) > 1:
        same = all(r.summary() | {"timings": 0} == runs[0][3].summary() | {"timings": 0}
                   for *_, r in runs)
        print(f"verify_path speed-up {runs[0][0]} -> {runs[-1][0]} threads: "
              f"x{runs[0][1] / runs[-1][1]:.2f} wall, CPU {runs[0][2]:.2f} -> {runs[-1][2]:.2f} s"
              + ("" if same else " (FIGURES DIFFER between thread counts)"))
    figures = {k: v for k, v in rep.summary().items() if not k.startswith("pair")}
    print(json.dumps(figures, indent=1))
    print("pair cusp min/max:", np.nanmin(rep.pair_cusp), np.nanmax(rep.pair_cusp))
    if args.bull_triangles > 0:
        # bull-nose R 6, r 2 and flat R 6, lead 10° along the feed, on a smaller case
        for cutter in (Cutter.bull(6.0, 2.0), Cutter.flat(6.0)):
            mesh, path = build(args.bull_triangles, args.bull_poses, n_levels=args.levels)
            lead = np.radians(10.0)
            for c in path.curves:
                feed = np.roll(c.cc, -1, axis=0) - np.roll(c.cc, 1, axis=0)
                feed -= np.einsum("ij,ij->i", feed, c.normal)[:, None] * c.normal
                feed /= np.linalg.norm(feed, axis=1)[:, None]
                c.axis = np.cos(lead) * c.normal + np.sin(lead) * feed
                c.tip = cutter.cl_points(c.cc, c.normal, c.axis)
            path.tool = cutter
            reps = {}
            for method in ("fast", "exact") if args.exact else ("fast",):
                t = time.perf_counter()
                reps[method] = rep = verify_path(mesh, path, spacing=args.spacing, method=method)
                print(f"verify_path {cutter.type} R6{' r2' if cutter.r else ''} lead 10° "
                      f"({mesh.n_faces} triangles, {path.n_poses} poses, {rep.n_samples} samples) "
                      f"method {method}: {time.perf_counter() - t:.2f} s")
                print(json.dumps({k: rep.summary()[k] for k in (
                    "max_material_left", "max_gouge", "max_cusp_normal", "cc_contact",
                    "timings")}, indent=1))
            if len(reps) == 2:
                fa, ex = reps["fast"], reps["exact"]
                keys = ("max_material_left", "max_gouge", "max_cusp", "max_cusp_normal")
                print("fast − exact:", {k: float(getattr(fa, k) - getattr(ex, k)) for k in keys},
                      "max |Δ| over samples:",
                      float(np.nanmax(np.abs(fa.sample_values - ex.sample_values))))


if __name__ == "__main__":
    main()
