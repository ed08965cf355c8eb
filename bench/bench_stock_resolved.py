"""Where the stock verdicts judge gouges (issue #22): the share of the demo blisk's surface
vertices the deviation map resolves at a coarse stock, by the test the verdicts use
(:func:`blisk_cam.core.stock.deviation.resolved_points`: the part cast on the stock's own rays
holds the map's samples at the tolerance's depth) and by the test it replaced (the final
verdict's "thick" test: the part, cast on a grid of its own, holds a disc of one cell's
radius across θ and z 1.5 cells below the point).

The stock is the template's blank (``envelope:2``) at the resolution given (default 0.5 mm);
the tolerance is blade finishing's chord (0.02 mm) plus the resolution, as the template's
verdicts use. Prints, for the blade's vertices and the hub's outer ones: how many, the share
resolved by each test, and the area (mm²) not judged.

Measured (0.5 mm, 118 × 167 rays, the loaded 2-core machine): blade 50400 vertices, 7089 mm²:
98.2 % resolved by the ray test (20 mm² not judged), 55.7 % by the disc test (1161 mm²); the
hub's outer 1347 vertices: 100 % (0 mm²) against 95.8 % (61 mm²).

Run: ``PYTHONPATH=. python bench/bench_stock_resolved.py [RES_MM]``
"""
import sys

import numpy as np

from blisk_cam.core.part.model import theta_about
from blisk_cam.core.process.job import build_part, job_template, load_job
from blisk_cam.core.stock.blank import stock_from_allowance, stock_from_envelope
from blisk_cam.core.stock.deviation import resolved_points, surface_distance, vertex_areas
from blisk_cam.core.stock.simulation import part_surface

res = float(sys.argv[1]) if len(sys.argv) > 1 else 0.5
tol = 0.02 + res
part = build_part(load_job(job_template("tung-tso")))
stock = stock_from_envelope(part, 2.0, res)
solid = stock_from_allowance(part, 0.0, res, grid=stock)
V, F, N, surface = part_surface(part, res, solid=solid)
_, _, hub = part.part_mesh()
on_blade = np.zeros(len(V), bool)
on_blade[np.unique(F[~hub])] = True
area = vertex_areas(V, F)

new = resolved_points(solid, V, N, tol, surface_distance(V, F[surface[F].any(axis=1)]),
                      cut_depth=0.02)
# the replaced test (core/process/job_verdict._thick before): its own grid, a disc across θ, z
own = stock_from_allowance(part, 0.0, res)
P = V - 1.5 * res * N
_, th, _ = theta_about(P, part.axis)
e1, e2, d = part.axis.angular_frame()
tang = -np.sin(th)[:, None] * e1 + np.cos(th)[:, None] * e2
old = own.occupied(P) & own.occupied(V - 0.5 * res * N)
for e in (tang, np.broadcast_to(d, P.shape)):
    old &= own.occupied(P + res * e) & own.occupied(P - res * e)

print(f"stock {res} mm ({stock.n_theta} x {stock.n_z} rays), tolerance {tol:.3f} mm")
for name, sel in (("blade", surface & on_blade), ("hub (outer)", surface & ~on_blade)):
    n = int(sel.sum())
    print(f"{name}: {n} vertices, {area[sel].sum():.0f} mm2; resolved: "
          f"{100 * new[sel].mean():.1f} % by the ray test ({area[sel & ~new].sum():.0f} mm2 not "
          f"judged), {100 * old[sel].mean():.1f} % by the disc test "
          f"({area[sel & ~old].sum():.0f} mm2)")
