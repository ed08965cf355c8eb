"""The template's edge "gouges" (issue 24): after blade finishing, the stock's radial dexels
read empty 1–8 mm inside some leading/trailing-edge faces of the demo blisk. A real cut, or
the grid? Measured on a `process` output folder:

* the faces of the blade's edges whose deviation (:func:`blisk_cam.core.stock.deviation.
  deviation_map`, 8 mm inward) reads ≤ −1 mm, how many the verdicts judge
  (:func:`blisk_cam.core.stock.deviation.resolved_points`, issue #22; before it, the final
  verdict's "thick" test), and how many faces the part's own solid cast on the stock's own
  rays (no cut at all) reads ≤ −1 mm the same way;
* the exact swept ball of every program row of the operation (the ball centres' polyline,
  each segment sampled every 0.01 mm, closest points on the blade mesh): the deepest it goes
  into the blade, and how far those faces' centroids lie from it.

On the template (0.5 mm stock): 119 faces (0.8 mm²) read ≤ −1 mm (down to −8), none judged;
the part alone reads so on 301; the swept ball goes at most 0.012 mm into the blade (chord
0.02; 0.017 mm with the hub cone at 20 mm) and touches those centroids within 0.011 mm — the
grid, not a cut. With issue 22's resolution test (the part cast on the stock's own rays):
175 faces (1.2 mm²) read ≤ −1 mm, none judged; 95.4 % of the 33584 edge faces judged, the
worst of them reads −0.499 mm (tolerance 0.520).

Run: ``python bench/bench_job_edges.py DIR [NN-operation]`` (default 03-blade-finishing)
"""
import sys
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from blisk_cam.core.geometry.distance import MeshDistance
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.hub.channel import side_distance
from blisk_cam.core.process.job import build_part, job_template, load_job
from blisk_cam.core.process.job_verdict import _classes, face_frame
from blisk_cam.core.stock.blank import stock_from_allowance
from blisk_cam.core.stock.deviation import deviation_map, resolved_points, surface_distance
from blisk_cam.core.stock.dexels import RadialDexels
from blisk_cam.core.toolpath.paths_io import read_paths_json

out = Path(sys.argv[1])
stem = sys.argv[2] if len(sys.argv) > 2 else "03-blade-finishing"
job = load_job(job_template("tung-tso"))
part = build_part(job)
V, F, hub, C, N, area = face_frame(part)
cls, _, _ = _classes(part, C, N, hub, 8.24)
edge = np.flatnonzero(np.isin(cls, (4, 5)))
stock = RadialDexels.load(out / f"{stem}.stock.npz")
res = stock.resolution
dev = deviation_map(stock, C[edge], N[edge], reach_out=2.0, reach_in=8.0)
solid = stock_from_allowance(part, 0.0, res, grid=stock)
ideal = deviation_map(solid, C[edge], N[edge], reach_out=2.0, reach_in=8.0)
path = read_paths_json(out / f"{stem}.paths.json")
tol = path.chord + res
thick = resolved_points(solid, C[edge], N[edge], tol, surface_distance(V, F),
                        cut_depth=path.chord)
bad = dev <= -1.0
print(f"edge faces {len(edge)}, stock res {res}: dev<=-1 on {bad.sum()} faces "
      f"({area[edge][bad].sum():.1f} mm2), min dev {dev.min():.2f}; of those resolved "
      f"(judged, stock.deviation.resolved_points): {(bad & thick).sum()}; resolved edge faces "
      f"{thick.sum()} ({100 * thick.mean():.1f} %), worst judged dev "
      f"{dev[thick].min() if thick.any() else float('nan'):.3f} (tolerance {tol:.3f}); "
      f"ideal (the part on the stock's own rays) dev<=-1 on {(ideal <= -1).sum()}")
rho = float(path.tool.radius)
P = path.program
cen = P.tip + rho * P.axis
A, B = cen[:-1], cen[1:]
blade = MeshDistance(TriMesh.from_arrays(part.blade_vertices, part.blade_faces))
d_c = side_distance(blade.query(cen))
print(f"rows {len(cen)}, ball radius {rho}; centre-to-blade distance: median {np.median(d_c):.4f}"
      f" min {d_c.min():.4f} (rho - min = deepest pose gouge {rho - d_c.min():.4f} mm)")
Q = C[edge][bad]
# exact swept ball: segments within reach of the empty faces
mid = 0.5 * (A + B)
L = np.linalg.norm(B - A, axis=1)
near = np.unique(np.concatenate(cKDTree(mid).query_ball_point(Q, rho + 0.5 * L.max() + 3.0))
                 ).astype(int) if len(Q) else np.zeros(0, int)
print(f"segments near the empty edge faces: {len(near)} (longest segment {L.max():.2f} mm)")
dq = np.full(len(Q), np.inf)
for a in range(0, len(near), 200):
    k = near[a:a + 200]
    D = B[k] - A[k]
    t = np.clip(np.einsum("qkj,kj->qk", Q[:, None] - A[k][None], D) / np.maximum(
        np.einsum("kj,kj->k", D, D), 1e-300)[None], 0, 1)
    X = A[k][None] + t[..., None] * D[None]
    dq = np.minimum(dq, np.linalg.norm(Q[:, None] - X, axis=2).min(axis=1))
if len(Q):
    print(f"empty faces' centroids: distance to the swept ball surface min {(dq - rho).min():.3f} "
          f"median {np.median(dq - rho):.3f} mm (<0: the ball swept through the centroid)")
# deepest swept-ball gouge into the blade along the near segments, sampled every 0.01 mm
worst, wrow = -np.inf, -1
for j in near:
    n = max(2, int(np.ceil(L[j] / 0.01)) + 1)
    S = A[j] + np.linspace(0, 1, n)[:, None] * (B[j] - A[j])
    cp = blade.query(S)
    g = rho - side_distance(cp)
    if g.max() > worst:
        worst, wrow = float(g.max()), int(j + 1)
print(f"deepest swept-ball gouge into the blade along those segments: {worst:.4f} mm (row {wrow},"
      f" move {P.move[wrow] if wrow >= 0 else '-'})")
